"""Reproduce section 5 of paper 002 (DMAPS) on ``Foraging-v0`` and go past it.

    python experiments/paper002_foraging.py all --out results/paper002 [--games 2000] [--workers 2]
    python experiments/paper002_foraging.py consume --radio rate --consumed persist --games 400 --key-games 2000

Subcommands (each writes ``<sweep>.json``, ``<sweep>.md`` and ``<sweep>.png`` into ``--out``):

* ``consume`` (section 5.1, Figs. 6-8): 2 robots, 3 targets; for ``comm_throughput`` in
  :data:`THROUGHPUTS`: success %, TL, TT1-TT3 over ``--games`` games.
* ``surround`` (section 5.2, Figs. 8-9): 2 robots, 1 target: success %, TL, TG, DG.
* ``search`` (section 5.2's "about 25 s for one robot to search the whole field"): one robot
  running DMAPS's search behaviour only (``search_only``); the time until its camera has
  covered 90 % and 100 % of the cells (true poses), over at most 100 games cut at 60 s.
* ``robots``: the consume and surround sweeps with 4 and 8 robots (surround keeps
  ``robots_per_target`` = 2).
* ``large``: both sweeps on a field four times larger (6.0 m × 4.8 m).
* ``all``: every sweep above.

The radio axis (``--radio``): ``throughput`` (default) sweeps ``comm_throughput`` over
:data:`THROUGHPUTS` with a packet every control step (10 per s: throughput 0.25 already
delivers 2.5 packets/s); ``rate`` sweeps ``packet_rate`` over :data:`RATES` packets per second
with ``comm_throughput`` 1 (a graded axis, files ``<sweep>-rate.*``). ``--consumed persist``
keeps consumed targets in the world and the cameras (``consumed_targets``; files
``<sweep>-persist*``): a robot learns of a teammate's consumption only by radio.
``--key-games`` sets the games at the axis's two ends (no radio, full radio), ``--games``
those in between.
* ``report``: the tables of the sweeps found in ``--out`` and the paper's trends checked
  (differences between no and full communication against their 95 % intervals); redraws
  every sweep's plot from its JSON.

Times are means over the successful games (as in section 4.5) with 95 % confidence intervals
(1.96 standard errors); success rates carry Wilson 95 % intervals. Games use seeds
``--first-seed`` .. ``--first-seed + games - 1`` (the same seeds for every throughput) and run
in ``--workers`` processes through :func:`baselines.evaluate.evaluate`, so the numbers do not
depend on the worker count.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

import teamgym
from baselines.cli import Parser, message, nonblank
from baselines.episode import Step, run_episode
from baselines.evaluate import evaluate
from baselines.registry import make_policy, required_config
from baselines.stats import mean_ci, wilson
from baselines.summary import markdown_table

THROUGHPUTS = (0.0, 0.25, 0.5, 0.75, 1.0)
#: Packets per second per robot of ``--radio rate`` (10 = one every control step, the default radio).
RATES = (0.0, 0.1, 0.2, 0.5, 1.0, 2.0, 10.0)
#: ``--radio`` -> (config key swept, its values, the other radio settings, axis label).
RADIO_AXES = {
    "throughput": ("comm_throughput", THROUGHPUTS, {}, "communication throughput (packet every 0.1 s)"),
    "rate": ("packet_rate", RATES, {"comm_throughput": 1.0}, "packets per second per robot"),
}
#: Sweeps: name -> (Foraging-v0 config, metrics reported).
CONSUME = {"task": "consume", "n_robots": 2, "n_targets": 3}
SURROUND = {"task": "surround", "n_robots": 2, "n_targets": 1, "robots_per_target": 2}
LARGE_FIELD = {"field_size": (6.0, 4.8)}
CONSUME_METRICS = ("TL", "TT1", "TT2", "TT3", "DG")
SURROUND_METRICS = ("TL", "TG", "DG")


def sweeps(name: str) -> dict[str, tuple[dict[str, Any], tuple[str, ...]]]:
    """The throughput sweeps of subcommand ``name``: sweep id -> (config, metrics)."""
    if name == "consume":
        return {"consume": (CONSUME, CONSUME_METRICS)}
    if name == "surround":
        return {"surround": (SURROUND, SURROUND_METRICS)}
    if name == "robots":
        out = {}
        for n in (4, 8):
            out[f"consume-{n}robots"] = ({**CONSUME, "n_robots": n}, CONSUME_METRICS)
            out[f"surround-{n}robots"] = ({**SURROUND, "n_robots": n}, SURROUND_METRICS)
        return out
    if name == "large":
        return {
            "consume-large": ({**CONSUME, **LARGE_FIELD}, CONSUME_METRICS),
            "surround-large": ({**SURROUND, **LARGE_FIELD}, SURROUND_METRICS),
        }
    raise ValueError(f"unknown sweep {name!r}")


def run_setting(config: dict[str, Any], metrics: Sequence[str], games: int, first_seed: int, workers: int, policy: str) -> dict:
    """One throughput setting: success and the metrics' means over the successful games."""
    results = evaluate("Foraging-v0", policy, episodes=games, seed=first_seed, config=config, workers=workers)
    wins = [r for r in results if r.success]
    row: dict[str, Any] = {"games": games, "successes": len(wins)}
    low, high = wilson(len(wins), games)
    row["success"] = {"rate": len(wins) / games, "low": low, "high": high}
    for name in metrics:
        row[name] = mean_ci([r.metric_means().get(name, math.nan) for r in wins])
    dt = teamgym.env_class("Foraging-v0").config_class.from_kwargs(**config).dt
    row["bytes_sent_per_robot_s"] = mean_ci([r.metric_means().get("bytes_sent", math.nan) / (r.length * dt) for r in wins])
    return row


def run_sweep(name: str, config: dict, metrics: Sequence[str], args: argparse.Namespace, partial: Path | None = None) -> dict:
    """Every point of one sweep's radio axis (``args.radio``), for ``args.policy``.

    The axis's two ends (``--key-games`` each) run first, then the points between; after each
    point the sweep so far is written to ``partial`` (if given), rows in axis order.
    """
    key, values, fixed = RADIO_AXES[args.radio][:3]
    config = {**config, **fixed, **({"consumed_targets": args.consumed} if args.consumed != "vanish" else {})}
    last = len(values) - 1
    done: dict[int, dict] = {}
    result = {"sweep": name, "policy": args.policy, "config": config, "axis": key, "metrics": list(metrics), "rows": {}}
    for k in [0, last, *range(1, last)] if last else [0]:
        value = values[k]
        games = args.key_games if k in (0, last) else args.games
        start = time.perf_counter()
        row = run_setting({**config, key: value}, metrics, games, args.first_seed, args.workers, args.policy)
        row["seconds"] = time.perf_counter() - start
        done[k] = row
        result["rows"] = {str(values[j]): done[j] for j in sorted(done)}
        if partial is not None:
            partial.write_text(json.dumps(result, indent=2) + "\n")
        if not args.quiet:
            shown = ", ".join(f"{m} {row[m]['mean']:.1f}±{row[m]['ci95']:.1f}" for m in metrics)
            print(f"{name} {key} {value}: success {100 * row['success']['rate']:.1f}%, {shown}", file=sys.stderr, flush=True)
    return result


#: Table column of each radio axis.
AXIS_COLUMNS = {"comm_throughput": "throughput", "packet_rate": "packets/s"}


def axis_label(result: dict) -> str:
    """The x-axis label of a sweep (older results have no ``axis``: throughput)."""
    axis = result.get("axis", "comm_throughput")
    return next(label for key, _, _, label in RADIO_AXES.values() if key == axis)


def table(result: dict) -> str:
    """Markdown table of one sweep."""
    lines = []
    for throughput, row in result["rows"].items():
        s = row["success"]
        success = f"{100 * s['rate']:.1f} [{100 * s['low']:.1f}, {100 * s['high']:.1f}]"
        line = {AXIS_COLUMNS[result.get("axis", "comm_throughput")]: throughput, "games": row["games"], "success %": success}
        for m in result["metrics"]:
            unit = "m" if m == "DG" else "s"
            line[f"{m} ({unit})"] = f"{row[m]['mean']:.2f} ± {row[m]['ci95']:.2f}"
        lines.append(line)
    return markdown_table(lines)


def plot(result: dict, path: Path) -> None:
    """Success rate and the time/distance measures against throughput, with 95 % bands."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.array([float(t) for t in result["rows"]])
    rows = list(result["rows"].values())
    fig, (ax_s, ax_t) = plt.subplots(1, 2, figsize=(10, 3.8))
    rate = np.array([100 * r["success"]["rate"] for r in rows])
    low = np.array([100 * r["success"]["low"] for r in rows])
    high = np.array([100 * r["success"]["high"] for r in rows])
    ax_s.errorbar(
        x,
        rate,
        yerr=np.maximum(0.0, [rate - low, high - rate]),  # a rate of 100 % may round above its interval
        marker="o",
        capsize=3,
    )
    consumed = result.get("config", {}).get("consumed_targets")  # a sweep made before the option has no such entry
    title = result["sweep"] + (f" ({consumed})" if consumed else "")
    ax_s.set(xlabel=axis_label(result), ylabel="successful games (%)", title=title)
    ax_s.set_ylim(max(0.0, float(low.min()) - 5.0), 100.5)
    for m in result["metrics"]:
        mean = np.array([r[m]["mean"] for r in rows])
        half = np.array([r[m]["ci95"] for r in rows])
        target = ax_t.twinx() if m == "DG" else ax_t
        target.plot(x, mean, marker="o", label=f"{m} ({'m' if m == 'DG' else 's'})", color=None if m != "DG" else "grey")
        target.fill_between(x, mean - half, mean + half, alpha=0.2 if m != "DG" else 0.08, color=None if m != "DG" else "grey")
        if m == "DG":
            target.set_ylabel("DG (m per robot)")
            target.legend(loc="upper right")
    ax_t.set(xlabel=axis_label(result), ylabel="time (s), successful games")
    ax_t.legend(loc="upper left")
    if result.get("axis") == "packet_rate":
        for ax in (ax_s, ax_t):
            ax.set_xscale("symlog", linthresh=0.1)
            ax.set_xlim(left=-0.02)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def search_time(games: int, first_seed: int, config: dict | None = None) -> dict:
    """One robot searching with DMAPS (search behaviour only): time to see 90 % and 100 % of the cells.

    Search-only games never end by success, so they are cut at 60 s (``time_limit``); a game that
    has not seen every cell by then counts in ``never``.
    """
    settings = {"task": "surround", "n_robots": 1, "robots_per_target": 1, "n_targets": 1, "time_limit": 60.0, **(config or {})}
    env = teamgym.make("Foraging-v0", **settings)
    policy = make_policy("dmaps", env, search_only=True)
    c, grid = env.config, env.config.grid
    times: dict[str, list[float]] = {"90": [], "100": []}
    covered = np.zeros(grid.shape, dtype=bool)
    reached: dict[str, float] = {}

    def watch(step: Step) -> None:
        x, y, theta = step.env.state()[:3]
        covered[:] |= grid.sector_mask(x, y, theta, c.camera_range, c.camera_fov)
        share = covered.mean()
        for key, level in (("90", 0.9), ("100", 1.0)):
            if key not in reached and share >= level - 1e-12:
                reached[key] = step.env.world.time

    for seed in range(first_seed, first_seed + games):
        covered[:] = False
        reached.clear()
        run_episode(env, policy, seed, on_step=watch, on_reset=watch, record_trajectories=False)
        for key in times:
            times[key].append(reached.get(key, math.nan))
    return {key: {**mean_ci(values), "never": int(np.sum(np.isnan(values)))} for key, values in times.items()}


def difference(result: dict, metric: str, low: str | None = None, high: str | None = None) -> dict[str, float]:
    """``metric`` at radio ``low`` minus at ``high`` (default: the axis's first and last points), with the 95 %
    half-width of the difference."""
    keys = list(result["rows"])
    a, b = result["rows"][low or keys[0]][metric], result["rows"][high or keys[-1]][metric]
    return {"drop": a["mean"] - b["mean"], "ci95": math.hypot(a["ci95"], b["ci95"])}


def report(out: Path, suffix: str = "") -> str:
    """Markdown summary of the sweeps found in ``out``: tables and the paper's trends checked."""
    lines = []
    for path in sorted(out.glob(f"*{suffix}.json")):
        result = json.loads(path.read_text())
        if "rows" not in result:
            continue
        plot(result, path.with_suffix(".png"))
        counts = [row["games"] for row in result["rows"].values()]
        games = f"{counts[0]} games per point" if len(set(counts)) == 1 else f"{counts[0]} games at the ends, {counts[1]} between"
        title = f"**{result['sweep']}** ({games}, `{json.dumps(result['config'])}`)"
        lines += [title, "", table(result), ""]
        ends = [result["rows"][key]["success"] for key in (next(iter(result["rows"])), list(result["rows"])[-1])]
        lines.append(
            "- success: "
            + " → ".join(f"{100 * e['rate']:.1f} % [{100 * e['low']:.1f}, {100 * e['high']:.1f}]" for e in ends)
            + " (no radio → full radio)"
        )
        for metric in ("TT2", "TT3", "TG", "DG"):
            if metric in result["metrics"]:
                d = difference(result, metric)
                unit = "m" if metric == "DG" else "s"
                if abs(d["drop"]) <= d["ci95"]:
                    verdict = f"no difference beyond the 95 % interval (no − full = {d['drop']:.2f} ± {d['ci95']:.2f} {unit})"
                else:
                    side = "lower" if d["drop"] > 0 else "higher"
                    verdict = f"{abs(d['drop']):.2f} {unit} {side} with full communication than without (± {d['ci95']:.2f})"
                lines.append(f"- {metric}: {verdict}")
        lines.append("")
    lines += readings(out, suffix)
    search = out / f"search{suffix}.json"
    if search.exists():
        s = json.loads(search.read_text())["search"]
        lines.append(
            f"**search** (one robot, DMAPS search only, {s['100']['n'] + s['100']['never']} games cut at 60 s): 90 % of cells "
            f"seen after {s['90']['mean']:.1f} ± {s['90']['ci95']:.1f} s ({s['90']['n']} games), all cells after "
            f"{s['100']['mean']:.1f} ± {s['100']['ci95']:.1f} s ({s['100']['n']} games)"
        )
    return "\n".join(lines)


def readings(out: Path, suffix: str = "") -> list[str]:
    """Both ``consumed_targets`` readings of a sweep side by side (no − full radio, 95 % intervals) and a plot of each pair."""
    lines = []
    for persist in sorted(out.glob(f"*-persist*{suffix}.json")):
        vanish = out / persist.name.replace("-persist", "")
        if not vanish.exists():
            continue
        pair = {"vanish": json.loads(vanish.read_text()), "persist": json.loads(persist.read_text())}
        metrics = [m for m in ("TT1", "TT2", "TT3", "TG", "DG") if m in pair["vanish"]["metrics"]]
        rows = []
        for reading, result in pair.items():
            row = {"consumed_targets": reading}
            for m in metrics:
                d = difference(result, m)
                row[f"{m} gain"] = f"{d['drop']:.2f} ± {d['ci95']:.2f}"
            ends = [result["rows"][k]["success"]["rate"] for k in (next(iter(result["rows"])), list(result["rows"])[-1])]
            row["success % (no → full)"] = f"{100 * ends[0]:.1f} → {100 * ends[1]:.1f}"
            rows.append(row)
        name = persist.stem.replace("-persist", "")
        lines += [f"**{name}: both readings** (gain = no radio − full radio, 95 % interval)", "", markdown_table(rows), ""]
        plot_readings(pair, metrics, out / f"{name}-readings.png")
    return lines


def plot_readings(pair: dict[str, dict], metrics: Sequence[str], path: Path) -> None:
    """Success and the time measures of both readings against the radio axis (one panel each)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    shown = [m for m in metrics if m != "DG"]
    fig, axes = plt.subplots(1, 1 + len(shown), figsize=(3.2 * (1 + len(shown)), 3.4), squeeze=False)
    for reading, result in pair.items():
        x = np.array([float(t) for t in result["rows"]])
        rows = list(result["rows"].values())
        rate = np.array([100 * r["success"]["rate"] for r in rows])
        spread = np.maximum(
            0.0, [rate - [100 * r["success"]["low"] for r in rows], [100 * r["success"]["high"] for r in rows] - rate]
        )
        axes[0, 0].errorbar(x, rate, yerr=spread, marker="o", capsize=3, label=reading)
        for ax, m in zip(axes[0, 1:], shown):
            mean, half = np.array([r[m]["mean"] for r in rows]), np.array([r[m]["ci95"] for r in rows])
            ax.errorbar(x, mean, yerr=half, marker="o", capsize=3, label=reading)
            ax.set(title=f"{m} (s)", xlabel=axis_label(result))
    axes[0, 0].set(title="successful games (%)", xlabel=axis_label(pair["vanish"]))
    for ax in axes[0]:
        if pair["vanish"].get("axis") == "packet_rate":
            ax.set_xscale("symlog", linthresh=0.1)
            ax.set_xlim(left=-0.02)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    """The command line: a bad one (an empty or unknown ``--policy`` included) exits 2 with one line, before any output."""
    parser = Parser(description="Paper 002 (DMAPS): throughput sweeps on Foraging-v0.", named=True)
    parser.add_argument("experiment", choices=["consume", "surround", "search", "robots", "large", "all", "report"])
    parser.add_argument("--out", type=Path, default=Path("results/paper002"))
    parser.add_argument("--games", type=int, default=2000, help="games per setting (default 2000, as in the paper)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--policy", type=nonblank("a policy name"), default="dmaps", help="dmaps (default), dmaps-nocomm or random-walk"
    )
    parser.add_argument(
        "--radio", choices=sorted(RADIO_AXES), default="throughput", help="the swept radio setting (default throughput)"
    )
    parser.add_argument(
        "--consumed", choices=["vanish", "persist"], default="vanish", help="consumed_targets of the sweeps (default vanish)"
    )
    parser.add_argument("--key-games", type=int, default=None, help="games at the radio axis's two ends (default: --games)")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    if args.key_games is None:
        args.key_games = args.games
    if args.games < 2 or args.key_games < 2 or args.workers < 1 or args.first_seed < 0:
        parser.error("--games and --key-games must be >= 2, --workers >= 1 and --first-seed >= 0")
    try:  # an unknown policy, or one that does not fit Foraging-v0, fails here, before any output
        env = teamgym.make("Foraging-v0", **required_config(args.policy))
        try:
            make_policy(args.policy, env)
        finally:
            env.close()
    except (KeyError, ValueError, TypeError, FileNotFoundError) as error:
        parser.error(f"argument --policy: {message(error)}")
    args.out.mkdir(parents=True, exist_ok=True)
    suffix = "" if args.policy == "dmaps" else f"-{args.policy}"
    variant = ("-persist" if args.consumed == "persist" else "") + ("-rate" if args.radio == "rate" else "")
    if args.experiment == "report":
        print(report(args.out, suffix))
        return 0
    names = ["consume", "surround", "search", "robots", "large"] if args.experiment == "all" else [args.experiment]
    for name in names:
        if name == "search":
            result = {"search": search_time(min(args.games, 100), args.first_seed)}
            (args.out / f"search{suffix}.json").write_text(json.dumps(result, indent=2) + "\n")
            if not args.quiet:
                print(f"search: {result['search']}", file=sys.stderr)
            continue
        for sweep, (config, metrics) in sweeps(name).items():
            stem = f"{sweep}{variant}{suffix}"
            partial = args.out / f"{stem}.partial"
            result = run_sweep(sweep, config, metrics, args, partial)
            (args.out / f"{stem}.json").write_text(json.dumps(result, indent=2) + "\n")
            partial.unlink(missing_ok=True)
            (args.out / f"{stem}.md").write_text(table(result) + "\n")
            plot(result, args.out / f"{stem}.png")
            if not args.quiet:
                print(table(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
