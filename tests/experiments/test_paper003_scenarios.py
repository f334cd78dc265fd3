"""The scenarios of paper 003, section 6 (Figs. 5-8), reconstructed as data: every statement of the text holds.

Reading (docs/notes/paper003_maps.md): the robots move one way per step, together; each senses
all the ways at its place; when a robot's next way is known to be blocked both re-plan the
shortest path between them, split at the place ceil(n/2) ways from the red robot.
"""

import math

import networkx as nx
import pytest
import shapely

from teamgym.maps import load_graph_map, validate_graph_map
from teamgym.maps.scenarios import load_scenario

NAMES = ["paper003_fig5", "paper003_fig8"]
TOL = 1e-9


def scenario(name: str) -> dict:
    return load_scenario(name)


def way(a: str, b: str) -> frozenset:
    return frozenset((a, b))


def combined(plan: dict) -> list[str]:
    """The whole planned path, from the red robot's place to the blue robot's."""
    return plan["paths"]["red"] + plan["paths"]["blue"][::-1][1:]


def known_at(sc: dict, step: int) -> set[frozenset]:
    """Blocked ways the robots know after sensing at ``step``."""
    return {way(b["a"], b["b"]) for b in sc["blocked"] if b["detected"][0]["step"] <= step}


def distance(graph: nx.Graph, a: str, b: str, cut: set[frozenset]) -> float:
    view = nx.restricted_view(graph, [], [tuple(w) for w in cut])
    try:
        return nx.dijkstra_path_length(view, a, b, weight="length")
    except nx.NetworkXNoPath:
        return math.inf


def assert_unique_shortest(graph_map, path: list[str], cut: set[frozenset]) -> None:
    """``path`` is a shortest path avoiding ``cut``, and every other path is longer by more than TOL.

    Another path of length <= L must leave out some way of ``path``; so it suffices that removing
    any one of them makes the best path longer.
    """
    graph = graph_map.to_networkx()
    length = sum(graph_map.way(a, b).length for a, b in zip(path, path[1:]))
    assert not {way(a, b) for a, b in zip(path, path[1:])} & cut, f"{path} uses a blocked way"
    assert length <= distance(graph, path[0], path[-1], cut) + TOL, f"{path} is not a shortest path"
    for a, b in zip(path, path[1:]):
        assert distance(graph, path[0], path[-1], cut | {way(a, b)}) > length + TOL, f"{path} ties without {a}-{b}"


def simulate(graph_map, sc: dict, unseen: frozenset = frozenset()) -> dict:
    """Run the protocol on the scenario; return the plans, the first detection of each blocked way and the meeting.

    Each robot checks its next way and the other ways at its place, except the (robot, way)
    pairs in ``unseen``; after a re-plan the robots check their new next ways before moving.
    """
    red, blue = (r["id"] for r in sc["robots"])
    at = {r["id"]: r["start"] for r in sc["robots"]}
    appears = {way(b["a"], b["b"]): b["from_step"] for b in sc["blocked"]}
    known, plans, detections, route = set(), [], {}, None
    for step in range(100):
        while True:
            for robot in (red, blue):
                ahead = way(*route[robot][:2]) if route and len(route[robot]) > 1 else None
                for other in graph_map.neighbours(at[robot]):
                    w = way(at[robot], other)
                    if appears.get(w, math.inf) <= step and w not in known and (w == ahead or (robot, w) not in unseen):
                        detections.setdefault(w, []).append({"step": step, "robot": robot, "place": at[robot]})
            known |= set(detections)
            if route is not None and not any(len(r) > 1 and way(r[0], r[1]) in known for r in route.values()):
                break
            path = graph_map.shortest_path(at[red], at[blue], blocked=[tuple(w) for w in known])
            k = math.ceil((len(path) - 1) / 2)
            route = {red: path[: k + 1], blue: path[k:][::-1]}
            plans.append({"step": step, "paths": {red: list(route[red]), blue: list(route[blue])}, "meeting": path[k]})
        if at[red] == at[blue]:
            return {"plans": plans, "detections": detections, "meeting": at[red], "step": step}
        for robot in (red, blue):
            if len(route[robot]) > 1:
                route[robot] = route[robot][1:]
                at[robot] = route[robot][0]
    raise AssertionError("the robots never meet")


@pytest.fixture(params=NAMES)
def case(request):
    sc = scenario(request.param)
    return load_graph_map(sc["graph"]), sc


def test_files_load_and_validate(case):
    graph_map, sc = case
    validate_graph_map(graph_map)
    assert set(sc) >= {"name", "graph", "description", "robots", "blocked", "plans", "meeting", "meeting_step"}
    assert [r["id"] for r in sc["robots"]] == ["red", "blue"] and [r["agent"] for r in sc["robots"]] == [1, 2]
    for b in sc["blocked"]:
        graph_map.way(b["a"], b["b"])  # the blocked ways exist
        assert b["from_step"] <= b["detected"][0]["step"]
    for plan in sc["plans"]:
        for a, b in zip(combined(plan), combined(plan)[1:]):
            graph_map.way(a, b)


def test_three_replans_and_meeting(case):
    graph_map, sc = case
    assert len(sc["plans"]) == 4  # "the two agents have had to re-plan their path three times"
    assert sc["plans"][-1]["meeting"] == sc["meeting"]
    for plan in sc["plans"]:
        assert plan["paths"]["red"][-1] == plan["paths"]["blue"][-1] == plan["meeting"]


def test_each_plan_is_the_unique_shortest_path_with_the_known_blocked_ways(case):
    graph_map, sc = case
    for plan in sc["plans"]:
        assert_unique_shortest(graph_map, combined(plan), known_at(sc, plan["step"]))


def test_meeting_place_is_half_way_rounded_towards_the_blue_robot(case):
    _, sc = case
    for plan in sc["plans"]:
        path = combined(plan)
        assert path[math.ceil((len(path) - 1) / 2)] == plan["meeting"]


def test_quoted_paths_are_the_plans_from_the_robot_or_the_next_place(case):
    _, sc = case
    for plan in sc["plans"]:
        for robot in ("red", "blue"):
            path, quoted = plan["paths"][robot], plan["quoted"][robot]
            assert quoted in (path, path[1:]), (plan["step"], robot)


def test_simulation_reproduces_the_scenario(case):
    graph_map, sc = case
    run = simulate(graph_map, sc)
    assert run["plans"] == [{k: p[k] for k in ("step", "paths", "meeting")} for p in sc["plans"]]
    assert run["detections"] == {way(b["a"], b["b"]): b["detected"] for b in sc["blocked"]}
    assert (run["meeting"], run["step"]) == (sc["meeting"], sc["meeting_step"])


def test_simulation_with_blocked_ways_present_from_the_detection_step(case):
    """Whether a way is blocked from the start or from when it is found does not change the run."""
    graph_map, sc = case
    moved = dict(sc, blocked=[dict(b, from_step=b["detected"][0]["step"]) for b in sc["blocked"]])
    assert simulate(graph_map, moved)["plans"] == simulate(graph_map, sc)["plans"]


def test_every_blocked_way_changes_the_plan_it_is_found_for(case):
    graph_map, sc = case
    for b in sc["blocked"]:
        step = b["detected"][0]["step"]
        plan = next(p for p in sc["plans"] if p["step"] == step)
        cut = known_at(sc, step) - {way(b["a"], b["b"])}
        assert graph_map.shortest_path(plan["paths"]["red"][0], plan["paths"]["blue"][0], [tuple(w) for w in cut]) != combined(
            plan
        )


def test_ways_do_not_cross_or_pass_through_places(case):
    graph_map, _ = case
    segments = [shapely.LineString([graph_map.place(w.a).pos, graph_map.place(w.b).pos]) for w in graph_map.ways]
    for i, (w, s) in enumerate(zip(graph_map.ways, segments)):
        for v, t in zip(graph_map.ways[i + 1 :], segments[i + 1 :]):
            if not w.ends & v.ends:
                assert not s.intersects(t), (w, v)
        for p in graph_map.places:
            if p.id not in w.ends:
                assert s.distance(shapely.Point(p.pos)) > 0.1, (w, p.id)


# -- Fig. 5-7 --------------------------------------------------------------------------------


def test_fig5_layout_as_described():
    """38 places; weights 1 (horizontal), sqrt 2 (oblique), sqrt 5 for 5-8 and 24-32; one or two successors."""
    graph_map = load_graph_map("paper003_fig5")
    assert graph_map.place_ids == [str(i) for i in range(1, 39)]
    for w in graph_map.ways:
        (xa, ya), (xb, yb) = graph_map.place(w.a).pos, graph_map.place(w.b).pos
        assert abs(xa - xb) == 1.0
        expected = math.sqrt(5) if w.ends in ({"5", "8"}, {"24", "32"}) else (1.0 if ya == yb else math.sqrt(2))
        assert w.length == pytest.approx(expected, abs=TOL), w
    for p in graph_map.places:
        successors = [q for q in graph_map.neighbours(p.id) if graph_map.place(q).x > p.x]
        assert len(successors) in ((1, 2) if p.id != "38" else (0,)), p.id


def test_fig5_first_plan_and_the_searches():
    sc = scenario("paper003_fig5")
    first = sc["plans"][0]
    assert combined(first) == ["1", "2", "4", "11", "17", "21", "27", "33", "36", "38"]
    assert sc["search"]["red"] == first["paths"]["red"]  # Agent 1: "the path from position 1 to 21"
    path = combined(first)
    blue = sc["search"]["blue"]  # Agent 2: "the path from 38 to 11", along the optimal path
    assert blue == path[::-1][: len(blue)] and blue[-1] == "11" and "21" in blue


def test_fig5_blocked_ways():
    graph_map, sc = load_graph_map("paper003_fig5"), scenario("paper003_fig5")
    assert len(sc["blocked"]) == 5  # "five ways were successively detected as being obstructed"
    on_from_4 = {way("4", q) for q in graph_map.neighbours("4") if graph_map.place(q).x > graph_map.place("4").x}
    assert on_from_4 == {way(b["a"], b["b"]) for b in sc["blocked"] if "4" in (b["a"], b["b"])}  # both ways on
    at_34 = [b for b in sc["blocked"] if b["detected"] == [{"step": 12, "robot": "blue", "place": "34"}]]
    assert len(at_34) == 2  # "the blue robot detects the two blocked ways"
    run = simulate(graph_map, sc)
    assert [p["paths"]["red"][0] for p in run["plans"][1:]] == ["4", "16", "7"]
    assert [p["paths"]["blue"][0] for p in run["plans"][1:]] == ["33", "20", "34"]


# -- Fig. 8 ----------------------------------------------------------------------------------


def test_fig8_blue_robot_sees_8_9_and_spares_a_replan():
    """Had the blue robot at 8 not reported 8-9, the plan would go 1-9-8 and be redone when 8-9 is found."""
    graph_map, sc = load_graph_map("paper003_fig8"), scenario("paper003_fig8")
    assert len(graph_map.places) == 9 and sc["meeting"] == sc["robots"][1]["start"]
    without = simulate(graph_map, sc, unseen=frozenset({("blue", way("8", "9"))}))
    assert combined(without["plans"][3]) == ["1", "9", "8"]
    assert len(without["plans"]) == len(sc["plans"]) + 1
    assert combined(without["plans"][4]) == combined(sc["plans"][3])
