"""``python -m baselines [evaluate|train] ...``: the evaluation (default) and training CLIs."""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    """Dispatch to ``baselines.train`` or ``baselines.evaluate`` (the default)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "train":
        from baselines.train import main as train_main

        return train_main(argv[1:])
    if argv and argv[0] == "evaluate":
        argv = argv[1:]
    from baselines.evaluate import main as evaluate_main

    return evaluate_main(argv)


if __name__ == "__main__":
    sys.exit(main())
