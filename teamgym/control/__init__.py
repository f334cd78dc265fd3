"""Controllers that environments offer as action types."""

from teamgym.control.heading import HeadingHeuristic

__all__ = ["HeadingHeuristic"]
