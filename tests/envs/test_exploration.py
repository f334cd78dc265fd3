"""Exploration-v0 (paper 000): configuration, observations, masks, stages, doors, physics, copies."""

import copy
import json
import math
import pickle

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import teamgym
from baselines.exploration.policies import GreedyExplore
from teamgym.control.watcher import WatcherState
from teamgym.envs.exploration import ExplorationConfig
from teamgym.maps import load_map, wall_layout
from teamgym.maps.model import DATA_DIR
from teamgym.sim import Category
from teamgym.sim.robot import RobotSpec

OFFICE = load_map("office12")
ALL_DOORS = tuple(OFFICE.door_ids)

EVERY_KEY = dict(
    max_cycles=500,
    dt=0.05,
    substeps=10,
    coarse_substeps=5,
    map="lab7",
    n_robots=2,
    action_type="operator",
    goal_sectors=("S1", "S2"),
    start_sectors=("S5", "S6"),
    start_positions="centre",
    door_states="open",
    open_doors=("D1",),
    closed_doors=("D2",),
    door_resample_period=5.0,
    furniture=False,
    stage_end="all",
    wait_steps=5,
    max_speed=0.1,
    task_timeout=30.0,
    stall_time=3.0,
    fail_on_collision=True,
    clutter_prior_weight=2.0,
    sensor_range=0.08,
    sensor_noise=0.001,
    explore_reward=2.0,
    collision_penalty=0.5,
    time_penalty=0.01,
    obs_format="dict",
    comm_dim=1,
    comm_range=2.0,
    comm_throughput=0.9,
    comm_latency=2,
    comm_byte_budget=100,
    fixed_agents=True,
)


def operator_env(**config):
    return teamgym.make("Exploration-v0", action_type="operator", **config)


def run_greedy(env, seed, max_steps=400):
    """Play greedy on ``env``; returns per-step (actions, observations, rewards, infos)."""
    policy = GreedyExplore(env)
    observations, infos = env.reset(seed=seed)
    policy.reset(seed)
    record = []
    for _ in range(max_steps):
        if not env.agents:
            break
        actions = policy.act(observations, infos)
        observations, rewards, terminations, truncations, infos = env.step(actions)
        record.append((actions, observations, rewards, infos, terminations, truncations))
    return record


def same_steps(a, b):
    assert len(a) == len(b)
    for (act_a, obs_a, rew_a, info_a, term_a, trunc_a), (act_b, obs_b, rew_b, info_b, term_b, trunc_b) in zip(a, b):
        assert act_a == act_b and rew_a == rew_b and term_a == term_b and trunc_a == trunc_b
        for agent in obs_a:
            np.testing.assert_array_equal(obs_a[agent], obs_b[agent])
            assert info_a[agent].keys() == info_b[agent].keys()
            for key, value in info_a[agent].items():
                np.testing.assert_array_equal(value, info_b[agent][key])


# -- configuration ----------------------------------------------------------------------


def test_every_key_is_covered_and_accepted():
    # normalize_actions needs a continuous action type (tests/baselines/test_rl_options.py covers it)
    assert set(EVERY_KEY) | {"normalize_actions"} == set(ExplorationConfig.field_names())
    defaults = ExplorationConfig()
    for key, value in EVERY_KEY.items():
        assert getattr(defaults, key) != value, key
    env = teamgym.make("Exploration-v0", **EVERY_KEY)
    assert env.config.as_dict() == {**EVERY_KEY, "normalize_actions": False}
    env.reset(seed=0)
    assert not env.doors["D2"].is_open and env.doors["D1"].is_open
    assert env.world.of_kind(Category.FURNITURE) == []
    assert env.world.coarse_substeps == 5


@pytest.mark.parametrize(
    ("config", "fragment"),
    [
        ({"n_robots": 0}, "n_robots"),
        ({"map": "nowhere"}, "map='nowhere'"),
        ({"goal_sectors": ("S99",)}, "S99"),
        ({"start_sectors": ("S1",)}, "one sector per robot"),
        ({"closed_doors": ("D9,9",)}, "D9,9"),
        ({"open_doors": ("D3,6",), "closed_doors": ("D3,6",)}, "open_doors"),
        ({"max_speed": 0.5}, "max_speed"),
        ({"door_resample_period": -1.0}, "door_resample_period"),
        ({"wait_steps": 0}, "wait_steps"),
        ({"stage_end": "some"}, "stage_end"),
        ({"action_type": "wheels"}, "action_type"),
        ({"colour": "red"}, "unknown config key"),
        ({"task_timeout": float("nan")}, "task_timeout"),
    ],
)
def test_invalid_configs_fail_at_make(config, fragment):
    with pytest.raises(teamgym.ConfigError, match=fragment):
        teamgym.make("Exploration-v0", **config)


def test_broken_map_file_fails_at_make(tmp_path):
    lab = DATA_DIR / "lab7.json"
    data = json.loads(lab.read_text())
    data["sectors"][1]["top_left"] = [300, 1300]  # S2 now overlaps S1
    broken = tmp_path / "broken.json"
    broken.write_text(json.dumps(data))
    with pytest.raises(teamgym.ConfigError, match="overlap"):
        teamgym.make("Exploration-v0", map=str(broken))
    good = tmp_path / "good.json"
    good.write_text(lab.read_text())
    env = teamgym.make("Exploration-v0", map=str(good), n_robots=2)
    assert env.map.name == "lab7"


# -- spaces, observations, reset -------------------------------------------------------------


def test_spaces_and_layout():
    env = operator_env()
    s, d, v = 12, 13, 25
    assert env.action_space("robot_0").n == 1 + d + 2 * d + 2 * 3
    assert [op.name for op in env.operators[:2]] == ["Wait()", "FindDoor(D1,2_1)"]
    observations, infos = env.reset(seed=3)
    fields = env.decode(observations["robot_0"])
    shapes = {k: f.shape for k, f in fields.items()}
    assert shapes == {
        "pose": (3,),
        "velocity": (2,),
        "sector": (s,),
        "place": (v,),
        "proximity": (8,),
        "mates_sector": (2, s),
        "mates_place": (2, v),
        "visited": (s,),
        "goal": (s,),
        "door_belief": (d,),
        "clutter": (s,),
        "task_status": (4,),
        "task": (1,),
    }
    assert fields["sector"].sum() == 1 and fields["place"].sum() == 1 and fields["mates_place"].sum() == 2
    assert fields["mates_sector"].sum() == 2
    assert fields["task_status"][WatcherState.WAITING] == 1 and fields["task"][0] == -1
    np.testing.assert_allclose(fields["clutter"], [0.7, 0, 0.1, 0.6, 0, 0, 0, 0, 0.2, 0, 0.3, 0.2], atol=1e-6)
    assert fields["door_belief"][ALL_DOORS.index("D3,6")] == pytest.approx(0.2)
    assert fields["goal"].all()


def test_start_sectors_are_explored_and_places_set():
    env = operator_env(start_sectors=("S4", "S9", "S2"), start_positions="centre")
    observations, infos = env.reset(seed=0)
    assert [env.decode_info(infos[a])["sector"] for a in env.agents] == ["S4", "S9", "S2"]
    assert [env.decode_info(infos[a])["place"] for a in env.agents] == ["S4", "S9", "S2"]
    assert infos["robot_0"]["explored"] == 3 and not infos["robot_0"]["explored_all"]
    assert env.robots["robot_0"].position == pytest.approx(OFFICE.sector("S4").centre)
    visited = env.decode(observations["robot_1"])["visited"]
    assert visited.nonzero()[0].tolist() == [1, 3, 8]


def test_random_starts_are_clear_and_differ_by_seed():
    env = teamgym.make("Exploration-v0", n_robots=5)
    starts = []
    for seed in range(6):
        env.reset(seed=seed)
        points = [r.position for r in env.robot_list]
        starts.append(points)
        for p in points:
            assert all(math.dist(p, d.centre) >= d.radius for d in OFFICE.doors)
        for i in range(5):
            for j in range(i):
                assert math.dist(points[i], points[j]) > 2 * 0.0275
    assert len({tuple(np.round(s[0], 6)) for s in starts}) == 6


def test_door_sampling_follows_open_probability():
    env = teamgym.make("Exploration-v0")
    opened = 0
    for seed in range(200):
        env.reset(seed=seed)
        opened += env.doors["D3,6"].is_open
        assert all(env.doors[d].is_open for d in ALL_DOORS if d != "D3,6")
    assert 20 <= opened <= 60  # o = 0.2 for D3,6: 40 expected
    env = teamgym.make("Exploration-v0", door_states="open", closed_doors=("D1,8",))
    env.reset(seed=1)
    assert [d for d in ALL_DOORS if not env.doors[d].is_open] == ["D1,8"]


# -- action masks (section 3.1) ----------------------------------------------------------------


def expected_mask(env, place):
    """Preconditions of section 3.1, evaluated from the map alone (o_j from the team's beliefs)."""
    belief = dict(zip(ALL_DOORS, env.model.door_open))
    mask = np.zeros(len(env.operators), dtype=np.int8)
    for op in env.operators:
        if op.kind == "wait":
            ok = True
        elif op.kind == "find_door":
            ok = place in OFFICE.door(op.door).sectors and belief[op.door] > 0
        elif op.kind == "traverse_door":
            ok = place == op.door and belief[op.door] > 0
        else:
            ok = place == op.origin
        mask[op.index] = ok
    return mask


def test_masks_match_the_preconditions_along_an_episode():
    env = operator_env()
    policy = GreedyExplore(env)
    observations, infos = env.reset(seed=2)
    checked = 0
    for _ in range(30):
        for agent in env.agents:
            info = infos[agent]
            mask = expected_mask(env, env.decode_info(info)["place"])
            if env.decode_info(info)["task_status"] == "executing":
                mask[env.operator_set.by_name[env.decode_info(info)["task"]]] = 1  # continuing is always allowed
            np.testing.assert_array_equal(info["action_mask"], mask)
            np.testing.assert_array_equal(env.action_mask(agent), mask)
            np.testing.assert_array_equal(env.action_space(agent).live_mask, mask)
            checked += 1
        if not env.agents:
            break
        observations, _, _, _, infos = env.step(policy.act(observations, infos))
    assert checked > 30


def test_sampling_the_operator_space_gives_admissible_operators():
    env = operator_env()
    env.reset(seed=0)
    space = env.action_space("robot_0")
    space.seed(0)
    draws = {int(space.sample()) for _ in range(200)}
    assert draws == set(np.flatnonzero(env.action_mask("robot_0")).tolist())
    assert int(space.sample(mask=np.eye(len(env.operators), dtype=np.int8)[5])) == 5


def test_masked_operator_raises_and_leaves_the_episode_unchanged():
    env = operator_env()
    env.reset(seed=0)
    env.step({a: 0 for a in env.agents})
    before = copy.deepcopy(env)
    masked = int(np.flatnonzero(env.action_mask("robot_1") == 0)[0])
    with pytest.raises(ValueError, match=r"robot_1.*masked.*admissible now"):
        env.step({"robot_0": 0, "robot_1": masked, "robot_2": 0})
    assert env.cycles == before.cycles
    np.testing.assert_array_equal(env.state(), before.state())
    same_steps(run_continuation(env), run_continuation(before))


def run_continuation(env, steps=8):
    policy = GreedyExplore(env)
    observations = {a: env._collect_observations()[a] for a in env.agents}
    infos = {a: env._metrics(a) for a in env.agents}
    record = []
    for _ in range(steps):
        if not env.agents:
            break
        actions = policy.act(observations, infos)
        observations, rewards, terminations, truncations, infos = env.step(actions)
        record.append((actions, observations, rewards, infos, terminations, truncations))
    return record


@pytest.mark.parametrize(
    ("actions", "error", "fragment"),
    [
        ({"robot_0": 999, "robot_1": 0, "robot_2": 0}, ValueError, "outside Discrete"),
        ({"robot_0": -1, "robot_1": 0, "robot_2": 0}, ValueError, "outside Discrete"),
        ({"robot_0": 0.5, "robot_1": 0, "robot_2": 0}, ValueError, "integer"),
        ({"robot_0": "wait", "robot_1": 0, "robot_2": 0}, TypeError, "integer"),
        ({"robot_0": 0, "robot_1": 0}, ValueError, "no action"),
        ({"robot_0": 0, "robot_1": 0, "robot_2": 0, "robot_9": 0}, KeyError, "unknown agent"),
    ],
)
def test_bad_operator_actions(actions, error, fragment):
    env = operator_env()
    env.reset(seed=0)
    state = env.state().copy()
    with pytest.raises(error, match=fragment):
        env.step(actions)
    np.testing.assert_array_equal(env.state(), state)
    assert env.cycles == 0


@pytest.mark.parametrize("bad", [[np.nan, 0.0], [0.0, np.inf], [5.0, 0.0], [0.1, 0.1, 0.1]])
def test_bad_velocity_actions(bad):
    env = teamgym.make("Exploration-v0")
    env.reset(seed=0)
    actions = {a: np.zeros(2, dtype=np.float32) for a in env.agents}
    actions["robot_2"] = np.array(bad)
    with pytest.raises(ValueError, match="robot_2"):
        env.step(actions)
    assert env.cycles == 0


def test_finished_episode_and_bad_calls():
    env = operator_env(max_cycles=5)
    with pytest.raises(teamgym.EpisodeOverError):
        env.step({})
    with pytest.raises(teamgym.EpisodeOverError):
        env.set_door("D3,6", True)
    env.reset(seed=0)
    while env.agents:
        env.step({a: 0 for a in env.agents})
    with pytest.raises(teamgym.EpisodeOverError, match="ended"):
        env.step({a: 0 for a in env.possible_agents})
    with pytest.raises(KeyError, match="unknown door"):
        env.set_door("D7,7", True)
    with pytest.raises(TypeError, match="True or False"):
        env.set_door("D3,6", "open")
    with pytest.raises(KeyError, match="unknown agent"):
        env.action_mask("robot_7")
    velocity = teamgym.make("Exploration-v0")
    velocity.reset(seed=0)
    with pytest.raises(ValueError, match="has none"):
        velocity.action_mask("robot_0")
    assert velocity.action_masks() == {}


# -- stages, tasks and exploration ------------------------------------------------------------


def test_greedy_episode_explores_everything_with_consistent_metrics():
    env = operator_env()
    record = run_greedy(env, seed=4)
    actions, _, _, infos, terminations, _ = record[-1]
    assert all(terminations.values()) and env.agents == []
    info = infos["robot_0"]
    assert info["explored_all"] and info["explored"] == 12 and info["explored_fraction"] == 1.0
    assert info["stages"] == len(record)
    assert info["explore_time"] == pytest.approx(env.cycles * env.config.dt)
    assert info["team_path_length"] == pytest.approx(sum(i["path_length"] for i in infos.values()))
    assert env.episode_success()
    # rewards: one explore_reward per newly explored sector, time penalty per control step
    total = sum(sum(r.values()) for _, _, r, _, _, _ in record)
    collisions = sum(i["collisions"] for i in infos.values())
    expected = 3 * (9 * 1.0 - 0.001 * env.cycles) - 0.1 * collisions
    assert total == pytest.approx(expected)


@pytest.mark.parametrize("stage_end", ["any", "all"])
def test_stage_ends_when_a_task_ends(stage_end):
    env = operator_env(stage_end=stage_end)
    for _, _, _, infos, terminations, _ in run_greedy(env, seed=1, max_steps=25):
        if all(terminations.values()):
            break
        statuses = [env.decode_info(i)["task_status"] for i in infos.values()]
        assert "completed" in statuses or "failed" in statuses
        if stage_end == "all":
            assert "executing" not in statuses


def test_continuing_an_operator_does_not_restart_it():
    env = operator_env(start_sectors=("S5", "S12", "S1"), start_positions="centre")
    env.reset(seed=0)
    goto = env.operator_set.by_name["GoTo(S5,S6)"]
    find = env.operator_set.by_name["FindDoor(D11,12)"]
    _, _, _, _, infos = env.step({"robot_0": goto, "robot_1": find, "robot_2": 0})
    assert env.decode_info(infos["robot_1"])["task_status"] == "completed"  # the short task ended the stage
    assert env.decode_info(infos["robot_0"])["task_status"] == "executing"
    task, started = env._watchers[0].task, env._watchers[0]._start_time
    env.step({"robot_0": goto, "robot_1": 0, "robot_2": 0})
    assert env._watchers[0].task is task and env._watchers[0]._start_time == started
    env.step({"robot_0": 0, "robot_1": 0, "robot_2": 0})  # Wait replaces the running task
    assert env._watchers[0].task.is_wait


def test_robot_half_way_through_a_door_has_not_explored_the_room():
    env = teamgym.make("Exploration-v0", start_sectors=("S1", "S12", "S5"), start_positions="centre", door_states="open")
    env.reset(seed=0)
    robot = env.robots["robot_0"]
    robot.teleport((0.375 + 0.03, 0.7))  # inside the circle of D1,2_1, on S2's side
    env.world.read_states()
    env._update_state()
    assert env.decode_info(env._metrics("robot_0"))["place"] == "D1,2_1" and not env.visited[1]
    robot.teleport((0.375 + 0.1, 0.7))  # out of the circle: in S2
    env.world.read_states()
    env._update_state()
    assert env.decode_info(env._metrics("robot_0"))["place"] == "S2" and env.visited[1]


def test_closed_door_fails_the_task_and_becomes_known():
    env = operator_env(start_sectors=("S3", "S12", "S9"), start_positions="centre", closed_doors=("D3,6",))
    env.reset(seed=0)
    j = ALL_DOORS.index("D3,6")
    assert env.model.door_open[j] == pytest.approx(0.2)
    find = env.operator_set.by_name["FindDoor(D3,6)"]
    for _ in range(10):
        _, _, _, _, infos = env.step({"robot_0": find, "robot_1": 0, "robot_2": 0})
        if env.decode_info(infos["robot_0"])["task_status"] != "executing":
            break
    named = env.decode_info(infos["robot_0"])
    assert named["task_status"] == "failed" and named["task_reason"] == "door closed"
    assert env.model.door_open[j] == 0.0
    assert infos["robot_0"]["action_mask"][find] == 0
    assert env.decode(env._collect_observations()["robot_0"])["door_belief"][j] == 0.0


def test_clutter_is_re_estimated_from_find_door_tasks():
    env = operator_env()
    run_greedy(env, seed=3)
    estimate = env.clutter_estimate
    assert estimate.count.sum() > 0
    np.testing.assert_allclose(env.model.clutter, estimate.values)
    changed = estimate.count > 0
    assert np.all(env.model.clutter[changed] != np.array([s.clutter for s in OFFICE.sectors])[changed])


# -- physics invariants ----------------------------------------------------------------------


def crossings(a, b, segments):
    """Whether the move a -> b crosses any segment (proper intersection)."""

    def orient(p, q, r):
        return np.sign((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))

    return any(orient(a, b, s.a) * orient(a, b, s.b) < 0 and orient(s.a, s.b, a) * orient(s.a, s.b, b) < 0 for s in segments)


@pytest.mark.parametrize("doors", ["closed", "open"])
def test_robots_never_cross_walls_or_closed_doors(doors):
    closed = ALL_DOORS if doors == "closed" else ()
    env = teamgym.make("Exploration-v0", n_robots=4, closed_doors=closed, max_cycles=400)
    env.reset(seed=5)
    walls, door_segments = wall_layout(OFFICE)
    solid = walls + (door_segments if doors == "closed" else [])
    rng = np.random.default_rng(0)
    start_sector = {a: env.decode_info(env._metrics(a))["sector"] for a in env.agents}
    command = {a: np.array([0.4, 0.0], dtype=np.float32) for a in env.agents}
    for t in range(400):
        if t % 15 == 0:
            command = {a: np.array([0.4, rng.uniform(-3, 3)], dtype=np.float32) for a in env.agents}
        before = {a: env.robots[a].position for a in env.agents}
        env.step(command)
        for a in env.agents:
            after = env.robots[a].position
            assert not crossings(before[a], after, solid), (a, t, before[a], after)
            assert 0 < after[0] < OFFICE.size[0] and 0 < after[1] < OFFICE.size[1]
            if doors == "closed" and OFFICE.sector(start_sector[a]).kind == "room":
                assert OFFICE.sector(start_sector[a]).contains(*after)


# -- determinism, run-time doors, copies -------------------------------------------------------


def test_same_seed_same_operator_episode():
    env = operator_env()
    first = run_greedy(env, seed=7, max_steps=20)
    run_greedy(env, seed=8, max_steps=5)
    second = run_greedy(env, seed=7, max_steps=20)
    same_steps(first, second)


def test_set_door_is_recorded_and_copies_continue_identically():
    env = operator_env(start_sectors=("S3", "S12", "S9"), start_positions="centre")
    run_greedy(env, seed=0, max_steps=3)
    assert env.set_door("D3,6", True) is True
    assert env.doors["D3,6"].is_open
    assert env.set_door("D11,12", False) is True
    assert not env.doors["D11,12"].is_open
    for clone in (copy.deepcopy(env), pickle.loads(pickle.dumps(env))):
        assert clone.doors["D3,6"].is_open and not clone.doors["D11,12"].is_open
        np.testing.assert_array_equal(clone.state(), env.state())
        same_steps(run_continuation(copy.deepcopy(env), 6), run_continuation(clone, 6))


def test_doors_resampled_at_run_time_replay_in_copies():
    env = teamgym.make("Exploration-v0", door_resample_period=0.5, max_cycles=200)
    env.reset(seed=2)
    rng = np.random.default_rng(0)
    history = set()
    for _ in range(60):
        env.step({a: rng.uniform(-0.2, 0.2, 2).astype(np.float32) for a in env.agents})
        history.add(env.doors["D3,6"].is_open)
    assert history == {True, False}  # D3,6 (o = 0.2) changed during the episode
    clone = pickle.loads(pickle.dumps(env))
    for _ in range(30):
        action = {a: rng.uniform(-0.2, 0.2, 2).astype(np.float32) for a in env.agents}
        out_a, out_b = env.step(action), clone.step(action)
        for agent in out_a[0]:
            np.testing.assert_array_equal(out_a[0][agent], out_b[0][agent])
        assert [env.doors[d].is_open for d in ALL_DOORS] == [clone.doors[d].is_open for d in ALL_DOORS]


def test_render_shows_unexplored_sectors():
    env = teamgym.make("Exploration-v0", render_mode="rgb_array", action_type="operator")
    env.reset(seed=0)
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[1] > frame.shape[0]  # 1.5 m x 1.0 m office
    assert len(env._overlay().points) == 9
    run_continuation(env, steps=15)
    assert len(env._overlay().points) < 9
    assert np.any(env.render() != frame)


# -- property-based action handling -----------------------------------------------------------


@pytest.fixture(scope="module")
def fresh_operator_env():
    env = operator_env()
    env.reset(seed=0)
    return env


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(op=st.integers(-3, 50), agent=st.sampled_from(["robot_0", "robot_1", "robot_2"]))
def test_an_operator_is_accepted_exactly_when_admissible(fresh_operator_env, op, agent):
    env = copy.deepcopy(fresh_operator_env)
    mask = env.action_mask(agent)
    actions = {a: 0 for a in env.agents}
    actions[agent] = op
    state = env.state().copy()
    if 0 <= op < len(mask) and mask[op]:
        env.step(actions)
        assert env.cycles > 0
        assert env._watchers[env.possible_agents.index(agent)].task.key == op
    else:
        with pytest.raises(ValueError, match=agent):
            env.step(actions)
        assert env.cycles == 0
        np.testing.assert_array_equal(env.state(), state)


@pytest.fixture(scope="module")
def fresh_velocity_env():
    env = teamgym.make("Exploration-v0", max_cycles=10_000)
    env.reset(seed=0)
    return env


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(v=st.floats(allow_nan=True, allow_infinity=True, width=32), w=st.floats(allow_nan=True, allow_infinity=True, width=32))
def test_a_velocity_is_accepted_exactly_when_in_the_box(fresh_velocity_env, v, w):
    env = fresh_velocity_env
    space = env.action_space("robot_0")
    action = np.array([v, w], dtype=np.float32)
    actions = {a: np.zeros(2, dtype=np.float32) for a in env.agents}
    actions["robot_0"] = action
    cycles = env.cycles
    if np.all(np.isfinite(action)) and space.contains(action):
        env.step(actions)
        assert env.cycles == cycles + 1
    else:
        with pytest.raises(ValueError, match="robot_0"):
            env.step(actions)
        assert env.cycles == cycles


def test_more_robots_than_sectors_always_find_a_start():
    """With 16 robots on the 12 sectors some sector gets several; a full one passes its robot to another (seeds 63, 98 failed)."""
    env = teamgym.make("Exploration-v0", n_robots=16)
    for seed in (63, 98, *range(10)):
        env.reset(seed=seed)
        starts = env.world.robot_states[:, :2]
        gaps = np.linalg.norm(starts[:, None] - starts[None], axis=-1) + np.eye(16)
        assert gaps.min() >= 2 * RobotSpec.radius + 0.02 - 1e-9  # the start rule of _free


@pytest.mark.parametrize("search_all", [False, True])
def test_sectors_places_and_door_sightings_follow_the_array_rules(search_all):
    """``_update_state`` on floats gives what the rectangle and disc tests over arrays give (with and
    without the shortcut for a robot still in its sector, which office12's disjoint sectors allow)."""
    env = teamgym.make("Exploration-v0").unwrapped
    env.reset(seed=0)
    assert env._sectors_disjoint
    env._sectors_disjoint = not search_all
    rng = np.random.default_rng(2)
    centres, radii = env._door_centres, env._door_radii
    at_doors = 0
    for trial in range(300):
        sector_before = env._sector.copy()
        near_door = centres[rng.integers(len(centres)), :] + rng.normal(0.0, 0.05, (3, 2))
        pos = near_door if trial % 2 else rng.uniform(0.0, max(env.map.size), (3, 2))
        env.world.robot_states = np.column_stack([pos, np.zeros((3, 4))])
        r, eps = env._rects, 1e-3
        inside = (
            (pos[:, None, 0] > r[None, :, 0] + eps)
            & (pos[:, None, 0] < r[None, :, 2] - eps)
            & (pos[:, None, 1] > r[None, :, 1] + eps)
            & (pos[:, None, 1] < r[None, :, 3] - eps)
        )
        sector = np.where(inside.any(axis=1), inside.argmax(axis=1), sector_before)
        distance = np.linalg.norm(pos[:, None, :] - centres[None, :, :], axis=2)
        near = distance < radii[None, :]
        beliefs = env.model.door_open.copy()
        for j in np.flatnonzero(near.any(axis=0)):
            beliefs[j] = 1.0 if env.doors[env.map.doors[j].id].is_open else 0.0
        usable = near & (beliefs[None, :] > 0)
        place = np.where(usable.any(axis=1), env.n_sectors + np.where(usable, distance, np.inf).argmin(axis=1), sector)
        env._update_state()
        assert np.array_equal(env._sector, sector) and np.array_equal(env._place, place)
        assert np.array_equal(env.model.door_open, beliefs)
        assert env._all_explored() == bool(np.all(env.visited[env.goal]))
        assert env._arrays.explored_goals[env._copy] == int(np.count_nonzero(env.visited & env.goal))
        at_doors += int((place >= env.n_sectors).sum())
    assert at_doors > 50  # the door rule was exercised
