"""Rendezvous of two robots on a graph map (paper 003): planners and the meeting place.

:mod:`baselines.rendezvous.search` holds the planners of section 4 as pure graph algorithms
(unidirectional A*, the paper's distributed bidirectional A*, an optimal bidirectional A*, the
centralized Dijkstra reference) and the "meet as soon as possible" place of section 3.
"""
