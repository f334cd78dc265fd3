"""BoxPushing-v0: config, goal and reward, sensing, primitives, dynamic agents and boxes, copying."""

import copy
import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pettingzoo.test import api_test, parallel_api_test

import teamgym
from teamgym.control.primitives import Primitive
from teamgym.envs.box_pushing.config import SITUATIONS

STOP = int(Primitive.STOP)


def make(**config):
    kwargs = dict(situation="S2", max_cycles=500)
    kwargs.update(config)
    return teamgym.make("BoxPushing-v0", **kwargs)


def stop_all(env):
    return {a: STOP for a in env.agents}


def place_robot(env, agent, x, y, heading):
    env.robots[agent].teleport((x, y), heading)
    env.world.read_states()


def place_box(env, name, x, y, angle=0.0):
    box = env.world[name]
    box.body.position = box.control.position = (x, y)
    box.body.angle = box.control.angle = angle
    env.world.space.reindex_shapes_for_body(box.body)


# -- config ---------------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(SITUATIONS))
def test_situation_presets_set_the_counts(name):
    env = teamgym.make("BoxPushing-v0", situation=name)
    robots, light, heavy = SITUATIONS[name]
    assert (env.config.n_robots, env.config.n_light_boxes, env.config.n_heavy_boxes) == (robots, light, heavy)
    env.reset(seed=0)
    assert len(env.agents) == robots
    assert sum(env.is_heavy(b) for b in env.box_names()) == heavy
    assert len(env.box_names()) == light + heavy


def test_preset_contradiction_names_the_key():
    with pytest.raises(teamgym.ConfigError, match="n_robots=3 contradicts situation='S3'"):
        teamgym.make("BoxPushing-v0", situation="S3", n_robots=3)
    assert teamgym.make("BoxPushing-v0", situation="S3", n_robots="4").config.n_robots == 4


@pytest.mark.parametrize(
    ("config", "fragment"),
    [
        ({"n_robots": 0}, "n_robots=0"),
        ({"n_light_boxes": 0, "n_heavy_boxes": 0}, "no box"),
        ({"lamp": (0.5, 0.5)}, "lamp"),
        ({"lamp": (1.2, 1.0)}, "corner"),
        ({"heavy_box_mass": 0.1}, "heavy_box_mass"),
        ({"heavy_box_mass": 0.3}, "heavy_box_mass"),
        ({"heavy_box_mass": 0.13, "heavy_box_size": 0.16}, "spin"),
        ({"light_box_mass": 0.15}, "light_box_mass"),
        ({"cruise_speed": 0.9}, "cruise_speed"),
        ({"turn_rate": 100.0}, "turn_rate"),
        ({"boxes_to_goal": 5}, "boxes_to_goal"),
        ({"sensor_noise": float("nan")}, "sensor_noise"),
        ({"events": ((10, "explode"),)}, "kind"),
        ({"events": ((0, "add_heavy_box"),)}, "cycle 0"),
        ({"events": ((10, "add_heavy_box"),)}, "n_spare_boxes=0"),
        ({"events": ((10, "add_robot"),)}, "n_spare_robots=0"),
        ({"events": ((10, "add_light_box", 5.0, 0.2),), "n_spare_boxes": 1}, "not on the table"),
        ({"events": ((10, "remove_robot"),)}, "one argument"),
        ({"n_robots": 16, "n_light_boxes": 8, "n_heavy_boxes": 8, "table_width": 0.5, "table_height": 0.5}, "crowded"),
        ({"unknown_key": 1}, "unknown config key"),
    ],
)
def test_invalid_configs_fail_at_make(config, fragment):
    with pytest.raises(teamgym.ConfigError, match=fragment):
        teamgym.make("BoxPushing-v0", **config)


def test_default_masses_make_light_and_heavy_boxes_from_friction():
    c = teamgym.make("BoxPushing-v0").config
    light = c.box_friction * c.light_box_mass * 9.81
    heavy = c.box_friction * c.heavy_box_mass * 9.81
    assert light < c.max_motor_force < heavy < 2 * c.max_motor_force


# -- goal, reward, success ------------------------------------------------------------------


def test_goal_is_the_wall_nearest_the_lamp():
    assert teamgym.make("BoxPushing-v0").goal.side == "east"
    assert teamgym.make("BoxPushing-v0", lamp=(-0.1, 0.45)).goal.side == "west"
    assert teamgym.make("BoxPushing-v0", lamp=(0.5, 1.0)).goal.side == "north"


def test_boxes_start_clear_of_the_walls():
    env = make(situation="S2", box_margin=0.08)
    for seed in range(10):
        env.reset(seed=seed)
        for name in env.box_names():
            box = env.world[name]
            corners = np.array([box.body.local_to_world(v) for v in box.local_vertices])
            assert corners.min() >= 0.08 - 1e-9
            assert corners[:, 0].max() <= 1.10 - 0.08 + 1e-9 and corners[:, 1].max() <= 0.90 - 0.08 + 1e-9


def test_pushing_a_box_to_the_goal_rewards_progress_and_succeeds():
    env = make(situation="S1", action_type="wheels", max_cycles=400, motor_noise=0.0)
    env.reset(seed=0)
    box = env.box_names()[0]
    place_box(env, box, 0.80, 0.45)
    place_robot(env, "robot_0", 0.80 - 0.04 - 0.0275 - 0.005, 0.45, 0.0)
    env._update_boxes()
    total, steps = 0.0, 0
    full = np.array([0.2, 0.2], dtype=np.float32)
    while env.agents:
        _, rewards, terminations, _, infos = env.step({"robot_0": full})
        total += rewards["robot_0"]
        steps += 1
    assert terminations["robot_0"] and infos["robot_0"]["success"] and env.episode_success()
    assert infos["robot_0"]["boxes_delivered"] == 1
    assert infos["robot_0"]["time_to_goal"] == pytest.approx(steps * 0.1)
    gap = 1.10 - 0.84
    assert infos["robot_0"]["box_progress"] == pytest.approx(gap, abs=0.004)
    c = env.config
    assert total == pytest.approx(c.progress_reward * infos["robot_0"]["box_progress"] - c.time_penalty * steps + c.success_bonus)


def test_boxes_to_goal_counts_deliveries():
    env = make(situation="S2", boxes_to_goal=1, action_type="wheels")
    env.reset(seed=1)
    first, second = env.box_names()
    place_box(env, first, 1.10 - 0.04, 0.2)  # touching the goal wall
    env.step({a: np.zeros(2, dtype=np.float32) for a in env.agents})
    assert env.episode_success() and env.agents == []
    env = make(situation="S2", action_type="wheels")
    env.reset(seed=1)
    place_box(env, env.box_names()[0], 1.10 - 0.04, 0.2)
    env.step({a: np.zeros(2, dtype=np.float32) for a in env.agents})
    assert not env.episode_success() and len(env.agents) == 2


# -- sensing -------------------------------------------------------------------------------


def light_of(env, agent):
    return env.decode(env._collect_observations()[agent])["light"]


@pytest.mark.parametrize("shadows", [False, True])
def test_light_passes_through_boxes_and_over_walls(shadows):
    env = make(situation="S1", light_shadows=shadows)
    env.reset(seed=0)
    place_robot(env, "robot_0", 0.3, 0.45, 0.0)
    place_box(env, env.box_names()[0], 2.0, 2.0)  # off the table: nothing between
    env._read_sensors(env.agents)
    clear = light_of(env, "robot_0").copy()
    place_box(env, env.box_names()[0], 0.6, 0.45)  # between robot and lamp
    env._read_sensors(env.agents)
    np.testing.assert_allclose(light_of(env, "robot_0"), clear)
    assert np.argmax(clear) in (2, 3) and clear.max() > 0  # the lamp is straight ahead, beyond the east wall


def test_light_shadows_from_robots_only_when_enabled():
    for shadows, blocked in ((False, False), (True, True)):
        env = make(situation="S2", light_shadows=shadows)
        env.reset(seed=0)
        for name in env.box_names():
            place_box(env, name, 3.0, 3.0 + env.box_names().index(name))
        place_robot(env, "robot_0", 0.3, 0.45, 0.0)
        place_robot(env, "robot_1", 0.6, 0.45, 0.0)
        env._read_sensors(env.agents)
        assert (light_of(env, "robot_0").max() == 0.0) == blocked


def test_observation_fields_and_busy_flag():
    env = make(situation="S1", direction_change_jitter=0.0)
    observations, _ = env.reset(seed=0)
    fields = env.decode(observations["robot_0"])
    assert set(fields) == {"proximity", "light", "encoders", "busy"}
    assert fields["proximity"].shape == (8,) and np.all(fields["proximity"] <= env.config.sensor_range)
    place_robot(env, "robot_0", 0.5, 0.2, 0.0)
    start = env.robots["robot_0"].pose[2]
    observations, *_ = env.step({"robot_0": int(Primitive.DIRECTION_CHANGE)})
    busy_steps = 1
    while env.decode(observations["robot_0"])["busy"][0] == 1.0:
        observations, *_ = env.step({"robot_0": int(Primitive.GO_AHEAD)})  # ignored while busy
        busy_steps += 1
    turned = abs(math.remainder(env.robots["robot_0"].pose[2] - start, 2 * math.pi))
    assert turned == pytest.approx(math.pi, abs=math.radians(4))
    assert busy_steps == math.ceil(math.pi / (env.config.turn_rate * env.config.dt))
    x0 = env.robots["robot_0"].pose[0]
    env.step({"robot_0": int(Primitive.GO_AHEAD)})
    assert env.robots["robot_0"].pose[0] < x0 - 0.01  # it now faces west and drives


def test_encoders_report_no_rotation_against_the_wall():
    env = make(situation="S1", action_type="wheels")
    env.reset(seed=0)
    place_robot(env, "robot_0", 1.10 - 0.0275 - 0.002, 0.45, 0.0)
    for _ in range(3):
        observations, *_ = env.step({"robot_0": np.array([0.2, 0.2], dtype=np.float32)})
    commanded_l, commanded_r, actual_l, actual_r = env.decode(observations["robot_0"])["encoders"]
    assert commanded_l == pytest.approx(0.2 * 0.1 / 0.008, rel=1e-5)
    assert abs(actual_l) + abs(actual_r) < 0.02 * (commanded_l + commanded_r)


# -- dynamic environment --------------------------------------------------------------------


def test_added_robot_joins_in_the_next_step():
    env = make(n_spare_robots=2)
    observations, _ = env.reset(seed=0)
    assert env.possible_agents == ["robot_0", "robot_1", "robot_2", "robot_3"]
    assert env.agents == ["robot_0", "robot_1"] and set(observations) == {"robot_0", "robot_1"}
    name = env.add_robot(position=(0.1, 0.1), heading=0.5)
    assert name == "robot_2" and env.agents == ["robot_0", "robot_1"]
    observations, rewards, terminations, truncations, infos = env.step(stop_all(env))
    assert env.agents == ["robot_0", "robot_1", "robot_2"]
    assert set(observations) == set(rewards) == set(terminations) == set(truncations) == set(infos) == set(env.agents)
    assert rewards["robot_2"] == 0.0 and not terminations["robot_2"]
    assert env.robots["robot_2"].pose[:2] == pytest.approx((0.1, 0.1), abs=1e-3)
    env.step(stop_all(env))  # the new agent acts from now on
    assert env.add_robot() == "robot_3"
    with pytest.raises(ValueError, match="no spare robot"):
        env.add_robot()


def test_removed_and_broken_robots_terminate_in_the_next_step():
    env = make(situation="S3", n_spare_robots=1)
    env.reset(seed=3)
    env.remove_robot("robot_1")
    assert "robot_1" not in env.world.entities
    env.break_down("robot_2")
    with pytest.raises(ValueError, match="not a live agent"):
        env.break_down("robot_2")
    observations, _, terminations, _, infos = env.step(stop_all(env))
    assert terminations == {"robot_0": False, "robot_1": True, "robot_2": True, "robot_3": False}
    assert infos["robot_1"]["removed"] and infos["robot_2"]["broken_down"] and not infos["robot_0"]["removed"]
    assert env.agents == ["robot_0", "robot_3"]
    broken = env.robots["robot_2"]
    assert "robot_2" in env.world.entities and not broken.enabled  # stays as an obstacle
    before = broken.pose
    place_robot(env, "robot_0", before[0] - 0.06, before[1], 0.0)
    for _ in range(10):
        env.step({"robot_0": int(Primitive.GO_AHEAD), "robot_3": STOP})
    assert np.hypot(broken.pose[0] - before[0], broken.pose[1] - before[1]) < 0.002  # wheels locked: one robot cannot push it
    with pytest.raises(KeyError, match="unknown agent"):
        env.remove_robot("robot_9")
    with pytest.raises(ValueError, match="not a live agent"):
        env.remove_robot("robot_1")


def test_boxes_added_and_removed():
    env = make(situation="S2", n_spare_boxes=2)
    env.reset(seed=0)
    heavy = env.add_box(heavy=True, position=(0.55, 0.45), angle=0.0)
    assert env.is_heavy(heavy) and heavy in env.box_names() and env.world[heavy].mass == env.config.heavy_box_mass
    with pytest.raises(ValueError, match="not free"):
        env.add_box(position=(0.55, 0.45))
    with pytest.raises(ValueError, match="off the table"):
        env.add_box(position=(0.01, 0.45))
    with pytest.raises(ValueError, match="finite"):
        env.add_box(position=(float("nan"), 0.45))
    with pytest.raises(TypeError, match="heavy"):
        env.add_box(heavy="yes")
    light = env.add_box()
    assert not env.is_heavy(light)
    with pytest.raises(ValueError, match="slots"):
        env.add_box()
    env.remove_box(heavy)
    assert heavy not in env.box_names() and heavy not in env.world.entities
    with pytest.raises(KeyError, match="no box named"):
        env.remove_box(heavy)
    state = env.state()
    assert state.shape == env.state_space.shape


def test_scheduled_events_apply_at_their_cycle():
    events = (
        (3, "add_heavy_box", 0.5, 0.45, 0.0),
        (3, "add_robot"),
        (5, "break_down", "robot_0"),
        (6, "remove_robot", "robot_0"),
    )
    env = make(n_spare_robots=1, n_spare_boxes=1, events=events)
    env.reset(seed=2)
    seen = []
    for _ in range(6):
        observations, *_, infos = env.step(stop_all(env))
        seen.append((env.cycles, list(env.agents), len(env.box_names())))
    assert seen[1] == (2, ["robot_0", "robot_1"], 2)
    assert seen[2] == (3, ["robot_0", "robot_1", "robot_2"], 3)
    assert seen[4][1] == ["robot_1", "robot_2"] and infos["robot_1"]["broken_down"] is False
    assert [e.kind for e in env.skipped_events] == ["remove_robot"]  # robot_0 had already broken down


def test_dynamic_episode_keeps_the_parallel_api_valid():
    events = ((5, "add_robot"), (8, "remove_robot", "robot_1"), (12, "break_down", "robot_0"), (15, "add_robot"))
    env = make(n_spare_robots=2, events=events, max_cycles=30)
    parallel_api_test(env, num_cycles=40)


def test_dynamic_episode_keeps_the_aec_api_valid():
    events = ((3, "add_robot"), (6, "remove_robot", "robot_1"))
    api_test(teamgym.make_aec("BoxPushing-v0", situation="S2", n_spare_robots=1, events=events, max_cycles=20), num_cycles=20)


def test_api_calls_need_a_running_episode():
    env = make(n_spare_robots=1)
    with pytest.raises(teamgym.EpisodeOverError, match="reset"):
        env.add_robot()
    env = make(max_cycles=1)
    env.reset(seed=0)
    env.step(stop_all(env))
    with pytest.raises(teamgym.EpisodeOverError):
        env.add_box()


# -- copying ---------------------------------------------------------------------------------


def random_primitives(env, rng):
    return {a: int(rng.integers(len(Primitive))) for a in env.agents}


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_copy_after_run_time_events_continues_identically(how):
    env = make(situation="S2", n_spare_robots=1, n_spare_boxes=1, motor_noise=0.05, sensor_noise=0.002)
    env.reset(seed=4)
    rng = np.random.default_rng(0)
    for t in range(40):
        if t == 10:
            env.add_robot()
        if t == 20:
            env.add_box(heavy=True)
            with pytest.raises(ValueError):  # a failed call must not disturb the copy
                env.add_box(position=env.world[env.box_names()[0]].position)
        if t == 30:
            env.break_down("robot_0")
        env.step(random_primitives(env, rng))
    clone = copy.deepcopy(env) if how == "deepcopy" else pickle.loads(pickle.dumps(env))
    np.testing.assert_array_equal(clone.state(), env.state())
    assert clone.agents == env.agents and clone.box_names() == env.box_names()
    rng_a, rng_b = np.random.default_rng(1), np.random.default_rng(1)
    for _ in range(60):
        if not env.agents:
            break
        a = env.step(random_primitives(env, rng_a))
        b = clone.step(random_primitives(clone, rng_b))
        for agent in a[0]:
            np.testing.assert_array_equal(a[0][agent], b[0][agent])
        assert a[1:] == b[1:]


def test_same_seed_same_episode_with_noise():
    def run(seed):
        env = make(situation="S3", motor_noise=0.05, sensor_noise=0.002, light_noise=0.01)
        observations, _ = env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        out = [np.concatenate(list(observations.values()))]
        for _ in range(50):
            observations, *_ = env.step(random_primitives(env, rng))
            out.append(np.concatenate(list(observations.values())))
        return np.array(out), env.state()

    a, b, c = run(7), run(7), run(8)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    assert not np.array_equal(a[1], c[1])


def test_render_shows_the_lamp():
    env = make(render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[1] > frame.shape[0]
    assert np.any(np.all(frame == (255, 220, 0), axis=2))  # the lamp beside the east wall


# -- action handling ---------------------------------------------------------------------------

HYPOTHESIS = settings(max_examples=40, deadline=None, database=None)


def assert_rejected(env, actions, error, fragment):
    twin = copy.deepcopy(env)
    state, cycles, agents = env.state().copy(), env.cycles, list(env.agents)
    with pytest.raises(error, match=fragment):
        env.step(actions)
    np.testing.assert_array_equal(env.state(), state)
    assert (env.cycles, env.agents) == (cycles, agents)
    a, b = env.step(neutral(env)), twin.step(neutral(twin))
    assert a[1:] == b[1:]


def neutral(env):
    if env.config.action_type == "wheels":
        return {a: np.zeros(2, dtype=np.float32) for a in env.agents}
    return stop_all(env)


@HYPOTHESIS
@given(
    st.sampled_from(["robot_0", "robot_1"]),
    st.one_of(
        st.integers(min_value=13, max_value=10**6),
        st.integers(max_value=-1),
        st.floats(allow_nan=True).filter(lambda v: not float(v).is_integer() if np.isfinite(v) else True),
    ),
)
def test_bad_primitive_actions_are_rejected_and_change_nothing(agent, bad):
    env = make()
    env.reset(seed=0)
    env.step(stop_all(env))
    actions = stop_all(env)
    actions[agent] = bad
    assert_rejected(env, actions, (ValueError, TypeError), agent)


@HYPOTHESIS
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), min_size=2, max_size=2))
def test_wheel_actions_outside_the_space_or_not_finite_are_rejected(values):
    env = make(action_type="wheels")
    env.reset(seed=0)
    action = np.array(values, dtype=np.float32)
    if env.action_space("robot_0").contains(action):
        env.step({a: action for a in env.agents})
        return
    assert_rejected(env, {"robot_0": action, "robot_1": np.zeros(2, dtype=np.float32)}, (ValueError, TypeError), "robot_0")


def test_unknown_missing_and_finished_agents_are_rejected():
    env = make(n_spare_robots=1, max_cycles=5)
    env.reset(seed=0)
    assert_rejected(env, {**stop_all(env), "robot_9": STOP}, KeyError, "robot_9")
    assert_rejected(env, {"robot_0": STOP}, ValueError, "robot_1")
    assert_rejected(env, {**stop_all(env), "robot_2": STOP}, ValueError, "robot_2")  # a spare not on the table
    while env.agents:
        env.step(stop_all(env))
    with pytest.raises(teamgym.EpisodeOverError):
        env.step({})


@HYPOTHESIS
@given(
    st.integers(0, 2**16), st.lists(st.lists(st.integers(0, len(Primitive) - 1), min_size=4, max_size=4), min_size=1, max_size=60)
)
def test_any_primitive_sequence_keeps_robots_and_boxes_on_the_table(seed, plan):
    env = make(situation="S3", motor_noise=0.05)
    env.reset(seed=seed)
    for row in plan:
        if not env.agents:
            break
        observations, rewards, *_ = env.step({a: row[i] for i, a in enumerate(env.agents)})
        assert all(np.all(np.isfinite(o)) for o in observations.values())
        assert all(np.isfinite(r) for r in rewards.values())
    state = env.state()
    robots = state[: 5 * 4].reshape(4, 5)
    assert np.all(robots[:, 0] > 0.0275 - 0.002) and np.all(robots[:, 0] < 1.1 - 0.0275 + 0.002)
    assert np.all(robots[:, 1] > 0.0275 - 0.002) and np.all(robots[:, 1] < 0.9 - 0.0275 + 0.002)
