"""Reproduce the experiments of paper 001 (section 6) with the ``nash`` baseline.

    python experiments/paper001_navigation.py all --out results/paper001 [--seeds 100]

Subcommands (each writes JSON, a Markdown table and PNG plots into ``--out``):

* ``delay`` (section 6.1, Fig. 5): 2 robots crossing, Δt = 0.1 s, true actuation delay
  T0_true = ½T0(1+δt) for T0 ∈ {0, 0.3, 0.6, 0.9}·Δt; the controller models T0 (eq. 17) or
  assumes T0 = 0. Success rate and time to goal for both; trajectories at T0 = 0.9Δt.
* ``delay-long`` (section 6.1 carried on; not part of ``all``): the delays the paper's table
  stops short of, over ``--seeds`` seeds (from ``--first-seed``). The paper's random true delay
  ½T0(1+δt) for T0 ∈ {1, 1.25, 1.5, 1.75, 2}·Δt; then one fixed true delay T0 (``true_delay=
  "fixed"``) from 0.9Δt to 8Δt (``LONG_FIXED``). Unmodelled (T0 = 0 in eq. 26) everywhere;
  modelled only where T0 ≤ Δt (``nash`` refuses a larger T0: eq. 26's Δt − T0 turns negative),
  which includes T0 = Δt, where eq. (26) drops the decision from the predicted heading. Arrival
  rate with its Wilson interval, contact-free rate, collisions, time to goal, smoothness J.
  ``--layout random`` (written as ``delay-long-random``): 2 robots with random starts, headings
  and goals instead of Fig. 5's head-on crossing, whose seeds change only the circle's phase.
* ``decision-set`` (section 6.2, Figs. 6–7): K = 3, 5, 9, 17 angular-velocity levels;
  smoothness J_1 of robot 1 and decision time per step.
* ``obstacles`` (section 6.3, Figs. 8–9): 3 and 5 robots, 2 obstacles at 20 cm/s,
  Δt = 0.2 s, robot radius 5 cm: distance to the nearest object over time for one seed;
  then over ``--seeds`` seeds (from ``--first-seed``) ``success`` (every robot at its goal
  and no contact: the paper's criterion), ``all_arrived`` (the env's success: every robot at
  its goal), collisions, minimum separation, and how often the arbiter saw one, several
  or no equilibria; the same seeds with ``goto`` and ``nash-first`` (no arbiter) for
  comparison. Each in three workspaces (``WORKSPACES``): ``walled`` (2 m arena with walls,
  obstacles bounce off them: the earlier setting), ``open`` (no walls, as in the paper;
  obstacles still reflect at the 2 m square's edges and stay inside it) and
  ``open-straight`` (no walls, obstacles on one straight line for the whole episode).
* ``failures``: for ``nash`` with 5 robots, the first contact of every episode without
  success (what was hit, from which side, robot speed, gap to the nearest wall,
  obstacle just reflected?, distance to goal) in each workspace: the failure taxonomy of
  docs/navigation.md. Run it on the held-out seeds (``--first-seed 100``).

Seeds 0–99 are the reported ones; 100–199 were used for every tuning decision.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

import teamgym
from baselines.episode import Step, run_episode
from baselines.registry import make_policy, required_config
from baselines.stats import wilson
from baselines.summary import markdown_table

DELAY_FRACTIONS = (0.0, 0.3, 0.6, 0.9)
#: ``delay-long``: T0/Δt with the paper's random true delay, and the fixed true delays T0_true/Δt.
LONG_RANDOM = (1.0, 1.25, 1.5, 1.75, 2.0)
LONG_FIXED = (0.9, 0.95, 1.0, 1.25, 1.5, 1.75, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0)
#: The crossing of Fig. 5 (section 6.1), Δt = 0.1 s.
CROSSING = {"n_robots": 2, "n_obstacles": 0, "layout": "circle", "dt": 0.1}
DECISION_SETS = (3, 5, 9, 17)
OBSTACLE_SETTING = {"dt": 0.2, "robot_radius": 0.05, "n_obstacles": 2, "obstacle_speed": 0.2}
#: Workspaces of the obstacle experiment (Navigation-v0 config on top of OBSTACLE_SETTING).
WORKSPACES = {
    "walled": {"walls": True, "obstacle_motion": "bounce"},
    "open": {"walls": False, "obstacle_motion": "bounce"},
    "open-straight": {"walls": False, "obstacle_motion": "straight"},
}
#: A robot counts as exposed in a step when an obstacle centre is this near its centre (m).
EXPOSURE_DISTANCE = 0.25


def run(env_id: str, policy_name: str, seed: int, config: dict[str, Any], policy_kwargs: dict | None = None) -> dict[str, Any]:
    """One episode; returns per-robot final metrics, per-step centre distances and policy statistics.

    ``arrived`` is the env's success (every robot at its goal, from ``infos``); ``success``
    also requires that no robot touched anything (the paper's criterion, from the metrics).
    """
    env = teamgym.make(env_id, **{**required_config(policy_name), **config})
    policy = make_policy(policy_name, env, **(policy_kwargs or {}))
    recorder = _Recorder()
    result = run_episode(env, policy, seed, on_step=recorder.after_step, on_reset=recorder.after_reset, record_trajectories=False)
    robots = list(result.metrics.values())
    size = env.config.arena_size
    path_points = np.concatenate([np.asarray(p, dtype=float).reshape(-1, 2) for p in env.trajectories().values()])
    collisions = sum(m["collisions"] for m in robots)
    return {
        "seed": seed,
        "success": result.success and collisions == 0,
        "arrived": result.success,
        "collisions": collisions,
        "min_center_distance": min(m["min_center_distance"] for m in robots),
        "min_clearance": min(m["min_clearance"] for m in robots),
        "time_to_goal": float(np.mean([m["time_to_goal"] for m in robots if "time_to_goal" in m]))
        if any("time_to_goal" in m for m in robots)
        else float("nan"),
        "smoothness": [result.metrics[a]["smoothness"] for a in env.possible_agents],
        "steps": env.cycles,
        "nearest": np.array(recorder.nearest),
        "trajectories": env.trajectories(),
        "obstacle_paths": np.array(recorder.obstacle_paths),
        "goals": np.asarray(env.goals).tolist(),
        "arena": size,
        "walls": env.config.walls,
        "exposed_steps": recorder.exposed,
        "outside_square_m": float(np.max(np.maximum(np.maximum(-path_points, path_points - size), 0.0))),
        "contacts": recorder.contacts,
        "branches": dict(getattr(policy, "branch_counts", {})),
        "decision_times": list(getattr(policy, "decision_times", [])),
    }


class _Recorder:
    """Episode hooks of :func:`run`: nearest distances, obstacle paths, exposure and described contacts per step."""

    def __init__(self) -> None:
        self.nearest: list[np.ndarray] = []
        self.obstacle_paths: list[np.ndarray] = []
        self.exposed = 0
        self.contacts: list[dict[str, Any]] = []
        self.turns = np.zeros(0)  # step of each obstacle's last change of direction
        self.before: dict[str, np.ndarray] = {}  # the state the last step started from
        self.scripted: list = []  # each obstacle's scripted velocity before the last step

    def after_reset(self, step: Step) -> None:
        self.turns = np.full(len(step.env.obstacles), -np.inf)
        self._remember(step.env)

    def after_step(self, step: Step) -> None:
        env = step.env
        self.nearest.append(_nearest_centre_distances(env))
        self.obstacle_paths.append(np.array([o.position for o in env.obstacles]).reshape(-1, 2))
        if env.obstacles:
            live_rows = [env.possible_agents.index(a) for a in step.agents]
            robots = env.robot_positions[live_rows]
            gaps = np.linalg.norm(env.obstacle_positions[None, :, :] - robots[:, None, :], axis=2)
            self.exposed += int(np.sum(gaps.min(axis=1) < EXPOSURE_DISTANCE))
        for k, (o, old) in enumerate(zip(env.obstacles, self.scripted)):
            if o.target_velocity != old:
                self.turns[k] = env.cycles
        self.contacts.extend(_describe_contacts(env, list(step.agents), self.before, self.turns))
        self._remember(env)

    def _remember(self, env) -> None:
        self.before = _snapshot(env)
        self.scripted = [o.target_velocity for o in env.obstacles]


def _snapshot(env) -> dict[str, np.ndarray]:
    """Robot poses, obstacle positions and velocities before a step (for the failure taxonomy)."""
    return {
        "pos": env.robot_positions,
        "theta": env.robot_headings,
        "obstacles": env.obstacle_positions,
        "obstacle_velocity": env.obstacle_velocities,
        "goal_distance": env.goal_distances,
    }


def _relative_angle(vector: np.ndarray, heading: float) -> float:
    """Angle of ``vector`` relative to ``heading`` in degrees, in (−180, 180]; 0 = straight ahead."""
    return float(np.degrees(np.angle(np.exp(1j * (np.arctan2(vector[1], vector[0]) - heading)))))


def _describe_contacts(env, live: list[str], before: dict[str, np.ndarray], turns: np.ndarray) -> list[dict[str, Any]]:
    """Contacts of driving robots that began in the last step, described from the robot's side."""
    out = []
    size, radius = env.config.arena_size, env.config.robot_radius
    for contact in env.world.contacts:
        for me, other in ((contact.a, contact.b), (contact.b, contact.a)):
            if me not in live:
                continue
            i = env.possible_agents.index(me)
            pos, heading = before["pos"][i], float(before["theta"][i])
            row: dict[str, Any] = {
                "step": env.cycles,
                "robot": me,
                "hit": "obstacle" if other.startswith("obstacle") else "robot" if other.startswith("robot") else "wall",
                "speed_m_s": float(env.robot_list[i].command[0]),
                "wall_gap_m": float(min(pos[0], pos[1], size - pos[0], size - pos[1]) - radius),
                "goal_distance_m": float(before["goal_distance"][i]),
            }
            if other.startswith("obstacle"):
                k = int(other.split("_")[1])
                velocity = before["obstacle_velocity"][k]
                row["bearing_deg"] = _relative_angle(before["obstacles"][k] - pos, heading)
                row["obstacle_from_deg"] = _relative_angle(-velocity, heading)
                # turned (reflected) within the last two steps: eq. (4)'s heading was stale
                row["obstacle_reflected"] = bool(env.cycles - turns[k] <= 2)
            out.append(row)
    return out


def _nearest_centre_distances(env) -> np.ndarray:
    """Centre distance from every robot to the nearest other robot or obstacle centre (m)."""
    state = env.state()
    n, m = env.config.n_robots, env.config.n_obstacles
    robots = state[: 7 * n].reshape(n, 7)[:, :2]
    points = np.concatenate([robots, state[7 * n :].reshape(m, 4)[:, :2]]) if m else robots
    d = np.linalg.norm(robots[:, None, :] - points[None, :, :], axis=2)
    d[np.arange(n), np.arange(n)] = np.inf
    return d.min(axis=1)


# -- experiment 1: delay -------------------------------------------------------------------
def experiment_delay(out: Path, seeds: int) -> dict:
    rows = []
    examples = {}
    for fraction in DELAY_FRACTIONS:
        config = {**CROSSING, "actuation_delay": fraction * 0.1}
        for modelled in (False, True):
            results = [run("Navigation-v0", "nash", s, config, {"model_delay": modelled}) for s in range(seeds)]
            rows.append(
                {
                    "T0/dt": fraction,
                    "T0 modelled": modelled,
                    "success": float(np.mean([r["arrived"] for r in results])),
                    "collisions": int(sum(r["collisions"] for r in results)),
                    "time_to_goal_s": float(np.nanmean([r["time_to_goal"] for r in results])),
                    "steps": float(np.mean([r["steps"] for r in results])),
                }
            )
            if fraction == DELAY_FRACTIONS[-1]:
                examples[modelled] = results[0]
    _plot_pair(out / "delay_trajectories.png", examples, "T0_true up to 0.9Δt: T0 not modelled (left) vs modelled (right)")
    return {"rows": rows}


def experiment_delay_long(
    out: Path,
    seeds: int,
    first_seed: int = 0,
    layout: str = "circle",
    random_fractions: tuple[float, ...] | None = None,
    fixed_fractions: tuple[float, ...] | None = None,
) -> dict:
    """``delay-long``: delays from Δt on (random ½T0(1+δt), then fixed), modelled where eq. (26) allows.

    ``layout="circle"`` is Fig. 5's head-on crossing (seeds change only the circle's phase);
    ``"random"`` draws starts, headings and goals per seed (independent episodes). The
    fractions of Δt default to ``LONG_RANDOM`` and ``LONG_FIXED``.
    """
    random_fractions = LONG_RANDOM if random_fractions is None else random_fractions
    fixed_fractions = LONG_FIXED if fixed_fractions is None else fixed_fractions
    cases = [("random", f, m) for f in random_fractions for m in ((False, True) if f <= 1.0 else (False,))]
    cases += [("fixed", f, m) for f in fixed_fractions for m in ((False, True) if f <= 1.0 else (False,))]
    rows = []
    for true_delay, fraction, modelled in cases:
        config = {**CROSSING, "layout": layout, "actuation_delay": fraction * CROSSING["dt"], "true_delay": true_delay}
        kwargs = {"model_delay": modelled}
        results = [run("Navigation-v0", "nash", s, config, kwargs) for s in range(first_seed, first_seed + seeds)]
        rows.append(_delay_row(results, fraction, true_delay, modelled))
    return {"rows": rows, "seeds": [first_seed, first_seed + seeds - 1], "layout": layout}


def _delay_row(results: list[dict], fraction: float, true_delay: str, modelled: bool) -> dict:
    """One row of ``delay-long``: arrival (Wilson 95 %), contact-free episodes, time to goal and J over ``results``."""
    arrived = sum(r["arrived"] for r in results)
    low, high = wilson(arrived, len(results))
    return {
        "T0/dt": fraction,
        "true delay": "½T0(1+δt)" if true_delay == "random" else "T0",
        "T0 modelled": modelled,
        "episodes": len(results),
        "arrived": arrived,
        "arrived 95% CI": f"{low:.3f}–{high:.3f}",
        "contact-free": sum(r["success"] for r in results),
        "collisions": int(sum(r["collisions"] for r in results)),
        "time_to_goal_s": float(np.nanmean([r["time_to_goal"] for r in results])) if arrived else float("nan"),
        "J": float(np.mean([np.mean(r["smoothness"]) for r in results])),
        "branches": ", ".join(f"{k} {v}" for k, v in sum((Counter(r["branches"]) for r in results), Counter()).most_common(2)),
    }


# -- experiment 2: decision-set size ---------------------------------------------------------
def experiment_decision_set(out: Path, seeds: int) -> dict:
    rows = []
    for k in DECISION_SETS:
        config = {"n_robots": 2, "n_obstacles": 0, "layout": "circle", "heading_levels": k}
        results = [run("Navigation-v0", "nash", s, config) for s in range(seeds)]
        times = np.concatenate([r["decision_times"] for r in results])
        rows.append(
            {
                "K": k,
                "J_1": float(np.mean([r["smoothness"][0] for r in results])),
                "decision_ms": float(1000 * np.mean(times)),
                "success": float(np.mean([r["arrived"] for r in results])),
            }
        )
    _plot_decision_set(out / "decision_set.png", rows)
    return {"rows": rows}


# -- experiment 3 and statistics: moving obstacles ------------------------------------------
def experiment_obstacles(out: Path, seeds: int, first_seed: int = 0) -> dict:
    summary: dict[str, Any] = {"seeds": [first_seed, first_seed + seeds - 1], "rows": [], "branches": {}}
    for workspace, setting in WORKSPACES.items():
        for n in (3, 5):
            config = {**OBSTACLE_SETTING, **setting, "n_robots": n}
            example = run("Navigation-v0", "nash", first_seed, config)
            suffix = "" if workspace == "walled" else f"_{workspace}"
            _plot_nearest(out / f"obstacles_{n}_robots{suffix}.png", example, n, workspace)
            for policy in ("nash", "nash-first", "goto"):
                started = time.perf_counter()
                results = [run("Navigation-v0", policy, s, config) for s in range(first_seed, first_seed + seeds)]
                summary["rows"].append(
                    {
                        "workspace": workspace,
                        "robots": n,
                        "policy": policy,
                        "success": float(np.mean([r["success"] for r in results])),
                        "all_arrived": float(np.mean([r["arrived"] for r in results])),
                        "collisions_per_episode": float(np.mean([r["collisions"] for r in results])),
                        "min_center_distance_m": float(np.min([r["min_center_distance"] for r in results])),
                        "median_min_center_distance_m": float(np.median([r["min_center_distance"] for r in results])),
                        "time_to_goal_s": float(np.nanmean([r["time_to_goal"] for r in results])),
                        "exposed_steps": float(np.mean([r["exposed_steps"] for r in results])),
                        "left_square": float(np.mean([r["outside_square_m"] > 0 for r in results])),
                        "wall_s": time.perf_counter() - started,
                    }
                )
                if policy == "nash":
                    counts: Counter[str] = Counter()
                    for r in results:
                        counts.update(r["branches"])
                    summary["branches"][f"{workspace}, {n} robots"] = dict(counts)
    return summary


def experiment_failures(out: Path, seeds: int, first_seed: int = 0) -> dict:
    """First contact of every failed ``nash`` episode with 5 robots, per workspace."""
    rows = []
    for workspace, setting in WORKSPACES.items():
        config = {**OBSTACLE_SETTING, **setting, "n_robots": 5}
        for seed in range(first_seed, first_seed + seeds):
            r = run("Navigation-v0", "nash", seed, config)
            if r["success"]:
                continue
            first = r["contacts"][0] if r["contacts"] else {}
            rows.append(
                {
                    "workspace": workspace,
                    "seed": seed,
                    "outcome": "collision" if r["collisions"] else "timeout",
                    "robot": first.get("robot", "-"),
                    "hit": first.get("hit", "-"),
                    "bearing_deg": round(first["bearing_deg"]) if "bearing_deg" in first else "-",
                    "obstacle_from_deg": round(first["obstacle_from_deg"]) if "obstacle_from_deg" in first else "-",
                    "v_cmd_m_s": first.get("speed_m_s", float("nan")),
                    "wall_gap_m": first.get("wall_gap_m", float("nan")),
                    "goal_distance_m": first.get("goal_distance_m", float("nan")),
                    "obstacle_reflected": first.get("obstacle_reflected", "-"),
                    "contacts": len(r["contacts"]),
                }
            )
    if not rows:
        rows = [{"workspace": "-", "seed": "-", "outcome": "no failures"}]
    return {"seeds": [first_seed, first_seed + seeds - 1], "rows": rows}


# -- plots -----------------------------------------------------------------------------------
def _figure(width: float = 6.0, height: float = 4.0):
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height))


def _draw_trajectories(ax, result: dict, title: str) -> None:
    for i, (agent, points) in enumerate(result["trajectories"].items()):
        pts = np.asarray(points)
        ax.plot(pts[:, 0], pts[:, 1], label=agent)
        ax.plot(*pts[0], "o", color=f"C{i}")
        ax.plot(*result["goals"][i], "x", color=f"C{i}", markersize=10)
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def _plot_pair(path: Path, examples: dict, title: str) -> None:
    fig = _figure(10, 5)
    for column, modelled in enumerate((False, True)):
        ax = fig.add_subplot(1, 2, column + 1)
        r = examples[modelled]
        _draw_trajectories(ax, r, f"T0 {'modelled' if modelled else 'not modelled'}: success={r['success']}, {r['steps']} steps")
    fig.suptitle(title)
    fig.savefig(path, dpi=100)


def _plot_decision_set(path: Path, rows: list[dict]) -> None:
    fig = _figure(10, 4)
    ks = [r["K"] for r in rows]
    for column, (key, label) in enumerate((("J_1", "smoothness J_1"), ("decision_ms", "decision time per step (ms)"))):
        ax = fig.add_subplot(1, 2, column + 1)
        ax.plot(ks, [r[key] for r in rows], "o-")
        ax.set_xlabel("decision-set size K")
        ax.set_ylabel(label)
        ax.set_xticks(ks)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def _plot_nearest(path: Path, result: dict, n: int, workspace: str = "walled") -> None:
    fig = _figure(11, 4.5)
    ax = fig.add_subplot(1, 2, 1)
    size = result["arena"]
    ax.plot(
        [0, size, size, 0, 0],
        [0, 0, size, size, 0],
        color="k",
        linewidth=2 if result["walls"] else 0.8,
        linestyle="-" if result["walls"] else ":",
    )
    for k in range(result["obstacle_paths"].shape[1] if len(result["obstacle_paths"]) else 0):
        path_k = result["obstacle_paths"][:, k]
        ax.plot(path_k[:, 0], path_k[:, 1], color="0.5", linestyle="--", linewidth=1)
        ax.annotate(f"o{k + 1}", path_k[0], fontsize=8, color="0.3")
    title = f"{n} robots, 2 obstacles, {workspace} (seed {result['seed']}): success={result['success']}"
    _draw_trajectories(ax, result, title)
    ax = fig.add_subplot(1, 2, 2)
    nearest = result["nearest"]
    t = 0.2 * np.arange(1, len(nearest) + 1)
    for i in range(n):
        ax.plot(t, nearest[:, i], label=f"robot_{i}")
    ax.axhline(0.13, color="k", linestyle="--", linewidth=1, label="13 cm (paper)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("centre distance to nearest object (m)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


# -- tables and CLI ----------------------------------------------------------------------------
EXPERIMENTS = {
    "delay": experiment_delay,
    "delay-long": experiment_delay_long,
    "decision-set": experiment_decision_set,
    "obstacles": experiment_obstacles,
    "failures": experiment_failures,
}
#: Experiments that take ``--first-seed`` (the others always start at seed 0).
SEEDED = ("obstacles", "failures", "delay-long")
#: Experiments that ``all`` leaves out.
NOT_IN_ALL = ("failures", "delay-long")


def _fractions(text: str) -> tuple[float, ...]:
    """``--random-delays`` / ``--fixed-delays``: comma-separated T0/Δt in [0, 8] (the env's limit)."""
    try:
        values = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None
    if not all(0.0 <= v <= 8.0 for v in values):
        raise argparse.ArgumentTypeError(f"each T0/Δt must be in [0, 8], got {text!r}")
    return values


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Reproduce paper 001's experiments with the nash baseline.")
    parser.add_argument("experiment", choices=[*EXPERIMENTS, "all"])
    parser.add_argument("--out", type=Path, default=Path("results/paper001"))
    parser.add_argument("--seeds", type=int, default=100, help="seeds for obstacles, failures and delay-long (20 for the others)")
    parser.add_argument(
        "--first-seed",
        type=int,
        default=0,
        help="first seed of obstacles, failures, delay-long (100: held-out tuning seeds)",
    )
    parser.add_argument(
        "--layout", choices=["circle", "random"], default="circle", help="delay-long: Fig. 5's crossing or random starts"
    )
    for kind, default in (("random", LONG_RANDOM), ("fixed", LONG_FIXED)):
        parser.add_argument(
            f"--{kind}-delays",
            type=_fractions,
            default=None,
            help=f"delay-long: T0/Δt of the {kind} true delay, comma-separated ('' none; default {','.join(map(str, default))})",
        )
    args = parser.parse_args(argv)
    if args.seeds < 1 or args.first_seed < 0:
        parser.error("--seeds must be >= 1 and --first-seed >= 0")
    args.out.mkdir(parents=True, exist_ok=True)
    names = [n for n in EXPERIMENTS if n not in NOT_IN_ALL] if args.experiment == "all" else [args.experiment]
    for name in names:
        seeds = args.seeds if name in SEEDED else min(args.seeds, 20)
        if name == "delay-long":
            result = experiment_delay_long(args.out, seeds, args.first_seed, args.layout, args.random_delays, args.fixed_delays)
            label = f"seeds {args.first_seed}–{args.first_seed + seeds - 1}, layout {args.layout}"
            name += "" if args.layout == "circle" else f"-{args.layout}"
        elif name in SEEDED:
            result = EXPERIMENTS[name](args.out, seeds, args.first_seed)
            label = f"seeds {args.first_seed}–{args.first_seed + seeds - 1}"
        else:
            result = EXPERIMENTS[name](args.out, seeds)
            label = f"{seeds} seeds"
        (args.out / f"{name}.json").write_text(json.dumps(result, indent=2, default=str))
        text = f"## {name} ({label})\n\n{markdown_table(result['rows'])}\n"
        if result.get("branches"):
            text += "\nArbiter branches per step (nash): " + json.dumps(result["branches"]) + "\n"
        (args.out / f"{name}.md").write_text(text)
        print(text, flush=True)


if __name__ == "__main__":
    main()
