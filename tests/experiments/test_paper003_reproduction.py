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


PROTOCOLS = ["bidir-astar", "bidir-astar-opt"]

# Where each plan starts (red robot, blue robot), as section 6 tells it. Figs. 5-7: from 1 and 38;
# "when the red robot is in the position 4", the blue one at 33 (its plan is quoted from its next
# place, 36 - 32 - 25 - 20); at 16 and 20, the ends of the "further blocked way (16 - 20)" (plans
# quoted from the next places 9 and 25); "until the first robot is in the position 7 and the
# second robot is in the position 34".
FIG5_STARTS = [("1", "38"), ("4", "33"), ("16", "20"), ("7", "34")]
# Fig. 8: from 1 and 5; "when reaching the positions 3 and respectively 4"; "when the robots are
# in the positions 2 and 5"; "after two movement steps" the red robot is at 1, the blue one at 8.
FIG8_STARTS = [("1", "5"), ("3", "4"), ("2", "5"), ("1", "8")]


def starts(run):
    return [(p["path"][0], p["path"][-1]) for p in run["plans"]]


@pytest.mark.parametrize("policy", [*PROTOCOLS, "centralized"])
def test_fig8_plans_replans_and_meeting(policy):
    run = run_scenario("paper003_fig8", policy)
    assert run["success"] and run["replans"] == 3
    assert starts(run) == FIG8_STARTS
    assert [p["path"] for p in run["plans"]] == [joined(p) for p in run["paper"]["plans"]]
    assert run["paper"]["meeting"] in run["places"].values()


@pytest.mark.parametrize("policy", [*PROTOCOLS, "centralized"])
def test_fig5_every_plan_is_the_papers_from_where_the_paper_starts_it(policy):
    """All four plans of Figs. 5-7, the fourth from place 7 (section 5: execution ends at the next position)."""
    run = run_scenario("paper003_fig5", policy)
    assert run["success"] and run["replans"] == 3
    assert starts(run) == FIG5_STARTS
    assert [p["path"] for p in run["plans"]] == [joined(p) for p in run["paper"]["plans"]]
    assert run["plans"][-1]["path"][:6] == ["7", "3", "6", "14", "19", "23"]  # "7 - 3 - 6 - 14 - 19 - 23"
    assert "23" in run["places"].values()


@pytest.mark.parametrize("name", ["paper003_fig5", "paper003_fig8"])
@pytest.mark.parametrize("policy", PROTOCOLS)
def test_protocol_plans_after_as_many_moves_as_the_paper(name, policy):
    """Robots set off together on a plan and stop where the partner's request finds them: the paper's lockstep."""
    run = run_scenario(name, policy)
    assert [p["moves"] for p in run["plans"]] == [p["step"] for p in run["paper"]["plans"]]


def test_eager_execution_runs_two_places_on_before_the_fourth_plan():
    """The former timing (``execution="eager"``): the red robot moves while the PATH, then the REPLAN, travel."""
    run = run_scenario("paper003_fig5", "bidir-astar-eager")
    assert run["success"] and run["replans"] == 3
    assert starts(run) == FIG5_STARTS[:3] + [("18", "34")]
    assert run["plans"][-1]["path"][:3] == ["18", "13", "7"]


def test_cli_writes_the_table_and_figures(tmp_path):
    assert scenarios.main(["--out", str(tmp_path)]) == 0
    assert (tmp_path / "scenarios.md").read_text().count("| bidir-astar |") == 2
    assert (tmp_path / "paper003_fig8_bidir-astar.png").stat().st_size > 0
