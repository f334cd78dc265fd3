"""Environments: one module per task on the shared simulator core."""
