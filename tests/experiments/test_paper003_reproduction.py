"""Paper 003's section 6 on Rendezvous-v0: the protocol announces the paper's plans and the robots meet."""

import importlib.util
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "paper003_scenarios.py"
_spec = importlib.util.spec_from_file_location("paper003_scenarios", SCRIPT)
scenarios = importlib.util.module_from_spec(_spec)
sys.modules["paper003_scenarios"] = scenarios
_spec.loader.exec_module(scenarios)
run_scenario = scenarios.run_scenario


def joined(plan):
    """A paper plan (red's path to the meeting place, blue's path to it) as one path from red to blue."""
    red, blue = plan["paths"]["red"], plan["paths"]["blue"]
    return red + blue[::-1][1:]


@pytest.mark.parametrize("policy", ["bidir-astar", "bidir-astar-opt", "centralized"])
def test_fig8_plans_replans_and_meeting(policy):
    run = run_scenario("paper003_fig8", policy)
    assert run["success"] and run["replans"] == 3
    assert [p["path"] for p in run["plans"]] == [joined(p) for p in run["paper"]["plans"]]
    assert run["paper"]["meeting"] in run["places"].values()


@pytest.mark.parametrize("policy", ["bidir-astar", "bidir-astar-opt", "centralized"])
def test_fig5_plans_follow_the_papers_routes(policy):
    run = run_scenario("paper003_fig5", policy)
    assert run["success"]
    announced = [p["path"] for p in run["plans"]]
    # Every plan of the paper is announced, from where the robots stood when it was made.
    for plan in run["paper"]["plans"]:
        route = joined(plan)
        assert any(route[1:-1] == [x for x in path if x in route][1:-1] or set(route) <= set(path) for path in announced), route
    assert run["replans"] == 3 and len(announced) == 4 and "23" in run["places"].values()


def test_cli_writes_the_table_and_figures(tmp_path):
    assert scenarios.main(["--out", str(tmp_path)]) == 0
    assert (tmp_path / "scenarios.md").read_text().count("| bidir-astar |") == 2
    assert (tmp_path / "paper003_fig8_bidir-astar.png").stat().st_size > 0
