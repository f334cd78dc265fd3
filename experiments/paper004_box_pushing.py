"""Reproduce the experiments of paper 004 (section 4) with the ``sbs`` baseline and the ``sbs1`` ablation.

    python experiments/paper004_box_pushing.py all --out results/paper004 --figures docs/figures/paper004 \\
        [--seeds 30] [--workers 2] [--env BoxPushing-v1] [--set noise=0] [--policies sbs,sbs1] [--situations S3]

``--policies sbs,sbs-literal`` runs both readings of the rule table side by side (``sbs``: the
shipped reading; ``sbs-literal``: footnote 1, B-17–B-19 and X-robot read literally, issue 26).
``--env`` picks the env id (default ``BoxPushing-v0``, the paper's reading; ``BoxPushing-v1``
has the coupled table friction and Khepera-like noise) and ``--set key=value`` (repeatable)
overrides its config for every run, e.g. ``--set noise=0`` for v1 without noise.

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
* ``pool`` (no runs): one static table over every ``static{prefix}*.json`` in ``--out`` for the
  comma-separated ``--tag`` prefixes, e.g. the runs of ``static --situations S3`` and of
  ``static --situations S2 --seeds 10 --first-seed 31010`` pooled; an episode run twice is an error.
"""

from __future__ import annotations

import json
import shutil
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

import teamgym
from baselines.cli import Parser, nonblank
from baselines.episode import Step, run_episode
from baselines.registry import make_policy, required_config
from baselines.runners import pool_map
from baselines.stats import mean_text, rate_text
from baselines.summary import markdown_table
from teamgym.envs.config import parse_value

SITUATIONS = ("S1", "S2", "S3", "S4")
POLICIES = ("sbs", "sbs1", "cooperative-push", "random")
#: The env of every run: (env id, config overrides); ``--env`` and ``--set``.
EnvChoice = tuple[str, dict[str, Any]]
DEFAULT_ENV: EnvChoice = ("BoxPushing-v0", {})


def make_env(env: EnvChoice, **config: Any):
    """``teamgym.make`` of the chosen env id with its overrides, then ``config``."""
    env_id, overrides = env
    return teamgym.make(env_id, **{**overrides, **config})


def run_static(args: tuple[str, str, int, EnvChoice]) -> dict[str, Any]:
    """One episode of ``policy`` in ``situation`` with ``seed``."""
    situation, policy_name, seed, choice = args
    env = make_env(choice, situation=situation, **required_config(policy_name))
    policy = make_policy(policy_name, env)
    first_box = _FirstDelivery()
    result = run_episode(env, policy, seed, on_step=first_box.check, record_trajectories=False)
    final = result.metrics
    first = next(iter(final.values()))
    starts = env.object_trajectories()
    return {
        "situation": situation,
        "policy": policy_name,
        "seed": seed,
        "success": result.success,
        "boxes": len(env.box_names()),
        "boxes_delivered": first["boxes_delivered"],
        "time_to_goal": first.get("time_to_goal"),
        "first_box_s": first_box.seconds,
        "steps": env.cycles,
        "activations": {str(k): v for k, v in sorted(getattr(policy, "activations", {}).items())},
        "situation_steps": dict(getattr(policy, "situation_steps", {})),
        "path_length": float(np.mean([m["path_length"] for m in final.values()])),
        "trajectories": env.trajectories(),
        "box_starts": [list(starts[b][0]) for b in env.box_names()],
        "box_ends": [list(env.world[b].position) for b in env.box_names()],
    }


class _FirstDelivery:
    """Episode hook: seconds until a box first touched the goal wall (the paper's success), or ``None``."""

    def __init__(self) -> None:
        self.seconds: float | None = None

    def check(self, step: Step) -> None:
        env = step.env
        if self.seconds is None and any(env.is_delivered(b) for b in env.box_names()):
            self.seconds = env.cycles * env.config.dt


def experiment_static(
    out: Path,
    figures: Path | None,
    seeds: int,
    workers: int,
    env: EnvChoice = DEFAULT_ENV,
    policies: tuple[str, ...] = POLICIES,
    first_seed: int = 0,
    tag: str = "",
    situations: tuple[str, ...] = SITUATIONS,
) -> list[dict]:
    """Section 4.1 for every policy in ``situations`` on seeds ``first_seed`` …, ``seeds`` of them; files ``static{tag}.*``."""
    seed_range = range(first_seed, first_seed + seeds)
    jobs = [(s, p, seed, env) for s in situations for p in policies for seed in seed_range]
    results = pool_map(run_static, jobs, workers)
    rows, activation_rows = static_rows(results, situations, policies)
    name = f"static{tag}"
    _write(
        out,
        name,
        {
            "env": env[0],
            "config": env[1],
            "first_seed": first_seed,
            "rows": rows,
            "activations": activation_rows,
            "episodes": _strip(results),
        },
    )
    header = f"{env[0]} {env[1] or ''}, seeds {first_seed}–{first_seed + seeds - 1}\n\n"
    (out / f"{name}.md").write_text(header + markdown_table(rows) + _activations_text(activation_rows) + "\n")
    for policy in policies:
        s3 = [r for r in results if r["situation"] == "S3" and r["policy"] == policy]
        _plot_typical(s3, out, figures, f"s3_{policy}{tag}")
    return rows


def static_rows(results: list[dict], situations: Sequence[str], policies: Sequence[str]) -> tuple[list[dict], list[dict]]:
    """The static table's rows (rates with Wilson 95 % intervals) and mean activations per episode, by situation and policy."""
    rows, activation_rows = [], []
    for situation in situations:
        for policy in policies:
            runs = [r for r in results if r["situation"] == situation and r["policy"] == policy]
            if not runs:
                continue
            steps = Counter()
            for r in runs:
                steps.update(r["situation_steps"])
            total = sum(steps.values())
            seeds = sorted(r["seed"] for r in runs)
            rows.append(
                {
                    "situation": situation,
                    "policy": policy,
                    "episodes": len(runs),
                    "seeds": f"{seeds[0]}–{seeds[-1]}",
                    "every box": rate_text(sum(r["success"] for r in runs), len(runs)),
                    "a box touches the goal": rate_text(sum(r["first_box_s"] is not None for r in runs), len(runs)),
                    "time, every box (s)": mean_text([r["time_to_goal"] for r in runs if r["success"]]),
                    "time, a box (s)": mean_text([r["first_box_s"] for r in runs if r["first_box_s"] is not None]),
                    "recognized S1/S2/S3/S4": "/".join(f"{steps[s] / total:.2f}" for s in SITUATIONS) if total else "–",
                }
            )
            counts = Counter()
            for r in runs:
                counts.update({int(k): v for k, v in r["activations"].items()})
            if counts:
                activation_rows.append(
                    {"situation": situation, "policy": policy}
                    | {f"B-{k}" if k else "none": round(counts[k] / len(runs)) for k in range(20)}
                )
    return rows, activation_rows


def pool(out: Path, prefixes: Sequence[str]) -> str:
    """One static table over the episodes of every ``static{prefix}*.json`` in ``out`` (runs split by situation or seeds).

    Raises ``ValueError`` if no file matches or an episode (situation, policy, seed) appears twice.
    """
    episodes: list[dict] = []
    files = list(dict.fromkeys(f for prefix in prefixes for f in sorted(out.glob(f"static{prefix}*.json"))))
    if not files:
        raise ValueError(f"no static{{prefix}}*.json in {out} for prefixes {list(prefixes)}")
    envs = set()
    for path in files:
        data = json.loads(path.read_text())
        envs.add((data["env"], json.dumps(data["config"], sort_keys=True)))
        episodes += data["episodes"]
    keys = [(e["situation"], e["policy"], e["seed"]) for e in episodes]
    twice = sorted({k for k in keys if keys.count(k) > 1})
    if twice:
        raise ValueError(f"episodes run twice in {out}: {twice[:3]}")
    policies = tuple(dict.fromkeys(e["policy"] for e in episodes))
    rows, activation_rows = static_rows(episodes, SITUATIONS, policies)
    names = ", ".join(f"static{prefix}*.json" for prefix in prefixes)
    header = f"{', '.join(f'{env} {config}' for env, config in sorted(envs))}; {len(files)} files {names}\n\n"
    return header + markdown_table(rows) + _activations_text(activation_rows) + "\n"


def _activations_text(activation_rows: list[dict]) -> str:
    return "\n\nBehaviour activations per episode (mean):\n\n" + markdown_table(activation_rows) if activation_rows else ""


def _plot_typical(runs: list[dict], out: Path, figures: Path | None, stem: str) -> None:
    """Trajectories of a typical success (the median time) and a typical failure (the lowest seed)."""
    wins = sorted((r for r in runs if r["success"]), key=lambda r: (r["time_to_goal"], r["seed"]))
    losses = [r for r in runs if not r["success"]]
    if wins:
        _plot_episode(wins[len(wins) // 2], out, figures, f"{stem}_success.png")
    if losses:
        _plot_episode(min(losses, key=lambda r: r["seed"]), out, figures, f"{stem}_failure.png")


def run_dynamic(args: tuple[str, int, EnvChoice]) -> dict[str, Any]:
    """Scenario ``"add_heavy"`` or ``"remove_robot"`` with ``seed``; situations from the recognizers.

    As in the paper's experiments, the experimenter intervenes once the robots are in the
    situation under study: the heavy box is added (``env.add_box``) in the first step in
    which both robots recognize S2; robot_1 is removed (``env.remove_robot``) in the first
    step in which robot_0 recognizes another robot (S2 or S3). Nothing is told to the robots.
    """
    scenario, seed, choice = args
    dt = 0.1
    if scenario == "add_heavy":
        config = dict(n_robots=2, n_light_boxes=2, n_spare_boxes=1, boxes_to_goal=3)
    else:  # the survivor cannot finish alone (the heavy box), so the episode runs on
        config = dict(n_robots=2, n_light_boxes=1, n_heavy_boxes=1, boxes_to_goal=2)
    env = make_env(choice, **config)
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


def experiment_dynamic(
    out: Path, figures: Path | None, seeds: int, workers: int, env: EnvChoice = DEFAULT_ENV, first_seed: int = 0, tag: str = ""
) -> list[dict]:
    """Section 4.2 with ``sbs``: the changes triggered by the robots' own recognizers; files ``dynamic{tag}.*``."""
    jobs = [(s, seed, env) for s in ("add_heavy", "remove_robot") for seed in range(first_seed, first_seed + seeds)]
    results = pool_map(run_dynamic, jobs, workers)
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
    _write(out, f"dynamic{tag}", {"env": env[0], "config": env[1], "first_seed": first_seed, "rows": rows, "episodes": results})
    (out / f"dynamic{tag}.md").write_text(markdown_table(rows) + "\n")
    if switched:
        _plot_timeline(min(switched, key=lambda r: r["seed"]), out, figures)
    return rows


#: Policy-independent dynamic scenarios (section 4.2 for every policy): config and event time (s).
DYNAMIC_SCENARIOS: dict[str, dict[str, Any]] = {
    "add_heavy": {"n_robots": 2, "n_light_boxes": 2, "n_spare_boxes": 1, "boxes_to_goal": 3},
    "remove_robot": {"n_robots": 2, "n_light_boxes": 1, "n_heavy_boxes": 1, "boxes_to_goal": 2},
}
DYNAMIC_EVENT_S = 30.0


def run_dynamic_policy(args: tuple[str, str, int, EnvChoice]) -> dict[str, Any]:
    """Scenario ``"add_heavy"`` or ``"remove_robot"`` for any policy, the change at ``DYNAMIC_EVENT_S``.

    ``add_heavy``: two robots, two light boxes; a heavy box is added at a random free spot;
    success is every box (three) at the goal wall. ``remove_robot``: two robots, a light and
    a heavy box; robot_1 is removed, so "every box" is out of reach by design (one robot
    cannot move the heavy box) and only "a box touches the goal" can be won.
    """
    scenario, policy_name, seed, choice = args
    env = make_env(choice, **DYNAMIC_SCENARIOS[scenario], **required_config(policy_name))
    policy = make_policy(policy_name, env)
    event_cycle = round(DYNAMIC_EVENT_S / env.config.dt)
    first_box = _FirstDelivery()

    def after_step(step: Step) -> None:
        first_box.check(step)
        if env.cycles == event_cycle and env.agents:
            if scenario == "add_heavy":
                env.add_box(heavy=True)
            elif "robot_1" in env.agents:
                env.remove_robot("robot_1")

    result = run_episode(env, policy, seed, on_step=after_step, record_trajectories=False)
    first = next(iter(result.metrics.values()))
    return {
        "scenario": scenario,
        "policy": policy_name,
        "seed": seed,
        "success": result.success,
        "first_box_s": first_box.seconds,
        "time_to_goal": first.get("time_to_goal"),
        "boxes_delivered": first["boxes_delivered"],
    }


def experiment_dynamic_policies(
    out: Path,
    seeds: int,
    workers: int,
    env: EnvChoice = DEFAULT_ENV,
    policies: tuple[str, ...] = POLICIES,
    first_seed: int = 0,
    tag: str = "",
) -> list[dict]:
    """Every policy in both dynamic scenarios, the change at a fixed time; files ``dynamic_policies{tag}.*``."""
    seed_range = range(first_seed, first_seed + seeds)
    jobs = [(s, p, seed, env) for s in DYNAMIC_SCENARIOS for p in policies for seed in seed_range]
    results = pool_map(run_dynamic_policy, jobs, workers)
    rows = []
    for scenario in DYNAMIC_SCENARIOS:
        for policy in policies:
            runs = [r for r in results if r["scenario"] == scenario and r["policy"] == policy]
            rows.append(
                {
                    "scenario": scenario,
                    "policy": policy,
                    "episodes": len(runs),
                    "every box": rate_text(sum(r["success"] for r in runs), len(runs)),
                    "a box touches the goal": rate_text(sum(r["first_box_s"] is not None for r in runs), len(runs)),
                    "time, every box (s)": mean_text([r["time_to_goal"] for r in runs if r["success"]]),
                    "boxes delivered": mean_text([r["boxes_delivered"] for r in runs], digits=2),
                }
            )
    name = f"dynamic_policies{tag}"
    _write(
        out,
        name,
        {
            "env": env[0],
            "config": env[1],
            "first_seed": first_seed,
            "event_s": DYNAMIC_EVENT_S,
            "rows": rows,
            "episodes": results,
        },
    )
    header = f"{env[0]} {env[1] or ''}, seeds {first_seed}–{first_seed + seeds - 1}, change at {DYNAMIC_EVENT_S:.0f} s\n\n"
    (out / f"{name}.md").write_text(header + markdown_table(rows) + "\n")
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


def run_diagnose(args: tuple[int, int, EnvChoice]) -> dict[str, Any]:
    """One S3 episode of variant ``DIAGNOSE_VARIANTS[index]`` with ``seed``."""
    index, seed, choice = args
    label, policy_name, kwargs = DIAGNOSE_VARIANTS[index]
    env = make_env(choice, situation="S3", **required_config(policy_name))
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


def experiment_diagnose(out: Path, seeds: int, first_seed: int, workers: int, env: EnvChoice = DEFAULT_ENV) -> list[dict]:
    jobs = [(i, seed, env) for i in range(len(DIAGNOSE_VARIANTS)) for seed in range(first_seed, first_seed + seeds)]
    results = pool_map(run_diagnose, jobs, workers)
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
    outcome = f"success after {result['time_to_goal']:.0f} s" if result["success"] else f"failed ({result['steps'] * 0.1:.0f} s)"
    ax.set_title(f"{title} · {outcome} (box: arrow)", fontsize=9)
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


def report(out: Path, tags: Sequence[str]) -> str:
    """One Markdown table per experiment kind, the runs of ``tags`` side by side (e.g. noise on, off).

    Reads ``static{tag}.json`` and ``dynamic_policies{tag}.json`` from ``out``; a tag whose
    file is missing is left out.
    """
    parts = []
    for kind, keys in (("static", ("situation", "policy")), ("dynamic_policies", ("scenario", "policy"))):
        runs = {tag: json.loads((out / f"{kind}{tag}.json").read_text()) for tag in tags if (out / f"{kind}{tag}.json").exists()}
        if not runs:
            continue
        merged: dict[tuple, dict[str, Any]] = {}
        labels: set[str] = set()
        for tag, data in runs.items():
            label = _run_label(data)
            label = label if label not in labels else f"{label}, {tag}"
            labels.add(label)
            for row in data["rows"]:
                entry = merged.setdefault(tuple(row[k] for k in keys), {k: row[k] for k in keys})
                entry[f"every box ({label})"] = row["every box"]
                entry[f"a box touches the goal ({label})"] = row["a box touches the goal"]
                entry[f"time, every box ({label})"] = row["time, every box (s)"]
        columns = dict.fromkeys(c for entry in merged.values() for c in entry)
        rows = [{c: entry.get(c, "not run") for c in columns} for entry in merged.values()]
        seeds = {data["first_seed"] for data in runs.values()}
        n = {row["episodes"] for data in runs.values() for row in data["rows"]}
        parts.append(f"{kind}: seeds from {sorted(seeds)}, {sorted(n)} per row\n\n" + markdown_table(rows))
    return "\n\n".join(parts) + "\n"


def _run_label(data: dict[str, Any]) -> str:
    """``"v1, noise on"``-style label of a run's env and overrides."""
    label = data["env"].removeprefix("BoxPushing-")
    config = data.get("config") or {}
    if "noise" in config:
        label += ", noise off" if float(config["noise"]) == 0 else f", noise × {config['noise']}"
    elif label == "v1":
        label += ", noise on"
    extra = {k: v for k, v in config.items() if k != "noise"}
    return label + (f", {extra}" if extra else "")


def main(argv: Sequence[str] | None = None) -> None:
    """The command line: a bad one (an empty ``--env`` or ``--policies`` included) exits 2 with one line, before any run."""
    parser = Parser(description=__doc__.splitlines()[0], named=True)
    parser.add_argument("experiment", choices=["static", "dynamic", "all", "diagnose", "report", "pool"])
    parser.add_argument("--out", type=Path, default=Path("results/paper004"))
    parser.add_argument("--figures", type=Path, default=None)
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--first-seed", type=int, default=None, help="first seed (default: 0; `diagnose`: 100, held out)")
    parser.add_argument(
        "--env", type=nonblank("an env id"), default=DEFAULT_ENV[0], help="env id (BoxPushing-v0 or BoxPushing-v1)"
    )
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="env config override (repeatable)")
    parser.add_argument("--policies", default=",".join(POLICIES), help="policies of `static` and `dynamic`, comma-separated")
    parser.add_argument(
        "--situations", default=",".join(SITUATIONS), help="situations of `static`, comma-separated (default S1,S2,S3,S4)"
    )
    parser.add_argument("--no-recognition", action="store_true", help="`dynamic`: skip sbs's recognizer-triggered runs")
    parser.add_argument(
        "--tag", default="", help="suffix of the output files (e.g. _v1_noise0); `report`, `pool`: comma-separated"
    )
    args = parser.parse_args(argv)
    if args.experiment == "report":
        print(report(args.out, args.tag.split(",")))
        return
    if args.experiment == "pool":
        try:
            print(pool(args.out, args.tag.split(",")))
        except ValueError as error:
            parser.error(str(error))
        return
    if args.seeds < 1 or args.workers < 1 or (args.first_seed is not None and args.first_seed < 0):
        parser.error("--seeds and --workers must be >= 1 and --first-seed >= 0")
    overrides = {}
    for item in args.set:
        key, sep, value = item.partition("=")
        if not sep:
            parser.error(f"--set needs KEY=VALUE, got {item!r}")
        overrides[key] = parse_value(value)
    env = (args.env, overrides)
    policies = tuple(p for p in args.policies.split(",") if p)
    if not policies:
        parser.error(f"argument --policies: expected comma-separated policy names, got {args.policies!r}")
    situations = tuple(s for s in args.situations.split(",") if s)
    if not situations or set(situations) - set(SITUATIONS):
        parser.error(f"argument --situations: expected some of {','.join(SITUATIONS)}, got {args.situations!r}")
    try:
        make_env(env)  # an unknown id or a bad override fails here, before any run
        for policy in policies:
            make_policy(policy, make_env(env, **required_config(policy)))
    except (KeyError, ValueError, TypeError) as error:
        parser.error(str(error).strip("'\""))
    if args.experiment == "diagnose":
        first = 100 if args.first_seed is None else args.first_seed
        print(markdown_table(experiment_diagnose(args.out, args.seeds, first, args.workers, env)))
        return
    first = args.first_seed or 0
    if args.experiment in ("static", "all"):
        rows = experiment_static(args.out, args.figures, args.seeds, args.workers, env, policies, first, args.tag, situations)
        print(markdown_table(rows))
    if args.experiment in ("dynamic", "all"):
        print(markdown_table(experiment_dynamic_policies(args.out, args.seeds, args.workers, env, policies, first, args.tag)))
        if "sbs" in policies and not args.no_recognition:
            print(markdown_table(experiment_dynamic(args.out, args.figures, args.seeds, args.workers, env, first, args.tag)))


if __name__ == "__main__":
    main()
