"""``python -m baselines.train``: the training CLI of :mod:`baselines.rl.train`."""

from baselines.rl.train import Training, build_parser, default_hyperparameters, main, train, train_seeds

__all__ = ["Training", "build_parser", "default_hyperparameters", "main", "train", "train_seeds"]

if __name__ == "__main__":
    raise SystemExit(main())
