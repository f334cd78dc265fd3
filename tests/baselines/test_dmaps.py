"""DMAPS (paper 002) and random-walk on Foraging-v0: allocation, potential fields, behaviour, episodes."""

import itertools

import numpy as np
import pytest

import teamgym
from baselines import run_episode
from baselines.foraging.allocation import distances, greedy_pairs, surround_groups
from baselines.foraging.dmaps import DMAPS, DMAPSParams
from baselines.foraging.potential import FieldParams, PotentialField
from baselines.registry import make_policy, policies, required_config
from teamgym.envs.foraging.grid import GridSpec
from teamgym.envs.foraging.world_model import ROBOT, SENDER, TARGET, TARGET_LAYER

GRID = GridSpec(3.0, 2.4, 0.2)
NX = GRID.nx


def flat(gx, gy):
    return gy * NX + gx


# -- allocation (section 4.1) ------------------------------------------------------------------


def repeated_argmin(robots, targets):
    d = distances(robots, targets)
    out = np.full(len(robots), -1)
    for _ in range(min(d.shape)):
        i, j = np.unravel_index(np.argmin(d), d.shape)
        out[i] = j
        d[i, :] = np.inf
        d[:, j] = np.inf
    return out


def test_greedy_pairs_is_the_shortest_distance_method():
    rng = np.random.default_rng(0)
    for m, k in itertools.product((1, 2, 4), (0, 1, 3, 6)):
        for _ in range(20):
            robots, targets = rng.uniform(0, 3, (m, 2)), rng.uniform(0, 3, (k, 2))
            assert greedy_pairs(robots, targets).tolist() == repeated_argmin(robots, targets).tolist()


def test_greedy_pairs_is_not_nearest_target_per_robot():
    # Robot 0 is nearest to both targets; robot 1 gets the other one (not the one nearest to it).
    robots, targets = [(0.0, 0.0), (2.0, 0.0)], [(0.5, 0.0), (1.4, 0.0)]
    assert greedy_pairs(robots, targets).tolist() == [0, 1]
    assert greedy_pairs(robots[:1], targets).tolist() == [0]
    assert greedy_pairs(robots, targets[:1]).tolist() == [0, -1]
    # Ties go to the lower robot index, so every robot computes the same pairing.
    assert greedy_pairs([(1.0, 0.0), (-1.0, 0.0)], [(0.0, 0.0)]).tolist() == [0, -1]


def test_surround_groups():
    robots = [(0.0, 0.0), (0.2, 0.0), (3.0, 0.0)]
    assert surround_groups(robots, [(0.1, 0.5)], 2).tolist() == [0, 0, -1]
    assert surround_groups(robots, [(0.1, 0.5), (2.8, 0.2)], 2).tolist() == [0, 0, 1]  # a smaller group still goes
    assert surround_groups(robots[:1], [(0.1, 0.5), (2.8, 0.2)], 2).tolist() == [0]  # the team may be bigger than seen
    assert surround_groups(robots, [], 2).tolist() == [-1, -1, -1]
    assert surround_groups(robots, [(0.1, 0.5)], 3).tolist() == [0, 0, 0]


# -- potential fields (section 3.1, Figs. 4-5) -----------------------------------------------------------


def test_approach_field_peaks_at_the_target():
    field = PotentialField(GRID)
    fitness = field.approach((7, 4))
    assert field.best(fitness) == flat(7, 4)
    mask = np.ones(GRID.n_cells, dtype=np.int8)
    mask[flat(7, 4)] = 0
    best = field.best(fitness, mask)
    assert best != flat(7, 4) and max(abs(best % NX - 7), abs(best // NX - 4)) == 1


def test_search_field_prefers_unseen_near_cells_and_avoids_teammates():
    field = PotentialField(GRID, FieldParams(turn_cost=0.0))
    last_seen = np.full(GRID.shape, -np.inf)
    last_seen[:, :8] = 100.0  # the left half was just seen
    fitness = field.search(100.0, last_seen, np.array([0.5, 1.2, 0.0]))
    goal = field.best(fitness)
    assert goal % NX == 8  # the nearest unseen column
    # A teammate standing there pushes the goal away.
    crowded = field.search(100.0, last_seen, np.array([0.5, 1.2, 0.0]), np.array([[1.7, 1.3]]))
    assert abs(field.best(crowded) // NX - 6) >= 3
    # Novelty grows with the time since a cell was seen.
    assert fitness[6, 8] > field.search(100.0, np.full(GRID.shape, 99.0), np.array([0.5, 1.2, 0.0]))[6, 8]


# -- behaviour on hand-made observations (section 4.3) --------------------------------------------------


@pytest.fixture
def env():
    env = teamgym.make("Foraging-v0")
    env.reset(seed=0)
    return env


def observation(env, pose, detections=(), received=(), at_target=0, progress=0.0):
    """A dict observation: ``received`` holds (sender, class, gx, gy, Pc) rows."""
    obs = {name: np.zeros(shape, dtype=np.float32) for name, shape in env.layout.shapes.items()}
    obs["pose_estimate"][:] = pose
    obs["localisation_certainty"][0] = 1.0
    for k, (cls, gx, gy, pc) in enumerate(detections):
        obs["detections"][k] = (cls, gx, gy, pc)
        obs["detection_mask"][k] = 1
        centre = GRID.centre_of(np.array([gx, gy], dtype=float))
        rel = centre - np.asarray(pose[:2])
        obs["detection_polar"][k] = (np.hypot(*rel), np.arctan2(rel[1], rel[0]) - pose[2])
    obs["received_sender"][:] = -1
    for k, (sender, cls, gx, gy, pc) in enumerate(received):
        obs["received"][k] = (cls, gx, gy, pc)
        obs["received_sender"][k] = sender
        obs["received_mask"][k] = 1
    obs["at_target"][0] = at_target
    obs["consume_progress"][0] = progress
    return obs


def decide(policy, agent, obs, mask=None):
    infos = {agent: {"action_mask": mask}} if mask is not None else None
    return policy.act({agent: obs}, infos)[agent]


def test_a_robot_that_sees_a_target_approaches_it(env):
    policy = DMAPS(env)
    goal = decide(policy, "robot_0", observation(env, (0.5, 0.5, 0.0), [(TARGET, 5, 2, 0.8)]))
    plan = policy.plans()["robot_0"]
    assert goal == flat(5, 2) and plan["behaviour"] == "approach" and plan["target"] == (5, 2)
    assert plan["known_targets"] == [(5, 2)]


def test_a_closer_teammate_takes_the_target_and_the_robot_searches(env):
    packet = [(1, SENDER, 6, 3, 0.9), (1, TARGET, 5, 2, 0.8), (1, ROBOT, 2, 2, 0.7)]
    obs = observation(env, (0.5, 0.5, 0.0), [(TARGET, 5, 2, 0.8)], packet)
    policy = DMAPS(env)
    goal = decide(policy, "robot_0", obs)
    assert policy.plans()["robot_0"]["behaviour"] == "search" and goal != flat(5, 2)
    # Without communication the robot does not know about its teammate: it goes itself.
    alone = DMAPS(env, communication=False)
    assert decide(alone, "robot_0", obs) == flat(5, 2)


def test_robots_pair_with_targets_by_shortest_distance(env):
    # Robot 0 near (2, 2), robot 1 near (12, 9); both targets known to both through one packet each.
    obs0 = observation(env, (0.3, 0.3, 0.8), [(TARGET, 2, 2, 0.9)], [(1, SENDER, 13, 10, 0.9), (1, TARGET, 12, 9, 0.9)])
    obs1 = observation(env, (2.7, 2.1, -2.3), [(TARGET, 12, 9, 0.9)], [(0, SENDER, 1, 1, 0.9), (0, TARGET, 2, 2, 0.9)])
    policy = DMAPS(env)
    actions = policy.act({"robot_0": obs0, "robot_1": obs1})
    assert actions == {"robot_0": flat(2, 2), "robot_1": flat(12, 9)}


def test_surround_sends_both_robots_to_the_target():
    env = teamgym.make("Foraging-v0", task="surround", n_targets=1)
    env.reset(seed=0)
    obs0 = observation(env, (0.3, 0.3, 0.8), [(TARGET, 3, 3, 0.9)], [(1, SENDER, 13, 10, 0.9)])
    obs1 = observation(env, (2.7, 2.1, -2.3), [], [(0, SENDER, 1, 1, 0.9), (0, TARGET, 3, 3, 0.9)])
    actions = DMAPS(env).act({"robot_0": obs0, "robot_1": obs1})
    assert actions == {"robot_0": flat(3, 3), "robot_1": flat(3, 3)}


def test_a_robot_holds_at_its_target_and_forgets_it_once_consumed(env):
    policy = DMAPS(env)
    pose = (1.0, 1.0, 0.0)  # cell (5, 5); target just ahead in (6, 5)
    assert decide(policy, "robot_0", observation(env, pose, [(TARGET, 6, 5, 0.9)])) == flat(6, 5)
    for k in range(1, 100):
        obs = observation(env, pose, [(TARGET, 6, 5, 0.9)] if k % 3 else [], at_target=1, progress=k / 100)
        assert decide(policy, "robot_0", obs) == flat(6, 5)
        assert policy.plans()["robot_0"]["behaviour"] == "hold"
    # Consumed: the target vanishes (and with it at_target); it is cleared from the model.
    decide(policy, "robot_0", observation(env, (1.0, 1.0, np.pi), []))
    planner = policy.planners["robot_0"]
    assert planner.model.fused_map()[TARGET_LAYER, 4:7, 5:8].max() == 0
    assert policy.plans()["robot_0"]["behaviour"] == "search"


def test_a_robot_passing_a_target_its_teammate_consumes_drives_on(env):
    policy = DMAPS(env)
    packet = [(1, SENDER, 6, 5, 0.9), (1, TARGET, 6, 5, 0.9)]  # robot 1 is at the target, closer
    obs = observation(env, (1.0, 1.1, 0.0), [(TARGET, 6, 5, 0.9), (TARGET, 12, 5, 0.7)], packet, at_target=1)
    assert decide(policy, "robot_0", obs) == flat(12, 5)
    assert policy.plans()["robot_0"]["behaviour"] == "approach"


def test_a_teammate_that_stayed_at_a_target_for_consume_time_consumed_it(env):
    policy = DMAPS(env)
    decide(policy, "robot_0", observation(env, (0.5, 1.1, 0.0), [(TARGET, 7, 5, 0.9)]))  # seen by robot 0 itself
    here = [(1, SENDER, 6, 5, 0.9), (1, TARGET, 7, 5, 0.9)]
    for k in range(int(env.config.consume_time / env.config.dt)):  # robot 1 sits at it for consume_time
        decide(policy, "robot_0", observation(env, (0.5, 1.1 + 0.1 * (k % 2), np.pi), [], here))
    assert policy.plans()["robot_0"]["known_targets"] == [(7, 5)]
    decide(policy, "robot_0", observation(env, (0.5, 1.1, np.pi), [], [(1, SENDER, 10, 8, 0.9)]))  # it moved on
    model = policy.planners["robot_0"].model
    assert model.partial(0)[TARGET_LAYER, 4:7, 6:9].max() == 0  # the robot's own memory of it is cleared too
    decide(policy, "robot_0", observation(env, (0.5, 1.1, np.pi), [], [(1, SENDER, 10, 8, 0.9)]))
    assert policy.plans()["robot_0"]["known_targets"] == []


def test_a_teammate_passing_by_a_target_did_not_consume_it(env):
    policy = DMAPS(env)
    decide(policy, "robot_0", observation(env, (0.5, 1.1, 0.0), [(TARGET, 7, 5, 0.9)]))
    for _ in range(20):  # 2 s only
        decide(policy, "robot_0", observation(env, (0.5, 1.1, np.pi), [], [(1, SENDER, 6, 5, 0.9), (1, TARGET, 7, 5, 0.9)]))
    decide(policy, "robot_0", observation(env, (0.5, 1.1, np.pi), [], [(1, SENDER, 10, 8, 0.9)]))
    assert policy.planners["robot_0"].model.partial(0)[TARGET_LAYER, 5, 7] == pytest.approx(0.9)


def test_search_only_ignores_targets(env):
    policy = DMAPS(env, search_only=True)
    goal = decide(policy, "robot_0", observation(env, (0.5, 0.5, 0.0), [(TARGET, 5, 2, 0.8)], at_target=1))
    assert goal != flat(5, 2) and policy.plans()["robot_0"]["behaviour"] == "search"


def test_search_goal_is_kept_and_respects_the_action_mask(env):
    policy = DMAPS(env, params=DMAPSParams(min_hold=1.0))
    obs = observation(env, (1.5, 1.2, 0.0))
    goals = [decide(policy, "robot_0", obs) for _ in range(10)]
    assert len(set(goals)) == 1 and policy.plans()["robot_0"]["behaviour"] == "search"
    mask = np.ones(GRID.n_cells, dtype=np.int8)
    mask[goals[0]] = 0
    other = DMAPS(env)
    assert decide(other, "robot_0", obs, mask) != goals[0]


def test_without_hysteresis_the_search_goal_follows_the_field_at_every_step(env):
    turning = [observation(env, (1.5, 1.2, k * np.pi / 2)) for k in range(8)]  # 0.8 s, the robot turning on the spot
    held = DMAPS(env)
    assert len({decide(held, "robot_0", obs) for obs in turning}) == 1  # min_hold 1 s
    free = DMAPS(env, params={"min_hold": 0.0, "max_hold": 0.0})  # JSON data, as a preset's bc.expert_kwargs
    assert free.params == DMAPSParams(min_hold=0.0, max_hold=0.0)
    assert len({decide(free, "robot_0", obs) for obs in turning}) > 2  # the turning cost moves the best cell


def test_params_from_json_data():
    params = DMAPSParams.from_mapping({"min_hold": 0, "target_separation": 3, "potential": {"turn_cost": 0.2}})
    assert params == DMAPSParams(min_hold=0.0, target_separation=3, potential=FieldParams(turn_cost=0.2))
    assert isinstance(params.min_hold, float) and DMAPSParams.from_mapping({}) == DMAPSParams()
    assert DMAPSParams.from_mapping(params) is params
    env = teamgym.make("Foraging-v0")
    assert make_policy("dmaps", env, params={"max_hold": 5}).params.max_hold == 5.0
    assert make_policy("dmaps", env, params=DMAPSParams(max_hold=4.0)).params.max_hold == 4.0


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"min_hld": 0.0}, r"unknown dmaps parameter\(s\) \['min_hld'\]; known: \[.*'min_hold'"),
        ({"world": {"blob": 1.0}}, r"unknown dmaps world parameter\(s\) \['blob'\]"),
        ({"min_hold": "0"}, "dmaps parameter 'min_hold' must be a number, got '0'"),
        ({"min_hold": True}, "dmaps parameter 'min_hold' must be a number"),
        ({"target_separation": 2.5}, "dmaps parameter 'target_separation' must be an integer, got 2.5"),
        ({"potential": 1}, "dmaps potential parameters must map parameter names to values, got 1"),
        ([("min_hold", 0.0)], "dmaps parameters must map parameter names to values"),
    ],
)
def test_bad_params_are_refused_in_one_line(values, message):
    with pytest.raises(TypeError, match=message) as error:
        DMAPS(teamgym.make("Foraging-v0"), params=values)
    assert "\n" not in str(error.value)


def test_policy_is_deterministic_on_the_same_observations(env):
    obs = observation(env, (1.5, 1.2, 0.4), [(ROBOT, 9, 6, 0.7)], [(1, SENDER, 9, 6, 0.8), (1, TARGET, 2, 9, 0.6)])
    first, second = DMAPS(env), DMAPS(env)
    assert [decide(first, "robot_0", obs) for _ in range(5)] == [decide(second, "robot_0", obs) for _ in range(5)]


# -- construction and registry ----------------------------------------------------------------------


def test_registry_names_and_required_config():
    assert {"dmaps", "dmaps-nocomm", "random-walk"} <= set(policies())
    for name in ("dmaps", "dmaps-nocomm", "random-walk"):
        assert required_config(name) == {"action_type": "goto_cell"}
    env = teamgym.make("Foraging-v0")
    assert make_policy("dmaps", env).communication and not make_policy("dmaps-nocomm", env).communication


@pytest.mark.parametrize("name", ["dmaps", "dmaps-nocomm", "random-walk"])
def test_velocity_actions_are_refused_with_a_clear_message(name):
    env = teamgym.make("Foraging-v0", action_type="velocity")
    with pytest.raises(ValueError, match="action_type='goto_cell'.*got action_type='velocity'"):
        make_policy(name, env)


def test_other_envs_are_refused():
    with pytest.raises(ValueError, match="Foraging-v0"):
        make_policy("dmaps", teamgym.make("Navigation-v0"))


# -- episodes ---------------------------------------------------------------------------------------


def test_dmaps_consumes_all_targets_on_most_seeds():
    env = teamgym.make("Foraging-v0")
    policy = make_policy("dmaps", env)
    results = [run_episode(env, policy, seed, record_trajectories=False) for seed in range(8)]
    assert sum(r.success for r in results) >= 7
    for r in results:
        assert r.metrics["robot_0"]["targets_done"] == 3 or not r.success


def test_dmaps_surrounds_a_target_with_two_robots():
    env = teamgym.make("Foraging-v0", task="surround", n_targets=1)
    policy = make_policy("dmaps", env)
    results = [run_episode(env, policy, seed, record_trajectories=False) for seed in range(5)]
    assert all(r.success for r in results)


@pytest.mark.parametrize("name", ["dmaps", "dmaps-nocomm", "random-walk"])
def test_episodes_are_deterministic(name):
    env = teamgym.make("Foraging-v0", time_limit=20.0)
    policy = make_policy(name, env)
    assert run_episode(env, policy, 3, record_trajectories=False) == run_episode(env, policy, 3, record_trajectories=False)


def test_dict_observations_give_the_same_episode():
    flat_env = teamgym.make("Foraging-v0", time_limit=20.0)
    dict_env = teamgym.make("Foraging-v0", time_limit=20.0, obs_format="dict", observe_world_model=True)
    a = run_episode(flat_env, make_policy("dmaps", flat_env), 1, record_trajectories=False)
    b = run_episode(dict_env, make_policy("dmaps", dict_env), 1, record_trajectories=False)
    assert a.length == b.length and a.metrics["robot_0"]["targets_done"] == b.metrics["robot_0"]["targets_done"]
    assert a.returns == pytest.approx(b.returns)


def test_without_throughput_dmaps_is_dmaps_nocomm():
    env = teamgym.make("Foraging-v0", comm_throughput=0.0, time_limit=30.0)
    a = run_episode(env, make_policy("dmaps", env), 2, record_trajectories=False)
    b = run_episode(env, make_policy("dmaps-nocomm", env), 2, record_trajectories=False)
    assert a == b


def test_random_walk_finds_and_consumes_targets():
    env = teamgym.make("Foraging-v0", n_targets=1)
    policy = make_policy("random-walk", env)
    results = [run_episode(env, policy, seed, record_trajectories=False) for seed in range(3)]
    assert sum(r.success for r in results) >= 2


# -- consumed targets that persist (consumed_targets="persist") -------------------------------------


@pytest.fixture
def persist_env():
    env = teamgym.make("Foraging-v0", consumed_targets="persist")
    env.reset(seed=0)
    return env


def test_persist_a_robot_remembers_what_it_consumed_and_drives_on_though_it_still_sees_it(persist_env):
    env, pose = persist_env, (1.0, 1.0, 0.0)  # cell (5, 5); target just ahead in (6, 5)
    policy = DMAPS(env)
    assert policy.remember_consumed and not DMAPS(teamgym.make("Foraging-v0")).remember_consumed
    seen = [(TARGET, 6, 5, 0.9)]
    decide(policy, "robot_0", observation(env, pose, seen))
    for k in range(1, 100):
        assert decide(policy, "robot_0", observation(env, pose, seen, at_target=1, progress=k / 100)) == flat(6, 5)
    # The operation is done (progress 1); the target is still at_target and in the camera: the robot drives on.
    for _ in range(3):
        goal = decide(policy, "robot_0", observation(env, pose, seen, at_target=1, progress=1.0))
        plan = policy.plans()["robot_0"]
        assert plan["behaviour"] == "search" and plan["known_targets"] == [] and max(abs(goal % NX - 6), abs(goal // NX - 5)) > 2
    assert policy.planners["robot_0"].consumed_cells == [(6, 5)]
    # Its own and received reports of that target are dropped from then on; another target is not.
    packet = [(1, SENDER, 10, 8, 0.9), (1, TARGET, 7, 5, 0.9), (1, TARGET, 12, 9, 0.9)]
    decide(policy, "robot_0", observation(env, (1.0, 1.0, np.pi), [], packet))
    assert policy.plans()["robot_0"]["known_targets"] == [(12, 9)]


def test_persist_without_radio_a_robot_approaches_a_target_its_teammate_consumed(persist_env):
    env = persist_env
    here = [(1, SENDER, 6, 5, 0.9), (1, TARGET, 7, 5, 0.9)]
    for communication in (True, False):
        policy = DMAPS(env, communication=communication)
        for k in range(int(env.config.consume_time / env.config.dt)):  # robot 1 consumes the target at (7, 5)
            decide(policy, "robot_0", observation(env, (0.5, 1.1 + 0.1 * (k % 2), np.pi), [], here))
        decide(policy, "robot_0", observation(env, (0.5, 1.1, np.pi), [], [(1, SENDER, 10, 8, 0.9)]))  # and moves on
        # robot 0 now looks at it: the target is still there, as any target
        goal = decide(policy, "robot_0", observation(env, (0.5, 1.1, 0.0), [(TARGET, 7, 5, 0.9)]))
        if communication:  # known consumed by radio: not approached
            assert policy.planners["robot_0"].consumed_cells == [(7, 5)] and goal != flat(7, 5)
        else:  # no news: it goes there (and would consume it again)
            assert goal == flat(7, 5) and policy.plans()["robot_0"]["behaviour"] == "approach"


def test_persist_dmaps_consumes_every_target_and_radio_cuts_redundant_operations():
    results = {}
    for name in ("dmaps", "dmaps-nocomm"):
        env = teamgym.make("Foraging-v0", consumed_targets="persist")
        policy = make_policy(name, env)
        results[name] = [run_episode(env, policy, seed, record_trajectories=False) for seed in range(6)]
        assert sum(r.success for r in results[name]) >= 5
    redundant = {name: sum(sum(m["redundant"] for m in r.metrics.values()) for r in rs) for name, rs in results.items()}
    assert redundant["dmaps"] <= redundant["dmaps-nocomm"]


def test_persist_changes_nothing_when_the_one_target_ends_the_game():
    # Paper 002's surround (one target): the game ends when it is done, so both readings play the same games.
    surround = {"task": "surround", "n_targets": 1, "packet_rate": 1.0}
    for seed in (0, 1):
        a, b = (teamgym.make("Foraging-v0", consumed_targets=reading, **surround) for reading in ("vanish", "persist"))
        ra = run_episode(a, make_policy("dmaps", a), seed, record_trajectories=False)
        rb = run_episode(b, make_policy("dmaps", b), seed, record_trajectories=False)
        assert ra.success and ra.length == rb.length and ra.returns == rb.returns
        assert all(rb.metrics[k]["redundant"] == 0 for k in rb.metrics)
