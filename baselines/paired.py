"""Two evaluations on the same seeds, compared episode by episode: is B faster (or better) than A?

Command line::

    python -m baselines.paired A B [--metric TT3] [--json OUT]

``A`` and ``B`` are ``baselines.evaluate`` output directories (or their ``episodes.csv``). Episodes are
paired by seed; a pair counts when both episodes report the metric (``TT3`` of an episode that did not
finish is empty, so failed episodes drop out, and their number is reported per side). Printed (and, with
``--json``, written): the number of pairs, both means, the mean difference ``B − A`` with its 95 %
normal interval (1.96 standard errors of the differences) and a 95 % percentile bootstrap interval
(10,000 resamples of the pairs, fixed seed), how often B is lower, higher or equal, and the exact
two-sided sign test p-value over the pairs that differ. Two policies on the same seeds meet the same
targets and starts, so the paired interval is narrower than the difference of two per-policy intervals.

Errors (a missing or unreadable file, a metric neither file has, no common seed) are one
``error: ...`` line with exit code 2, before anything is computed.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["compare_paired", "main", "read_metric"]

BOOTSTRAP_RESAMPLES = 10_000


def read_metric(path: str | Path, metric: str) -> dict[int, float | None]:
    """Seed -> the episode's ``metric`` (None where the episode does not report it) from an ``episodes.csv``.

    ``path`` is the CSV or the directory holding it. ``ValueError`` naming the file for a missing file,
    a file without ``seed`` or ``metric`` columns, or a value that is not a number."""
    path = Path(path)
    file = path / "episodes.csv" if path.is_dir() else path
    if not file.is_file():
        raise ValueError(f"no episodes.csv at {str(path)!r} (an output directory of python -m baselines.evaluate)")
    with file.open(newline="") as handle:
        reader = csv.DictReader(handle)
        columns = reader.fieldnames or []
        if "seed" not in columns or metric not in columns:
            known = ", ".join(c for c in columns if c not in ("episode", "seed")) or "none"
            raise ValueError(f"{str(file)!r} has no {'seed' if 'seed' not in columns else metric!r} column; its metrics: {known}")
        values: dict[int, float | None] = {}
        for row in reader:
            try:
                seed, text = int(row["seed"]), (row[metric] or "").strip()
                value = float(text) if text else None
            except ValueError:
                raise ValueError(f"{str(file)!r}: {metric} {row[metric]!r} of seed {row['seed']!r} is not a number") from None
            values[seed] = value if value is not None and math.isfinite(value) else None
    return values


def _sign_test(lower: int, higher: int) -> float:
    """Exact two-sided binomial (p = 1/2) p-value of ``lower`` against ``higher``."""
    n = lower + higher
    if n == 0:
        return 1.0
    k = min(lower, higher)
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2.0**n
    return min(1.0, 2.0 * tail)


def compare_paired(a: Mapping[int, float | None], b: Mapping[int, float | None]) -> dict[str, Any]:
    """The paired comparison of the module docstring over the seeds both report; ``ValueError`` if none."""
    common = sorted(set(a) & set(b))
    if not common:
        raise ValueError("the two evaluations share no seed (run both with the same --seed and --episodes)")
    pairs = [(a[s], b[s]) for s in common if a[s] is not None and b[s] is not None]
    missing_a = sum(1 for s in common if a[s] is None)
    missing_b = sum(1 for s in common if b[s] is None)
    result: dict[str, Any] = {"common_seeds": len(common), "pairs": len(pairs), "missing_a": missing_a, "missing_b": missing_b}
    if not pairs:
        return {**result, "mean_a": math.nan, "mean_b": math.nan, "mean_difference": math.nan}
    x, y = (np.array(side, dtype=float) for side in zip(*pairs))
    d = y - x
    half = 1.96 * float(np.std(d, ddof=1)) / math.sqrt(d.size) if d.size > 1 else math.nan
    rng = np.random.default_rng(0)
    boots = d[rng.integers(0, d.size, size=(BOOTSTRAP_RESAMPLES, d.size))].mean(axis=1)
    lower, higher = int(np.sum(d < 0)), int(np.sum(d > 0))
    return {
        **result,
        "mean_a": float(x.mean()),
        "mean_b": float(y.mean()),
        "mean_difference": float(d.mean()),
        "ci95_normal": [float(d.mean() - half), float(d.mean() + half)],
        "ci95_bootstrap": [float(np.percentile(boots, 2.5)), float(np.percentile(boots, 97.5))],
        "b_lower": lower,
        "b_higher": higher,
        "ties": int(d.size - lower - higher),
        "sign_test_p": _sign_test(lower, higher),
    }


def text(record: Mapping[str, Any], metric: str, names: Sequence[str] = ("A", "B")) -> str:
    """The comparison in a few lines."""
    a, b = names
    lines = [
        f"{metric}: {record['pairs']} pairs of {record['common_seeds']} common seeds "
        f"(no value: {record['missing_a']} of {a}, {record['missing_b']} of {b})"
    ]
    if record["pairs"]:
        normal, boot = record["ci95_normal"], record["ci95_bootstrap"]
        lines += [
            f"mean {a} {record['mean_a']:.3f}, {b} {record['mean_b']:.3f}; {b} − {a} {record['mean_difference']:+.3f}"
            f", 95 % [{normal[0]:+.3f}, {normal[1]:+.3f}] (normal), [{boot[0]:+.3f}, {boot[1]:+.3f}] (bootstrap)",
            f"{b} lower in {record['b_lower']}, higher in {record['b_higher']}, equal in {record['ties']}"
            f"; sign test p = {record['sign_test_p']:.3g}",
        ]
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m baselines.paired`` parser (usage errors: one line, exit 2)."""
    from baselines.cli import Parser, nonblank

    parser = Parser(prog="python -m baselines.paired", description=__doc__.splitlines()[0])
    parser.add_argument(
        "a",
        type=nonblank("an evaluation directory"),
        help="evaluation A: a baselines.evaluate --out directory or its episodes.csv",
    )
    parser.add_argument("b", type=nonblank("an evaluation directory"), help="evaluation B, on the same seeds")
    parser.add_argument("--metric", type=nonblank("a metric"), default="TT3", help="an episodes.csv column (default: TT3)")
    parser.add_argument("--json", type=nonblank("a path"), default=None, help="also write the record as JSON here")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI: 0 on success, 2 with one ``error:`` line for bad input."""
    from baselines.cli import check_out, guarded, message, parse_args

    args = parse_args(build_parser(), argv)
    if isinstance(args, int):
        return args
    try:
        if args.json is not None:
            check_out(Path(args.json), "--json", file=True)
        record = compare_paired(read_metric(args.a, args.metric), read_metric(args.b, args.metric))
    except ValueError as error:
        print(f"error: {message(error)}", file=sys.stderr)
        return 2

    def report() -> int:
        print(text(record, args.metric))
        if args.json is not None:
            Path(args.json).write_text(json.dumps({"a": args.a, "b": args.b, "metric": args.metric, **record}, indent=2) + "\n")
        return 0

    return guarded(report)


if __name__ == "__main__":
    sys.exit(main())
