"""Reproduce the experiments of paper 004 (section 4) with the ``sbs`` baseline and the ``sbs1`` ablation.

    python experiments/paper004_box_pushing.py all --out results/paper004 --figures docs/figures/paper004 \\
        [--seeds 30] [--workers 2]

Subcommands (each writes JSON and a Markdown table into ``--out``; figures also into ``--figures``):

* ``static`` (section 4.1): situations S1 (1 robot, 1 light box), S2 (2 robots, 2 light
  boxes), S3 (4 robots, 1 heavy box) and S4 (1 robot, 1 heavy box), ``--seeds`` random
  initial positions each (seed i places boxes away from the walls), ``sbs`` and ``sbs1`` on
  the same seeds. Success (every box at the goal wall), for S2 also "at least one box",
  mean time to success, behaviour activations per episode and the share of robot-steps in
  each recognized situation. Trajectory plot of one S3 episode.
* ``dynamic`` (section 4.2): (a) two robots with two light boxes; a heavy box is added once
  both recognize S2. Did both switch to S3, how fast, how long did both push the heavy box
  at once. (b) two robots with a light and a heavy box; one robot is removed once the other
  recognizes it. Did the survivor's situation change (M lapses after Tm), how fast. Every
  situation comes from a robot's own recognizer.
* ``diagnose`` (S3, not in ``all``): why S3 misses the paper's 80 %. The same seeds under
  ``sbs``, SBS-3 in every situation (perfect situation recognition), ``sbs1`` (no swarm
  rules), ``sbs-oracle`` (robots recognized from the simulator's state, a perfect M check)
  and both together. Reports success, seconds with two or more robots touching the heavy
  box, and the share of robot-steps stopped by the line-keeping rules B-12/B-14.
  ``--first-seed`` picks the seeds (held-out seeds 100+ by default).
"""

from __future__ import annotations

import argparse
import json
import shutil
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

import teamgym
from baselines.episode import Step, run_episode
from baselines.evaluate import markdown_table
from baselines.registry import make_policy, required_config

SITUATIONS = ("S1", "S2", "S3", "S4")
POLICIES = ("sbs", "sbs1")


def run_static(args: tuple[str, str, int]) -> dict[str, Any]:
    """One episode of ``policy`` in ``situation`` with ``seed``."""
    situation, policy_name, seed = args
    env = teamgym.make("BoxPushing-v0", situation=situation, **required_config(policy_name))
    policy = make_policy(policy_name, env)
    result = run_episode(env, policy, seed, record_trajectories=False)
    final = result.metrics
    first = next(iter(final.values()))
    starts = env.object_trajectories()
    return {
        "situation": situation,
        "policy": policy_name,
        "seed": seed,
        "success": result.success,
        "boxes_delivered": first["boxes_delivered"],
        "time_to_goal": first.get("time_to_goal"),
        "steps": env.cycles,
        "activations": {str(k): v for k, v in sorted(policy.activations.items())},
        "situation_steps": dict(policy.situation_steps),
        "path_length": float(np.mean([m["path_length"] for m in final.values()])),
        "trajectories": env.trajectories(),
        "box_starts": [list(starts[b][0]) for b in env.box_names()],
        "box_ends": [list(env.world[b].position) for b in env.box_names()],
    }


def _pool_map(fn, jobs: list, workers: int) -> list:
    if workers <= 1:
        return [fn(job) for job in jobs]
    with ProcessPoolExecutor(workers) as pool:
        return list(pool.map(fn, jobs))


def experiment_static(out: Path, figures: Path | None, seeds: int, workers: int) -> list[dict]:
    jobs = [(s, p, seed) for s in SITUATIONS for p in POLICIES for seed in range(seeds)]
    results = _pool_map(run_static, jobs, workers)
    rows, activation_rows = [], []
    for situation in SITUATIONS:
        for policy in POLICIES:
            runs = [r for r in results if r["situation"] == situation and r["policy"] == policy]
            times = [r["time_to_goal"] for r in runs if r["time_to_goal"] is not None]
            steps = Counter()
            for r in runs:
                steps.update(r["situation_steps"])
            total = sum(steps.values())
            rows.append(
                {
                    "situation": situation,
                    "policy": policy,
                    "episodes": len(runs),
                    "success": float(np.mean([r["success"] for r in runs])),
                    "≥1 box": float(np.mean([r["boxes_delivered"] >= 1 for r in runs])),
                    "mean time (s)": float(np.mean(times)) if times else float("nan"),
                    "recognized S1/S2/S3/S4": "/".join(f"{steps[s] / total:.2f}" for s in SITUATIONS),
                }
            )
            counts = Counter()
            for r in runs:
                counts.update({int(k): v for k, v in r["activations"].items()})
            activation_rows.append(
                {"situation": situation, "policy": policy}
                | {f"B-{k}" if k else "none": round(counts[k] / len(runs)) for k in range(20)}
            )
    _write(out, "static", {"rows": rows, "activations": activation_rows, "episodes": _strip(results)})
    (out / "static.md").write_text(
        markdown_table(rows) + "\n\nBehaviour activations per episode (mean):\n\n" + markdown_table(activation_rows) + "\n"
    )
    s3 = [r for r in results if r["situation"] == "S3" and r["policy"] == "sbs" and r["success"]]
    if s3:
        _plot_episode(min(s3, key=lambda r: r["steps"]), out, figures, "s3_trajectories.png")
    return rows


def run_dynamic(args: tuple[str, int]) -> dict[str, Any]:
    """Scenario ``"add_heavy"`` or ``"remove_robot"`` with ``seed``; situations from the recognizers.

    As in the paper's experiments, the experimenter intervenes once the robots are in the
    situation under study: the heavy box is added (``env.add_box``) in the first step in
    which both robots recognize S2; robot_1 is removed (``env.remove_robot``) in the first
    step in which robot_0 recognizes another robot (S2 or S3). Nothing is told to the robots.
    """
    scenario, seed = args
    dt = 0.1
    if scenario == "add_heavy":
        config = dict(n_robots=2, n_light_boxes=2, n_spare_boxes=1, boxes_to_goal=3)
    else:  # the survivor cannot finish alone (the heavy box), so the episode runs on
        config = dict(n_robots=2, n_light_boxes=1, n_heavy_boxes=1, boxes_to_goal=2)
    env = teamgym.make("BoxPushing-v0", **config)
    policy = make_policy("sbs", env)
    timeline: dict[str, list[str]] = {a: [] for a in env.possible_agents}
    event: dict[str, Any] = {"at": None, "heavy": None, "both_on_heavy": 0}

    def after_step(step: Step) -> None:
        situations = policy.situations()
        for agent in env.agents:
            timeline[agent].append(situations[agent])
        if event["at"] is None and env.agents:
            if scenario == "add_heavy" and all(situations.get(a) == "S2" for a in ("robot_0", "robot_1")):
                event["at"], event["heavy"] = env.cycles, env.add_box(heavy=True)
            elif scenario == "remove_robot" and situations.get("robot_0") in ("S2", "S3") and "robot_1" in env.agents:
                event["at"] = env.cycles
                env.remove_robot("robot_1")
        if event["heavy"] is not None:
            event["both_on_heavy"] += _robots_touching(env, event["heavy"]) >= 2

    episode = run_episode(env, policy, seed, on_step=after_step, record_trajectories=False)
    at, heavy, both_on_heavy = event["at"], event["heavy"], event["both_on_heavy"]
    result = {"scenario": scenario, "seed": seed, "event_step": at, "steps": env.cycles, "timelines": timeline}
    if scenario == "add_heavy":
        after = {a: timeline[a][at:] if at else [] for a in ("robot_0", "robot_1")}
        result["s3_after_s"] = {a: (t.index("S3") * dt if "S3" in t else None) for a, t in after.items()}
        result["both_on_heavy_s"] = both_on_heavy * dt
        result["heavy_delivered"] = heavy is not None and env.is_delivered(heavy)
        result["success"] = episode.success
    else:
        survivor = timeline["robot_0"][at:] if at else []
        lapse = next((i for i, s in enumerate(survivor) if s in ("S1", "S4")), None)
        result["not_m_after_s"] = lapse * dt if lapse is not None else None
        result["m_regained"] = lapse is not None and any(s in ("S2", "S3") for s in survivor[lapse:])
    return result


def _robots_touching(env, box_name: str) -> int:
    touching: list = []
    env.world[box_name].body.each_arbiter(lambda arbiter: touching.append(arbiter.shapes))
    return len({s.entity.name for shapes in touching for s in shapes if getattr(getattr(s, "entity", None), "kind", None) == 1})


def experiment_dynamic(out: Path, figures: Path | None, seeds: int, workers: int) -> list[dict]:
    results = _pool_map(run_dynamic, [(s, seed) for s in ("add_heavy", "remove_robot") for seed in range(seeds)], workers)
    add = [r for r in results if r["scenario"] == "add_heavy" and r["event_step"] is not None]
    rem = [r for r in results if r["scenario"] == "remove_robot" and r["event_step"] is not None]
    switched = [r for r in add if all(v is not None for v in r["s3_after_s"].values())]
    delays = [v for r in switched for v in r["s3_after_s"].values()]
    lapsed = [r for r in rem if r["not_m_after_s"] is not None]
    rows = [
        {
            "change": "heavy box added once both robots recognize S2",
            "episodes (change happened / run)": f"{len(add)} / {seeds}",
            "every robot's situation changed": f"{len(switched)} (both S2 → S3)",
            "mean time to change (s)": float(np.mean(delays)) if delays else float("nan"),
            "notes": f"both robots on the heavy box {np.mean([r['both_on_heavy_s'] for r in add]):.1f} s per episode; "
            f"heavy box delivered in {sum(r['heavy_delivered'] for r in add)}",
        },
        {
            "change": "robot_1 removed once robot_0 recognizes a robot (S2/S3)",
            "episodes (change happened / run)": f"{len(rem)} / {seeds}",
            "every robot's situation changed": f"{len(lapsed)} (survivor M → ¬M)",
            "mean time to change (s)": float(np.mean([r["not_m_after_s"] for r in lapsed])) if lapsed else float("nan"),
            "notes": f"M wrongly regained afterwards in {sum(r['m_regained'] for r in lapsed)}",
        },
    ]
    _write(out, "dynamic", {"rows": rows, "episodes": results})
    (out / "dynamic.md").write_text(markdown_table(rows) + "\n")
    if switched:
        _plot_timeline(min(switched, key=lambda r: r["seed"]), out, figures)
    return rows


#: ``diagnose`` variants: (label, policy name, extra policy keyword arguments).
DIAGNOSE_VARIANTS: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("sbs", "sbs", {}),
    ("sbs, SBS-3 always", "sbs", {"fixed_sbs": 3}),
    ("sbs1 (no swarm rules)", "sbs1", {}),
    ("sbs-oracle", "sbs-oracle", {}),
    ("sbs-oracle, SBS-3 always", "sbs-oracle", {"fixed_sbs": 3}),
)


class _TogetherOnBox:
    """Episode hook: steps that start with two or more robots touching the (first) box."""

    def __init__(self) -> None:
        self.box: str | None = None
        self.steps = 0

    def count(self, step: Step) -> None:
        """Count the state a step starts from: after reset and after every step but the last."""
        if step.index == 0:
            self.box = step.env.box_names()[0]
        if not step.done:
            self.steps += _robots_touching(step.env, self.box) >= 2


def run_diagnose(args: tuple[int, int]) -> dict[str, Any]:
    """One S3 episode of variant ``DIAGNOSE_VARIANTS[index]`` with ``seed``."""
    index, seed = args
    label, policy_name, kwargs = DIAGNOSE_VARIANTS[index]
    env = teamgym.make("BoxPushing-v0", situation="S3", **required_config(policy_name))
    policy = make_policy(policy_name, env, **kwargs)
    together = _TogetherOnBox()
    result = run_episode(env, policy, seed, on_step=together.count, on_reset=together.count, record_trajectories=False)
    robot_steps = sum(policy.situation_steps.values())
    return {
        "variant": label,
        "seed": seed,
        "success": result.success,
        "together_s": together.steps * env.config.dt,
        "stopped_b12_b14": (policy.activations[12] + policy.activations[14]) / robot_steps,
    }


def experiment_diagnose(out: Path, seeds: int, first_seed: int, workers: int) -> list[dict]:
    jobs = [(i, seed) for i in range(len(DIAGNOSE_VARIANTS)) for seed in range(first_seed, first_seed + seeds)]
    results = _pool_map(run_diagnose, jobs, workers)
    rows = []
    for label, _, _ in DIAGNOSE_VARIANTS:
        runs = [r for r in results if r["variant"] == label]
        rows.append(
            {
                "S3 variant": label,
                "episodes": len(runs),
                "success": float(np.mean([r["success"] for r in runs])),
                "≥2 robots on the box (s/episode)": float(np.mean([r["together_s"] for r in runs])),
                "robot-steps stopped by B-12/B-14": float(np.mean([r["stopped_b12_b14"] for r in runs])),
            }
        )
    _write(out, "diagnose", {"first_seed": first_seed, "rows": rows, "episodes": results})
    (out / "diagnose.md").write_text(f"S3, seeds {first_seed}–{first_seed + seeds - 1}\n\n" + markdown_table(rows) + "\n")
    return rows


# -- output ------------------------------------------------------------------------------------


def _strip(results: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k != "trajectories"} for r in results]


def _write(out: Path, name: str, data: Any) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{name}.json").write_text(json.dumps(data, indent=1, default=float, allow_nan=True) + "\n")


def _save(fig, name: str, out: Path, figures: Path | None) -> None:
    out.mkdir(parents=True, exist_ok=True)
    fig.savefig(out / name, dpi=110)
    if figures is not None:
        figures.mkdir(parents=True, exist_ok=True)
        shutil.copy(out / name, figures / name)


def _plot_episode(result: dict, out: Path, figures: Path | None, name: str) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    fig = Figure(figsize=(6.4, 5.4))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    ax.add_patch(Rectangle((0, 0), 1.1, 0.9, fill=False, lw=2))
    ax.plot([1.1, 1.1], [0, 0.9], color="green", lw=4, label="goal wall")
    for agent, points in result["trajectories"].items():
        xy = np.array(points)
        ax.plot(xy[:, 0], xy[:, 1], lw=0.8, label=agent)
    for start, end in zip(result["box_starts"], result["box_ends"]):
        ax.annotate("", xy=end, xytext=start, arrowprops={"arrowstyle": "->", "lw": 2.5, "color": "saddlebrown"})
    ax.set_aspect("equal")
    title = f"{result['situation']} · {result['policy']} · seed {result['seed']}"
    ax.set_title(f"{title} · {result['time_to_goal']:.0f} s (box: arrow)")
    ax.legend(fontsize=7, loc="lower left")
    _save(fig, name, out, figures)


def _plot_timeline(result: dict, out: Path, figures: Path | None) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 2.6))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    level = {s: i for i, s in enumerate(SITUATIONS)}
    for k, (agent, timeline) in enumerate(result["timelines"].items()):
        if timeline:
            t = np.arange(1, len(timeline) + 1) * 0.1
            ax.step(t, [level[s] + 0.06 * k for s in timeline], where="post", label=agent)
    ax.axvline(result["event_step"] * 0.1, color="k", ls="--", lw=1, label="heavy box added")
    ax.set_yticks(range(4), SITUATIONS)
    ax.set_xlabel("time (s)")
    ax.set_title(f"Recognized situations, seed {result['seed']}")
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    _save(fig, "dynamic_situations.png", out, figures)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("experiment", choices=["static", "dynamic", "all", "diagnose"])
    parser.add_argument("--out", type=Path, default=Path("results/paper004"))
    parser.add_argument("--figures", type=Path, default=None)
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--first-seed", type=int, default=100, help="first seed of `diagnose` (held-out seeds)")
    args = parser.parse_args()
    if args.experiment == "diagnose":
        print(markdown_table(experiment_diagnose(args.out, args.seeds, args.first_seed, args.workers)))
    if args.experiment in ("static", "all"):
        print(markdown_table(experiment_static(args.out, args.figures, args.seeds, args.workers)))
    if args.experiment in ("dynamic", "all"):
        print(markdown_table(experiment_dynamic(args.out, args.figures, args.seeds, args.workers)))


if __name__ == "__main__":
    main()
