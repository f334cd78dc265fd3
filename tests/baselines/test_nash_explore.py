"""The nash-explore planner (paper 000, eqs. 7-13), greedy and random-admissible baselines."""

import itertools
import math

import numpy as np
import pytest

import teamgym
from baselines.evaluate import evaluate
from baselines.exploration.nash_explore import UNREACHABLE, NashExplore, assignment_cost
from baselines.exploration.planning import TeamView, team_view
from baselines.exploration.policies import GreedyExplore, RandomAdmissible
from baselines.registry import make_policy, required_config
from baselines.summary import summarise
from teamgym.maps.topology import TopologicalModel


def operator_env(**config):
    return teamgym.make("Exploration-v0", action_type="operator", **config)


def hand_view(env, places, explored):
    """A planning stage built by hand: robots at ``places`` (vertex ids), sectors ``explored``."""
    model = TopologicalModel(env.map)
    index = env.operator_set.index
    at = np.array([index[p] for p in places])
    masks = np.array([env.operator_set.admissible(int(k), model.cost).astype(bool) for k in at])
    return TeamView(
        agents=[f"robot_{i}" for i in range(len(places))],
        places=at,
        masks=masks,
        running=np.full(len(places), -1),
        visited=np.array([s in explored for s in env.map.sector_ids]),
        goal=np.ones(len(env.map.sectors), dtype=bool),
        model=model,
        operators=env.operator_set,
        costs=model.path_costs(),
    )


def reference_cost(policy, view, joint):
    """Eqs. (7)-(11) for one joint action, written out term by term."""
    n_sectors = view.model.n_sectors
    ops = [int(a) for a in joint]
    nxt = [view.operators.next_place(op, int(view.places[i])) for i, op in enumerate(ops)]
    i_r = 0.0
    for target in nxt:
        if target < n_sectors and view.goal[target] and not view.visited[target]:
            i_r += policy.reward / nxt.count(target)
    i_e = 0.0
    for i, op in enumerate(ops):
        if op == 0:
            i_e += policy.wait_cost
        else:
            w = view.model.cost(int(view.places[i]), nxt[i])
            w = w if math.isfinite(w) else view.costs[view.places[i], nxt[i]]
            i_e += w if math.isfinite(w) else UNREACHABLE
    unexplored = [u for u in range(n_sectors) if view.goal[u] and not view.visited[u]]
    if policy.unexplored != "before":
        unexplored = [u for u in unexplored if u not in nxt]
    if policy.unexplored == "assigned":
        best = (0, 0.0)
        for choice in itertools.product([None, *unexplored], repeat=len(nxt)):
            taken = [u for u in choice if u is not None]
            if len(set(taken)) < len(taken):
                continue
            costs = [view.costs[nxt[i], u] for i, u in enumerate(choice) if u is not None]
            if not all(math.isfinite(c) for c in costs):
                continue
            best = min(best, (-len(costs), sum(costs)))
        i_d = best[1]
    else:
        i_d = 0.0
        for target in nxt:
            finite = [view.costs[target, u] for u in unexplored if math.isfinite(view.costs[target, u])]
            i_d += min(finite) if finite else 0.0
    return -i_r + i_e + i_d


def stages_of(policy_name, seed, **config):
    env = operator_env(**config)
    policy = make_policy(policy_name, env)
    observations, infos = env.reset(seed=seed)
    policy.reset(seed)
    views = []
    while env.agents:
        if isinstance(policy, NashExplore):
            views.append(team_view(env, TopologicalModel(env.map), observations, infos))
        observations, _, _, _, infos = env.step(policy.act(observations, infos))
    return views, infos


@pytest.mark.parametrize("reading", ["assigned", "after", "before"])
def test_team_cost_matches_eqs_7_to_11(reading):
    env = operator_env()
    policy = NashExplore(env, unexplored=reading)
    views, _ = stages_of("nash-explore", seed=3)
    for view in views[:6] + [hand_view(env, ["D1,8", "D8,12", "S3"], {"S1", "S2", "S3", "S12"})]:
        candidates = [np.flatnonzero(m) for m in view.masks]
        cost = policy.team_cost(view, candidates)
        for joint in itertools.product(*[range(len(c)) for c in candidates]):
            ops = [candidates[i][j] for i, j in enumerate(joint)]
            assert cost[joint] == pytest.approx(reference_cost(policy, view, ops), abs=1e-9)


def test_solution_is_the_team_optimum_eq13():
    env = operator_env()
    policy = NashExplore(env)
    views, _ = stages_of("nash-explore", seed=5)
    for view in views[:8]:
        actions = policy.decide(view)
        cost = policy.last_game["cost"]
        result = policy.last_game["result"]
        assert cost[result.actions] == pytest.approx(cost.min())
        assert result.branch.startswith("nash")  # a team game always has a pure equilibrium
        assert all(view.masks[i][actions[a]] for i, a in enumerate(view.agents))


def test_reward_is_shared_so_only_one_robot_enters_a_room():
    env = operator_env()
    explored = {s for s in env.map.sector_ids if s not in ("S8", "S5")}
    view = hand_view(env, ["D1,8", "D8,12"], explored)  # both at doors of the unexplored S8
    nash = NashExplore(env).decide(view)
    names = [env.operators[a].name for a in nash.values()]
    assert names.count("TraverseDoor(D1,8,S8)") + names.count("TraverseDoor(D8,12,S8)") == 1
    greedy = GreedyExplore(env).decide(view)  # no coordination: both go in
    assert sorted(env.operators[a].name for a in greedy.values()) == ["TraverseDoor(D1,8,S8)", "TraverseDoor(D8,12,S8)"]


def test_robots_with_nothing_left_to_do_wait():
    env = operator_env()
    explored = set(env.map.sector_ids) - {"S4"}
    view = hand_view(env, ["S12", "S3", "S9"], explored)
    actions = NashExplore(env).decide(view)
    assert [env.operators[actions[a]].name for a in view.agents] == ["Wait()", "FindDoor(D3,4)", "Wait()"]
    # with every robot's plain nearest object (reading "before") they all head for S4
    plain = NashExplore(env, unexplored="before").decide(view)
    assert all(env.operators[a].kind != "wait" for a in plain.values())


def test_default_reward_and_parameters():
    env = operator_env()
    policy = NashExplore(env)
    model = TopologicalModel(env.map)
    diameter = model.path_costs()[:12, :12].max()
    assert policy.reward == pytest.approx(4 * diameter)
    assert NashExplore(env, reward=2.0).reward == 2.0
    for kwargs, fragment in [
        ({"unexplored": "nearest"}, "unexplored"),
        ({"selection": "best"}, "selection"),
        ({"reward": -1}, "reward"),
        ({"door_reading": "squared"}, "door_reading"),
    ]:
        with pytest.raises(ValueError, match=fragment):
            NashExplore(env, **kwargs)
    for cls in (NashExplore, GreedyExplore, RandomAdmissible):
        with pytest.raises(ValueError, match="action_type='operator'"):
            cls(teamgym.make("Exploration-v0"))
    assert required_config("nash-explore") == {"action_type": "operator"}


@pytest.mark.parametrize("reading", ["per-attempt", "return-trip"])
def test_door_reading_reaches_the_planner_costs(reading):
    """nash-explore's model prices D3,6 (o = 0.2) by the chosen reading of eq. (3); per-attempt is the default."""
    env = operator_env()
    policy = NashExplore(env, door_reading=reading) if reading != "per-attempt" else NashExplore(env)
    assert policy.model.door_reading == reading
    model = policy.model
    s3, d36 = model.index["S3"], model.index["D3,6"]
    length = model.graph.edges["S3", "D3,6"]["length"]
    trips = {"per-attempt": 1.0, "return-trip": 1.8}[reading]
    assert model.cost(s3, d36) == pytest.approx(length * trips / (0.9 * 0.2))  # c(S3) = 0.1
    policy.act(*env.reset(seed=0))
    assert policy.last_game["view"].model is model  # the stage's costs come from that model


def test_assignment_cost():
    inf = math.inf
    costs = np.array([[[1.0, 2.0], [1.5, 10.0]], [[inf, 3.0], [inf, inf]], [[inf, inf], [inf, inf]]])
    # 1: robot 0 -> object 1, robot 1 -> object 0 (2 + 1.5 < 1 + 10); 2: only one object reachable; 3: none
    np.testing.assert_allclose(assignment_cost(costs), [3.5, 3.0, 0.0])


def test_nash_explores_with_fewer_stages_than_greedy():
    seeds = range(6)
    nash = [stages_of("nash-explore", s)[1]["robot_0"] for s in seeds]
    greedy = [stages_of("greedy", s)[1]["robot_0"] for s in seeds]
    assert all(i["explored_all"] for i in nash + greedy)
    assert np.mean([i["stages"] for i in nash]) < np.mean([i["stages"] for i in greedy])


def test_table2_setting_first_stages_match_the_paper():
    """Section 5.4: robots in S5 and S6 of the lab office; Table 2 starts GoTo(S4) | FindDoor(D4)."""
    env = operator_env(map="lab7", n_robots=2, start_sectors=("S5", "S6"), start_positions="centre")
    policy = NashExplore(env)
    observations, infos = env.reset(seed=0)
    rows = []
    while env.agents:
        actions = policy.act(observations, infos)
        rows.append(tuple(env.operators[actions[a]].name for a in env.agents))
        observations, _, _, _, infos = env.step(actions)
    assert rows[:3] == [
        ("GoTo(S5,S4)", "FindDoor(D4)"),
        ("GoTo(S5,S4)", "TraverseDoor(D4,S5)"),
        ("FindDoor(D3)", "TraverseDoor(D4,S5)"),
    ]
    assert infos["robot_0"]["explored_all"]


def test_random_admissible_and_evaluate_cli_path():
    results = evaluate("Exploration-v0", "random-admissible", episodes=2, seed=0, config={"max_cycles": 300})
    assert len(results) == 2 and all(r.length > 0 for r in results)
    summary = summarise(evaluate("Exploration-v0", "nash-explore", episodes=2, seed=0))
    assert summary["success_rate"] == 1.0 and summary["mean_explored_fraction"] == 1.0
    assert summary["metrics"]["stages"]["count"] == 6
    env = operator_env()
    policy = RandomAdmissible(env)
    observations, infos = env.reset(seed=1)
    policy.reset(1)
    for _ in range(10):
        actions = policy.act(observations, infos)
        assert all(infos[a]["action_mask"][op] for a, op in actions.items())
        observations, _, _, _, infos = env.step(actions)
