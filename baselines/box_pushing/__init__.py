"""BoxPushing-v0 baselines: paper 004's situated behaviour sets (recognizer, behaviours, oracle diagnostic)."""
