"""``python -m baselines.train``: the training CLI of :mod:`baselines.rl.train`."""

from baselines.rl.train import build_parser, default_hyperparameters, main, train

__all__ = ["build_parser", "default_hyperparameters", "main", "train"]

if __name__ == "__main__":
    raise SystemExit(main())
