"""Reproduce paper 003's section 6 scenarios (Figs. 5–7 and Fig. 8) on Rendezvous-v0.

Each scenario (``teamgym/maps/data/scenarios/``) gives the reconstructed map, the robots'
start places and the blocked ways; the robots move one way per step together
(``stage_end="all"``), as in the paper's simulation. Ways the paper blocks later (Fig. 8)
become blocked when a robot first reaches the place where the paper detects them
(``arrival_blockings``).
For every policy the run prints each whole path announced (robot_0's place first), the
re-plans and where the robots met, next to the paper's plans, and draws one panel per plan.
``bidir-astar`` and ``bidir-astar-opt`` use the protocol's Phase 3 timing ``execution="paper"``
(:mod:`baselines.rendezvous.protocol`), ``bidir-astar-eager`` the former ``execution="eager"``.

    python experiments/paper003_scenarios.py [--out results/paper003] [--figures docs/figures/paper003]
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path

# -- Figs. 5-8: the paper's scenarios on the env --------------------------------------------


def load_scenario(name: str) -> dict:
    """A scenario of section 6 (``teamgym/maps/data/scenarios/NAME.json``), checked by ``teamgym.maps.scenarios``."""
    from teamgym.maps.scenarios import load_scenario as load

    return load(name)


def scenario_config(scenario: dict) -> dict:
    """Env config of a scenario: its map, starts and blocked ways, robots moving one way per step together."""
    starts = tuple(r["start"] for r in sorted(scenario["robots"], key=lambda r: r["agent"]))
    from_start = tuple((b["a"], b["b"]) for b in scenario["blocked"] if b["from_step"] == 0)
    # A way blocked later appears when a robot first reaches the place where the paper detects it.
    on_arrival = tuple((b["a"], b["b"], b["detected"][0]["place"], 1) for b in scenario["blocked"] if b["from_step"] > 0)
    return {
        "map": scenario["graph"],
        "start_places": starts,
        "blocked_ways": from_start,
        "arrival_blockings": on_arrival,
        "protocol_messages": True,
        "stage_end": "all",
    }


def run_scenario(name: str, policy_name: str, seed: int = 0) -> dict:
    """Play a scenario with a policy; record every whole path announced and where the robots met."""
    import teamgym
    from baselines import make_policy, run_episode
    from teamgym.envs.rendezvous.messages import Kind, decode

    scenario = load_scenario(name)
    env = teamgym.make("Rendezvous-v0", **scenario_config(scenario))
    policy = make_policy(policy_name, env)
    plans: list[dict] = []
    moves = {"count": 0, "places": None}

    def blocked_now() -> list[list[str]]:
        flags = env.state()[5 * len(env.possible_agents) :]
        return [[env.place_id(a), env.place_id(b)] for (a, b), f in zip(env.way_ends, flags.tolist()) if f]

    def on_step(step) -> None:
        for action in step.actions.values():
            for kind, args in decode(action["message"]):
                if kind == Kind.PATH and len(args) > 1:
                    path = [env.place_id(i) for i in args[1:]]
                    if not plans or plans[-1]["path"] != path:
                        plans.append({"step": step.index, "moves": moves["count"], "path": path, "blocked": blocked_now()})
        places = [info["place"] for info in step.infos.values()]
        if moves["places"] is not None and places != moves["places"]:
            moves["count"] += 1  # the robots moved one way (stage_end="all")
        moves["places"] = places

    result = run_episode(env, policy, seed, on_step=on_step)
    metrics = result.metrics[env.possible_agents[0]]
    return {
        "scenario": name,
        "policy": policy_name,
        "success": result.success,
        "meeting_time": metrics.get("meeting_time"),
        "places": {a: env.place_id(m["place"]) for a, m in result.metrics.items()},
        "plans": plans,
        "replans": metrics["replans"],
        "worst_optimality": metrics.get("optimality"),
        "bytes_sent": sum(m.get("bytes_sent", 0) for m in result.metrics.values()),
        "trajectories": result.trajectories,
        "paper": {"plans": scenario["plans"], "meeting": scenario["meeting"]},
    }


def draw_scenario(run: dict, path: Path) -> Path:
    """One panel per announced plan (the map, the ways blocked by then, the plan), as Figs. 5-8."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from teamgym.maps.graph import load_graph_map
    from teamgym.maps.plot import plot_graph_map

    scenario = load_scenario(run["scenario"])
    graph_map = load_graph_map(scenario["graph"])
    plans = run["plans"] or [{"step": 0, "moves": 0, "path": [], "blocked": []}]
    figure = Figure(figsize=(4.2 * len(plans), 4.2))
    FigureCanvasAgg(figure)
    for k, plan in enumerate(plans):
        ax = figure.add_subplot(1, len(plans), k + 1)
        blocked = [tuple(way) for way in plan.get("blocked", [])]
        plot_graph_map(graph_map, ax=ax, blocked=blocked, path=plan["path"] or None, labels=True)
        ax.set_title(f"plan {k + 1} (after {plan.get('moves', 0)} moves)", fontsize=9)
    figure.suptitle(f"{run['scenario']} · {run['policy']} · met: {run['success']}", fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=90, bbox_inches="tight")
    return path


POLICIES = ("bidir-astar", "bidir-astar-opt", "bidir-astar-eager", "centralized")
SCENARIOS = ("paper003_fig5", "paper003_fig8")


def report(runs: list[dict]) -> str:
    """Markdown: per scenario and policy the plans announced, re-plans and meeting, and the paper's plans."""
    lines = []
    for name in SCENARIOS:
        paper = next(r["paper"] for r in runs if r["scenario"] == name)
        lines.append(f"## {name}\n")
        quoted = [" / ".join("-".join(p) for p in plan["paths"].values()) for plan in paper["plans"]]
        lines.append(f"Paper: {len(quoted) - 1} re-plans, meeting at {paper['meeting']}; plans: " + "; ".join(quoted) + "\n")
        lines.append("| policy | met | meeting time (s) | re-plans | worst optimality | plans announced (robot_0 → robot_1) |")
        lines.append("|---|---|---|---|---|---|")
        for r in (r for r in runs if r["scenario"] == name):
            plans = "; ".join("-".join(p["path"]) for p in r["plans"])
            time = f"{r['meeting_time']:.1f}" if r["meeting_time"] is not None else "–"
            lines.append(f"| {r['policy']} | {r['success']} | {time} | {r['replans']} | {r['worst_optimality']} | {plans} |")
        lines.append("")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results/paper003", help="folder for scenarios.json/.md and the figures")
    parser.add_argument("--figures", default=None, help="also copy the figures and the table here")
    args = parser.parse_args(argv)
    out = Path(args.out)
    runs = [run_scenario(name, policy) for name in SCENARIOS for policy in POLICIES]
    figures = [draw_scenario(r, out / f"{r['scenario']}_{r['policy']}.png") for r in runs if r["policy"] == "bidir-astar"]
    table = report(runs)
    (out / "scenarios.json").write_text(json.dumps([{k: v for k, v in r.items() if k != "trajectories"} for r in runs], indent=1))
    (out / "scenarios.md").write_text(table + "\n")
    print(table)
    if args.figures:
        target = Path(args.figures)
        target.mkdir(parents=True, exist_ok=True)
        for path in [*figures, out / "scenarios.md"]:
            shutil.copy(path, target / path.name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
