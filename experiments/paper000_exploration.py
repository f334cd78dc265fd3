"""Reproduce the experiments of paper 000 (sections 5.2-5.4) and compare exploration planners.

    python experiments/paper000_exploration.py all --out results/paper000 [--seeds 100] [--workers 2] [--check]
        [--figures docs/figures]

Subcommands (each writes JSON and Markdown into ``--out``, figures into ``--out`` and, with
``--figures``, also there):

* ``maps``: drawings of the reconstructed office (Fig. 10; also rebuilt for Table 1) and laboratory
  (Fig. 12) maps.
* ``p2p`` (section 5.2, Figs. 7-9): the behaviour-based controller drives one robot from
  S(50, 650) mm to T(600, 350) mm in room S6 of the lab office; trajectory, behaviour
  activations and controls over time.
* ``table1`` (section 5.3, Table 1): three robots from sectors 4, 9, 2 of the 12-sector
  office, door D3,6 closed (open with probability 0.2 in the model); ``nash-explore``'s
  operator sequence per planning stage with synchronous stages (``stage_end="all"``: the
  paper's table has one operator per robot per stage), compared with Table 1 cell by cell
  (operator and door per robot per stage). The faithful setting is the rebuilt office
  ``office12-table1`` (no door of S9-S11 onto the corridor) with eq. (3)'s ``"return-trip"``
  door reading; beside it the same map with the default ``"per-attempt"`` reading and the
  default map ``office12`` with both stage semantics (``"any"``: the asynchronous stages of
  Fig. 5), and Table 2's lab7 run with both readings. With ``--check`` it exits with status 1 if a
  cell of the faithful run differs from Table 1 (by default it reports the differing cells).
* ``table2`` (section 5.4, Table 2): two robots from sectors 5 and 6 of the lab office;
  stage count against the paper's 11.
* ``compare``: ``--seeds`` episodes with random start sectors and door samplings (seed i for
  episode i) for nash-explore, greedy and random-admissible: success (all 12 sectors within
  3000 control steps = 300 s), planning stages, time to full exploration, team path length.
* ``ablation``: nash-explore's readings of eq. (11) and the two stage semantics on the same
  seeds.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import teamgym
from baselines.episode import Step, run_episode
from baselines.evaluate import evaluate
from baselines.registry import make_policy
from baselines.summary import markdown_table
from teamgym.control.behaviour import BEHAVIOURS, STOP, BehaviourController
from teamgym.maps import load_map
from teamgym.maps.build import build_world
from teamgym.maps.plot import draw_map, save_map_figure
from teamgym.sim import KHEPERA_RING, DiffDriveRobot, ProximityRing, World

PAPER_TABLE1 = [
    ("FD(D3,4)", "FD(D9,10)", "FD(D1,2_1)"),
    ("TD(D3,4,S3)", "TD(D9,10,S10)", "TD(D1,2_1,S1)"),
    ("FD(D2,3)", "FD(D10,11)", "FD(D1,8)"),
    ("TD(D2,3,S2)", "TD(D10,11,S11)", "TD(D1,8,S8)"),
    ("W()", "FD(D11,12)", "GT(S7)"),
    ("W()", "TD(D10,11,S12)", "GT(S6)"),
    ("W()", "W()", "GT(S5)"),
]
PAPER_TABLE2 = [
    ("GoTo(S4)", "FindDoor(D4)"),
    ("GoTo(S4)", "TraverseDoor(D4,S8)"),
    ("FindDoor(D3)", "TraverseDoor(D4,S8)"),
    ("FindDoor(D3)", "FindDoor(D6)"),
    ("TraverseDoor(D3,S1)", "FindDoor(D6)"),
    ("FindDoor(D1)", "FindDoor(D6)"),
    ("FindDoor(D1)", "TraverseDoor(D6,S7)"),
    ("FindDoor(D1)", "Wait()"),
    ("TraverseDoor(D1,S2)", "Wait()"),
    ("FindDoor(D2)", "Wait()"),
    ("TraverseDoor(D2,S3)", "Wait()"),
]
#: Table 1's stage 6 for robot 2 reads TD(D10,11,S12): D10,11 joins S10 and S11 and cannot lead
#: into S12, and the robot found D11,12 in stage 5, so the comparison reads it as TD(D11,12,S12).
PAPER_TABLE1_ERRATA = {(6, 2): "TD(D11,12,S12)"}
TABLE1_SETTING = {"start_sectors": ("S4", "S9", "S2"), "start_positions": "centre", "closed_doors": ("D3,6",)}
#: The faithful Table 1 setting: the rebuilt office and eq. (3)'s return-trip door reading.
TABLE1_MAP = "office12-table1"
TABLE1_POLICY = {"door_reading": "return-trip"}
TABLE2_SETTING = {"map": "lab7", "n_robots": 2, "start_sectors": ("S5", "S6"), "start_positions": "centre"}
POLICIES = ("nash-explore", "greedy", "random-admissible")


def _figure(width: float, height: float):
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height))


def _save(fig, name: str, out: Path, figures: Path | None) -> None:
    fig.tight_layout()
    fig.savefig(out / name, dpi=110)
    if figures is not None:
        figures.mkdir(parents=True, exist_ok=True)
        shutil.copy(out / name, figures / name)


# -- maps ----------------------------------------------------------------------------------------
def experiment_maps(out: Path, figures: Path | None, seeds: int, workers: int) -> dict:
    rows = []
    for name, title in (
        ("office12", "office12: paper 000, Fig. 10 (reconstructed)"),
        ("office12-table1", "office12-table1: Fig. 10 rebuilt for Table 1"),
        ("lab7", "lab7: paper 000, Fig. 12 (reconstructed)"),
    ):
        office = load_map(name)
        save_map_figure(office, out / f"map_{name}.png", title)
        if figures is not None:
            figures.mkdir(parents=True, exist_ok=True)
            shutil.copy(out / f"map_{name}.png", figures / f"map_{name}.png")
        rows.append(
            {
                "map": name,
                "size_mm": f"{office.size[0] * 1000:.0f} x {office.size[1] * 1000:.0f}",
                "sectors": len(office.sectors),
                "doors": len(office.doors),
                "furniture": len(office.furniture),
            }
        )
    return {"rows": rows}


# -- section 5.2 ---------------------------------------------------------------------------------
def experiment_p2p(out: Path, figures: Path | None, seeds: int, workers: int) -> dict:
    office = load_map("lab7")
    world = World(office.size)
    build_world(office, world)
    start, target = (0.05, 0.65), (0.6, 0.35)
    robot = world.add(DiffDriveRobot("robot", start, 0.0))
    ring = ProximityRing(KHEPERA_RING, 0.1)
    controller = BehaviourController(record=True)
    path, contacts = [start], 0
    for _ in range(600):
        step = controller.step(robot.pose, ring.read(robot, world.space), target)
        robot.set_command(*step.command)
        world.step()
        contacts += len(world.contacts_of("robot"))
        path.append(robot.position)
        if step.winner == STOP:
            break
    activations, winners, controls = controller.activation_history()
    path = np.array(path)
    t = 0.1 * np.arange(len(activations))
    fig = _figure(5.5, 6)
    ax = fig.add_subplot(1, 1, 1)
    draw_map(office, ax, labels=True)
    ax.plot(path[:, 0] * 1000, path[:, 1] * 1000, color="C0", lw=1.8)
    ax.plot(start[0] * 1000, start[1] * 1000, "o", color="C0")
    ax.plot(target[0] * 1000, target[1] * 1000, "x", color="C3", ms=10)
    ax.set_title("Section 5.2 (Fig. 7): S(50, 650) mm to T(600, 350) mm")
    _save(fig, "p2p_trajectory.png", out, figures)
    fig = _figure(8, 6)
    for k, name in enumerate(BEHAVIOURS):
        ax = fig.add_subplot(len(BEHAVIOURS) + 1, 1, k + 1)
        ax.plot(t, activations[:, k], color=f"C{k}")
        ax.fill_between(t, 0, 1, where=winners == k, color=f"C{k}", alpha=0.2, step="mid")
        ax.set_ylim(-0.05, 1.05)
        ax.set_ylabel(name.replace("_", "\n"), fontsize=7, rotation=0, ha="right", va="center")
        ax.tick_params(labelsize=6, labelbottom=False)
    ax = fig.add_subplot(len(BEHAVIOURS) + 1, 1, len(BEHAVIOURS) + 1)
    ax.step(t, winners, where="mid", color="k")
    ax.set_yticks(range(len(BEHAVIOURS))[::2], [b.replace("_", " ") for b in BEHAVIOURS][::2], fontsize=5)
    ax.set_ylabel("winner", fontsize=7, rotation=0, ha="right", va="center")
    ax.set_xlabel("time (s), sample time 0.1 s")
    fig.suptitle("Section 5.2 (Fig. 8): behaviour activations a_i (shaded: winner of eq. 5)", fontsize=9)
    _save(fig, "p2p_activations.png", out, figures)
    fig = _figure(8, 3.5)
    for k, label in enumerate(("v (m/s)", "ω (rad/s)")):
        ax = fig.add_subplot(2, 1, k + 1)
        ax.plot(t, controls[:, k])
        ax.set_ylabel(label)
    ax.set_xlabel("time (s)")
    fig.suptitle("Section 5.2 (Fig. 9): controls of eq. (6)", fontsize=9)
    _save(fig, "p2p_controls.png", out, figures)
    length = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
    share = {BEHAVIOURS[k]: round(float(np.mean(winners == k)), 3) for k in range(len(BEHAVIOURS))}
    row = {
        "reached (within 2.5 cm)": bool(math.dist(path[-1], target) < 0.025),
        "final distance (mm)": round(1000 * math.dist(path[-1], target), 1),
        "time (s)": round(float(t[-1] + 0.1), 1),
        "path length (m)": round(length, 3),
        "straight line (m)": round(math.dist(start, target), 3),
        "contacts": contacts,
    }
    return {"rows": [row], "winner_share": share}


# -- sections 5.3 and 5.4 --------------------------------------------------------------------------
def operator_sequence(config: dict[str, Any], policy_name: str = "nash-explore", seed: int = 0, **policy_kwargs: Any) -> dict:
    """Play one operator episode; return the operator names per stage and the final metrics."""
    env = teamgym.make("Exploration-v0", action_type="operator", **config)
    policy = make_policy(policy_name, env, **policy_kwargs)
    rows, explored = [], []

    def record(step: Step) -> None:
        rows.append([env.operators[step.actions[a]] for a in step.agents])
        explored.append(int(step.infos["robot_0"]["explored"]))

    result = run_episode(env, policy, seed, on_step=record, record_trajectories=False)
    final = result.metrics["robot_0"]
    return {
        "short": [[op.short for op in row] for row in rows],
        "long": [[op.name for op in row] for row in rows],
        "explored": explored,
        "success": result.success,
        "stages": int(final["stages"]),
        "explore_time_s": final.get("explore_time"),
        "team_path_length_m": round(float(final["team_path_length"]), 3),
        "tasks_failed": [int(result.metrics[a]["tasks_failed"]) for a in env.possible_agents],
        "trajectories": env.trajectories(),
    }


def _sequence_table(rows: list[list[str]], paper: list[tuple[str, ...]], explored: list[int]) -> str:
    n = len(rows[0]) if rows else len(paper[0])
    head = (
        "| n | "
        + " | ".join(f"robot {i + 1}" for i in range(n))
        + " | explored | paper: "
        + " | ".join(f"robot {i + 1}" for i in range(n))
        + " |"
    )
    lines = [head, "|" + "---|" * (2 * n + 2)]
    for k in range(max(len(rows), len(paper))):
        ours = rows[k] if k < len(rows) else [""] * n
        theirs = paper[k] if k < len(paper) else ("",) * n
        seen = str(explored[k]) if k < len(explored) else ""
        lines.append(f"| {k + 1} | " + " | ".join(ours) + f" | {seen} | " + " | ".join(theirs) + " |")
    return "\n".join(lines)


def _plot_episode(path: Path, map_name: str, result: dict, title: str, figures: Path | None, out: Path) -> None:
    fig = _figure(7, 5.5)
    ax = fig.add_subplot(1, 1, 1)
    draw_map(load_map(map_name), ax, labels=True)
    for i, points in enumerate(result["trajectories"].values()):
        pts = np.asarray(points) * 1000
        ax.plot(pts[:, 0], pts[:, 1], color=f"C{i}", lw=1.6, label=f"robot {i + 1}")
        ax.plot(*pts[0], "o", color=f"C{i}")
    ax.legend(fontsize=7, loc="upper right")
    ax.set_title(title, fontsize=9)
    _save(fig, path.name, out, figures)


def table1_differences(rows: list[list[str]]) -> list[dict[str, Any]]:
    """Every cell (stage n, robot i) where ``rows`` differs from Table 1 (after :data:`PAPER_TABLE1_ERRATA`).

    A stage missing on either side counts as differing cells (an empty string stands for it).
    """
    n_robots = len(PAPER_TABLE1[0])
    cells = []
    for k in range(max(len(rows), len(PAPER_TABLE1))):
        for i in range(n_robots):
            ours = rows[k][i] if k < len(rows) else ""
            printed = PAPER_TABLE1[k][i] if k < len(PAPER_TABLE1) else ""
            paper = PAPER_TABLE1_ERRATA.get((k + 1, i + 1), printed)
            if ours != paper:
                cells.append({"stage": k + 1, "robot": i + 1, "ours": ours, "paper": paper})
    return cells


TABLE1_VARIANTS = (
    ("faithful", TABLE1_MAP, TABLE1_POLICY, "all"),
    ("rebuilt map, per-attempt", TABLE1_MAP, {"door_reading": "per-attempt"}, "all"),
    ("office12 (default)", "office12", {}, "all"),
    ("office12 (default), Fig. 5 stages", "office12", {}, "any"),
)


def experiment_table1(out: Path, figures: Path | None, seeds: int, workers: int) -> dict:
    result: dict[str, Any] = {"rows": [], "tables": {}, "beside": []}
    cells = len(PAPER_TABLE1) * len(PAPER_TABLE1[0])
    for label, map_name, policy_kwargs, stage_end in TABLE1_VARIANTS:
        run = operator_sequence({**TABLE1_SETTING, "map": map_name, "stage_end": stage_end}, **policy_kwargs)
        differences = table1_differences(run["short"])
        unequal = sum(d["stage"] <= len(PAPER_TABLE1) for d in differences)
        result["tables"][label] = _sequence_table(run["short"], PAPER_TABLE1, run["explored"])
        result["rows"].append(
            {
                "setting": label,
                "map": map_name,
                "door_reading": policy_kwargs.get("door_reading", "per-attempt"),
                "stage_end": stage_end,
                "stages": run["stages"],
                "paper stages": len(PAPER_TABLE1),
                "cells equal": f"{cells - unequal}/{cells}" if stage_end == "all" else "–",
                "success": run["success"],
                "explore_time_s": run["explore_time_s"],
                "team_path_length_m": run["team_path_length_m"],
                "tasks_failed": sum(run["tasks_failed"]),
            }
        )
        if label == "faithful":
            result["differences"] = differences
            _plot_episode(
                out / "table1_trajectories.png",
                map_name,
                run,
                "Section 5.3: nash-explore from S4, S9, S2 (D3,6 closed), office12-table1, return-trip",
                figures,
                out,
            )
    for reading in ("return-trip", "per-attempt"):  # Table 2 beside it: lab7's doors are all open (o = 1)
        run = operator_sequence({**TABLE2_SETTING, "stage_end": "any"}, door_reading=reading)
        result["beside"].append(
            {
                "Table 2 (lab7)": "stage_end=any",
                "door_reading": reading,
                "stages": run["stages"],
                "paper stages": len(PAPER_TABLE2),
                "success": run["success"],
                "explore_time_s": run["explore_time_s"],
            }
        )
    return result


def experiment_table2(out: Path, figures: Path | None, seeds: int, workers: int) -> dict:
    result: dict[str, Any] = {"rows": [], "tables": {}}
    for stage_end in ("any", "all"):
        run = operator_sequence({**TABLE2_SETTING, "stage_end": stage_end})
        result["tables"][stage_end] = _sequence_table(run["long"], PAPER_TABLE2, run["explored"])
        result["rows"].append(
            {
                "stage_end": stage_end,
                "stages": run["stages"],
                "paper stages": len(PAPER_TABLE2),
                "success": run["success"],
                "explore_time_s": run["explore_time_s"],
                "team_path_length_m": run["team_path_length_m"],
                "tasks_failed": sum(run["tasks_failed"]),
            }
        )
        if stage_end == "any":
            _plot_episode(out / "table2_trajectories.png", "lab7", run, "Section 5.4: nash-explore from S5, S6", figures, out)
    return result


# -- comparison over seeds ---------------------------------------------------------------------
def _summary(name: str, results: list) -> dict:
    first = [next(iter(r.metrics.values())) for r in results]
    success = [r.success for r in results]
    stages = [m["stages"] for m in first]
    times = [m["explore_time"] for m, ok in zip(first, success) if ok]
    return {
        "policy": name,
        "episodes": len(results),
        "success": float(np.mean(success)),
        "stages (mean, all)": float(np.mean(stages)),
        "stages (successful)": float(np.mean([s for s, ok in zip(stages, success) if ok])) if times else math.nan,
        "stages (median)": float(np.median(stages)),
        "time to full exploration (s)": float(np.mean(times)) if times else math.nan,
        "team path length (m)": float(np.mean([m["team_path_length"] for m in first])),
        "explored fraction": float(np.mean([m["explored_fraction"] for m in first])),
        "failed tasks / episode": float(np.mean([sum(x["tasks_failed"] for x in r.metrics.values()) for r in results])),
    }


def experiment_compare(out: Path, figures: Path | None, seeds: int, workers: int) -> dict:
    rows = []
    for name in POLICIES:
        started = time.perf_counter()
        results = evaluate("Exploration-v0", name, episodes=seeds, seed=0, workers=workers)
        row = _summary(name, results)
        row["wall (s)"] = round(time.perf_counter() - started, 1)
        rows.append(row)
        print(f"  {name}: {row}", flush=True)
    return {"rows": rows}


def experiment_ablation(out: Path, figures: Path | None, seeds: int, workers: int) -> dict:
    rows = []
    variants = [
        ("assigned (default)", {}, {}),
        ("after", {"unexplored": "after"}, {}),
        ("before (literal)", {"unexplored": "before"}, {}),
        ("assigned, stage_end=all", {}, {"stage_end": "all"}),
        ("assigned, selection=first", {"selection": "first"}, {}),
    ]
    for label, policy_kwargs, config in variants:
        runs = [operator_sequence(config, "nash-explore", s, **policy_kwargs) for s in range(seeds)]
        ok = [r["success"] for r in runs]
        rows.append(
            {
                "variant": label,
                "success": float(np.mean(ok)),
                "stages": float(np.mean([r["stages"] for r in runs])),
                "time to full exploration (s)": float(np.mean([r["explore_time_s"] for r in runs if r["success"]]))
                if any(ok)
                else math.nan,
                "team path length (m)": float(np.mean([r["team_path_length_m"] for r in runs])),
            }
        )
        print(f"  {rows[-1]}", flush=True)
    return {"rows": rows}


# -- CLI -----------------------------------------------------------------------------------------
EXPERIMENTS = {
    "maps": experiment_maps,
    "p2p": experiment_p2p,
    "table1": experiment_table1,
    "table2": experiment_table2,
    "compare": experiment_compare,
    "ablation": experiment_ablation,
}


def _differences_text(differences: list[dict[str, Any]]) -> str:
    errata = "; ".join(
        f"stage {n}, robot {i}: {PAPER_TABLE1[n - 1][i - 1]} read as {v}" for (n, i), v in PAPER_TABLE1_ERRATA.items()
    )
    if not differences:
        return f"\nEvery cell of Table 1 is reproduced in the faithful setting (erratum: {errata}).\n"
    cells = "; ".join(
        f"stage {d['stage']}, robot {d['robot']}: ours {d['ours'] or '–'}, paper {d['paper'] or '–'}" for d in differences
    )
    return f"\nFaithful setting: {len(differences)} cell(s) differ from Table 1: {cells} (erratum: {errata}).\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Reproduce paper 000's experiments (sections 5.2-5.4) and compare planners.")
    parser.add_argument("experiment", choices=[*EXPERIMENTS, "all"])
    parser.add_argument("--out", type=Path, default=Path("results/paper000"))
    parser.add_argument("--seeds", type=int, default=100, help="episodes (seeds 0..N-1) for compare and ablation")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--figures", type=Path, default=None, help="also copy the figures here (e.g. docs/figures)")
    parser.add_argument(
        "--check",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="exit with status 1 if table1's faithful run differs from Table 1 in any cell (default: report only)",
    )
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    names = list(EXPERIMENTS) if args.experiment == "all" else [args.experiment]
    status = 0
    for name in names:
        result = EXPERIMENTS[name](args.out, args.figures, args.seeds, args.workers)
        serialisable = {k: v for k, v in result.items() if k != "trajectories"}
        (args.out / f"{name}.json").write_text(json.dumps(serialisable, indent=2, default=str))
        text = f"## {name}\n\n{markdown_table(result['rows'])}\n"
        for key, table in result.get("tables", {}).items():
            text += f"\n{key if name == 'table1' else f'stage_end={key}'}:\n\n{table}\n"
        if "differences" in result:
            text += _differences_text(result["differences"])
            status = 1 if args.check and result["differences"] else status
        if result.get("beside"):
            text += f"\nBeside it, Table 2 on lab7:\n\n{markdown_table(result['beside'])}\n"
        if "winner_share" in result:
            text += "\nShare of control steps won by each behaviour: " + json.dumps(result["winner_share"]) + "\n"
        (args.out / f"{name}.md").write_text(text)
        print(text, flush=True)
    return status


if __name__ == "__main__":
    sys.exit(main())
