"""Navigation-v0 baselines: go-to-goal and paper 001's non-cooperative game with the fair arbiter."""
