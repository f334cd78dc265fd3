"""Foraging-v0 (paper 002): tasks, camera, uncertainty model (eqs. 1-2), packets, actions, bad input."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import teamgym
from teamgym.envs.config import ConfigError
from teamgym.envs.foraging.grid import GridSpec
from teamgym.envs.foraging.perception import PV_TABLE, ROBOT, SENDER, TARGET, landmark_positions, packet_bytes, visibility

EXACT = {"vision_noise": 0.0, "odometry_rotation_noise": 0.0, "odometry_distance_noise": 0.0}
CENTRE = (1.5, 1.2)  # more than 1 m from every wall: no landmark in view


def velocity_env(**config):
    return teamgym.make("Foraging-v0", action_type="velocity", **config)


def still(env):
    return {a: np.zeros(2, dtype=np.float32) for a in env.agents}


# -- the grid ----------------------------------------------------------------------------------
def test_default_grid_is_the_papers_180_cells_of_one_byte():
    grid = teamgym.make("Foraging-v0").config.grid
    assert (grid.nx, grid.ny, grid.n_cells, grid.location_bytes) == (15, 12, 180, 1)
    assert GridSpec(6.0, 4.8, 0.2).location_bytes == 2  # 720 cells need two bytes


def test_cells_round_trip_and_edge_positions_clip():
    grid = GridSpec(3.0, 2.4, 0.2)
    cells = grid.cell_of(np.array([[0.05, 0.05], [2.999, 2.399], [3.0, 2.4], [-0.1, 1.0]]))
    assert cells.tolist() == [[0, 0], [14, 11], [14, 11], [0, 5]]
    assert np.array_equal(grid.cell_at(grid.index_of(cells)), cells)
    assert np.allclose(grid.centre_of(np.array([3, 2])), (0.7, 0.5))


def test_default_camera_covers_about_16_cells():
    # Section 4.3: "the perception of each robot is limited to 16 cells in the direction of the robot's heading".
    c = teamgym.make("Foraging-v0").config
    area = 0.5 * c.camera_fov * c.camera_range**2
    assert area / c.cell_size**2 == pytest.approx(16, abs=0.1)
    seen = c.grid.sector_mask(*CENTRE, 0.0, c.camera_range, c.camera_fov)
    assert 13 <= seen.sum() <= 19


# -- camera --------------------------------------------------------------------------------------
def test_camera_range_opening_and_occlusion():
    pose = np.array([[0.0, 0.0, 0.0]])
    points = np.array([[0.9, 0.0], [1.1, 0.0], [0.5, 0.5 * math.tan(0.7)], [0.5, 0.5 * math.tan(0.6)]])
    seen, distance, bearing = visibility(pose, points, 1.0, 1.28, np.zeros((0, 2)), 0.09)
    assert seen.tolist() == [[True, False, False, True]]
    assert distance[0, 0] == pytest.approx(0.9) and bearing[0, 3] == pytest.approx(0.6)
    # A robot at (0.45, 0) hides the point at (0.9, 0) from the robot at the origin, not the other way round.
    poses = np.array([[0.0, 0.0, 0.0], [0.45, 0.0, math.pi]])
    seen, _, _ = visibility(poses, np.array([[0.9, 0.0], [0.45, 0.3]]), 1.0, 2 * math.pi, poses[:, :2], 0.09)
    assert not seen[0, 0] and seen[1, 0]
    assert seen[0, 1]  # off the line of sight


def test_landmarks_include_the_corners_and_lie_on_the_walls():
    marks = landmark_positions(3.0, 2.4, 0.6)
    for corner in [(0, 0), (3.0, 0), (3.0, 2.4), (0, 2.4)]:
        assert np.min(np.hypot(*(marks - corner).T)) < 1e-9
    x, y = marks.T
    on_wall = np.isclose(x, 0) | np.isclose(x, 3.0) | np.isclose(y, 0) | np.isclose(y, 2.4)
    assert on_wall.all() and len(marks) == 18


# -- uncertainty: eqs. (1) and (2) -------------------------------------------------------------------
def test_detection_tuple_is_class_cell_and_pv_times_pl():
    env = velocity_env(n_robots=1, n_targets=1, **EXACT)
    obs, _ = env.reset(seed=0, options={"targets": [(2.1, 1.25)], "starts": [(*CENTRE, 0.0)]})
    fields = env.decode(obs["robot_0"])
    assert fields["detection_mask"].tolist() == [1]
    cls, gx, gy, pc = fields["detections"][0]
    assert (cls, gx, gy) == (TARGET, 10, 6)
    # distance 0.60 m -> row 2, bearing 0.083 rad -> column 0; Pl = 1 at the start (eq. 1: Pc = Pv·Pl).
    assert pc == pytest.approx(PV_TABLE[2, 0], abs=1e-6)
    assert fields["detection_polar"][0] == pytest.approx([math.hypot(0.6, 0.05), math.atan2(0.05, 0.6)], abs=1e-6)


def test_pl_decays_as_pe_to_the_rotation_and_odometry_is_exact_without_noise():
    env = velocity_env(n_robots=1, n_targets=1, rotational_certainty=0.8, **EXACT)
    obs, _ = env.reset(seed=0, options={"targets": [(0.3, 0.3)], "starts": [(*CENTRE, 0.0)]})
    turned = 0.0
    heading = 0.0
    for _ in range(20):
        obs, *_, infos = env.step({"robot_0": np.array([0.0, 2.0], dtype=np.float32)})
        new = env.state()[2]
        turned += abs((new - heading + math.pi) % (2 * math.pi) - math.pi)
        heading = new
    fields = env.decode(obs["robot_0"])
    assert turned > 3.0
    assert fields["localisation_certainty"][0] == pytest.approx(0.8**turned, rel=1e-6)  # eq. (2) as reconstructed
    assert fields["pose_estimate"] == pytest.approx(env.state()[:3], abs=1e-5)
    assert infos["robot_0"]["position_error"] == pytest.approx(0.0, abs=1e-9)


def test_odometry_error_grows_with_rotation():
    errors = {}
    for noise in (0.0, 0.2):
        # A large field: no landmark within the camera's range of the path.
        env = velocity_env(n_robots=1, n_targets=1, field_size=(6.0, 4.8), **{**EXACT, "odometry_rotation_noise": noise})
        env.reset(seed=3, options={"targets": [(0.3, 0.3)], "starts": [(3.0, 2.4, 0.0)]})
        for k in range(60):  # spin, then drive straight 0.3 m: the heading error becomes a position error
            action = [0.0, 3.0] if k < 40 else [0.3, 0.0]
            *_, infos = env.step({"robot_0": np.array(action, dtype=np.float32)})
        errors[noise] = infos["robot_0"]["position_error"]
    assert errors[0.0] < 1e-9 < 0.005 < errors[0.2]


def test_landmark_sighting_resets_pl_to_its_pv():
    env = velocity_env(n_robots=1, n_targets=1, rotational_certainty=0.5, **EXACT)
    env.reset(seed=0, options={"targets": [(2.0, 2.0)], "starts": [(0.5, 1.2, math.pi / 2)]})
    # Turn away from the wall (certainty drops), then face the west wall's landmark at (0, 1.2).
    for _ in range(8):
        env.step({"robot_0": np.array([0.0, 3.0], dtype=np.float32)})
    obs, *_ = env.step(still(env))
    certainty = env.decode(obs["robot_0"])["localisation_certainty"][0]
    x, y, theta = env.state()[:3]
    bearings = np.arctan2(env.landmarks[:, 1] - y, env.landmarks[:, 0] - x) - theta
    bearings = (bearings + math.pi) % (2 * math.pi) - math.pi
    sees_landmark = np.any((np.hypot(env.landmarks[:, 0] - x, env.landmarks[:, 1] - y) <= 1.0) & (np.abs(bearings) <= 0.64))
    assert sees_landmark
    assert np.isclose(PV_TABLE, certainty).any()  # reset to the Pv of the sighting, not 0.5**turned
    assert certainty > 0.5 ** (8 * 0.3 * 0.9)


# -- tasks ---------------------------------------------------------------------------------------
def test_consume_takes_consume_time_at_the_target_and_then_the_target_is_gone():
    env = velocity_env(n_robots=2, n_targets=2, consume_time=2.0, **EXACT)
    env.reset(seed=0, options={"targets": [(1.0, 1.0), (2.5, 2.0)], "starts": [(1.05, 1.0, 0.0), (0.3, 0.3, 0.0)]})
    rewards = []
    for k in range(20):
        obs, r, term, trunc, infos = env.step(still(env))
        rewards.append(r["robot_0"])
        if k < 19:
            assert infos["robot_0"]["targets_done"] == 0
            assert env.decode(obs["robot_0"])["consume_progress"][0] == pytest.approx((k + 1) / 20)
    assert infos["robot_0"]["targets_done"] == 1 and infos["robot_0"]["TT1"] == pytest.approx(2.0)
    assert env.state()[6 + 2] == 0.0 and env.state()[6 + 5] == 1.0  # first target gone, second live
    assert rewards[-1] > 0.9 and not infos["robot_0"]["success"] and not any(term.values())
    obs, *_ = env.step(still(env))
    assert env.decode(obs["robot_0"])["at_target"][0] == 0


def test_leaving_a_target_restarts_its_consumption():
    env = velocity_env(n_robots=1, n_targets=1, consume_time=1.0, **EXACT)
    env.reset(seed=0, options={"targets": [(1.0, 1.0)], "starts": [(1.1, 1.0, 0.0)]})
    for _ in range(5):
        env.step(still(env))
    for _ in range(5):  # drive away (0.5 m/s for 0.5 s) and come back
        env.step({"robot_0": np.array([0.5, 0.0], dtype=np.float32)})
    for _ in range(5):
        obs, *_ = env.step({"robot_0": np.array([-0.5, 0.0], dtype=np.float32)})
    assert env.decode(obs["robot_0"])["consume_progress"][0] < 0.5


def test_single_target_consumed_is_success_and_ends_the_episode():
    env = velocity_env(n_robots=1, n_targets=1, consume_time=0.5, **EXACT)
    env.reset(seed=0, options={"targets": [(1.0, 1.0)], "starts": [(1.0, 1.1, 0.0)]})
    for _ in range(5):
        _, _, term, _, infos = env.step(still(env))
    assert term == {"robot_0": True} and infos["robot_0"]["success"]
    assert infos["robot_0"]["TG"] == pytest.approx(0.5) and env.agents == []


def test_surround_needs_robots_per_target_at_once():
    config = dict(task="surround", n_robots=3, n_targets=1, robots_per_target=2, **EXACT)
    env = velocity_env(**config)
    env.reset(seed=0, options={"targets": [(1.0, 1.0)], "starts": [(1.15, 1.0, 0.0), (0.3, 0.3, 0.0), (2.5, 2.0, 0.0)]})
    *_, infos = env.step(still(env))
    assert not infos["robot_0"]["success"]
    env.reset(seed=0, options={"targets": [(1.0, 1.0)], "starts": [(1.15, 1.0, 0.0), (0.85, 1.0, 0.0), (2.5, 2.0, 0.0)]})
    _, _, term, _, infos = env.step(still(env))
    assert infos["robot_2"]["success"] and all(term.values()) and infos["robot_0"]["TG"] == pytest.approx(0.1)


def test_episode_is_truncated_at_the_time_limit():
    env = teamgym.make("Foraging-v0", time_limit=1.0, consume_time=1.0, dt=0.1)
    env.reset(seed=0)
    steps = 0
    while env.agents:
        _, _, term, trunc, _ = env.step({a: 0 for a in env.agents})
        steps += 1
    assert steps == 10 and all(trunc.values())


# -- communication -------------------------------------------------------------------------------
def test_packets_carry_the_sender_tuple_then_its_detections():
    env = velocity_env(n_robots=2, n_targets=1, **EXACT)
    obs, infos = env.reset(seed=0, options={"targets": [(2.1, 1.25)], "starts": [(*CENTRE, 0.0), (0.5, 0.5, math.pi)]})
    fields = env.decode(obs["robot_1"])
    rows = fields["received"][fields["received_mask"] == 1]
    assert rows[:, 0].tolist() == [SENDER, TARGET]
    assert rows[0, 1:3].tolist() == [7, 6] and rows[0, 3] == 1.0  # robot_0's cell and its Pl
    assert fields["received_sender"][:2].tolist() == [0, 0]
    grid = env.config.grid
    assert infos["robot_0"]["bytes_sent"] == packet_bytes(1, grid) == 7
    assert infos["robot_1"]["bytes_sent"] == packet_bytes(0, grid) == 5
    assert infos["robot_1"]["bytes_delivered"] == 7


def test_robots_see_each_other_as_robot_tuples():
    env = velocity_env(n_robots=2, n_targets=1, **EXACT)
    obs, _ = env.reset(seed=0, options={"targets": [(0.3, 0.3)], "starts": [(*CENTRE, 0.0), (2.0, 1.2, 0.0)]})
    fields = env.decode(obs["robot_0"])
    assert fields["detections"][0, 0] == ROBOT and fields["detections"][0, 1:3].tolist() == [10, 6]


@pytest.mark.parametrize("throughput", [0.0, 0.5, 1.0])
def test_delivery_follows_comm_throughput(throughput):
    env = teamgym.make("Foraging-v0", comm_throughput=throughput, time_limit=100.0)
    env.reset(seed=1)
    delivered = 0
    steps = 400
    for _ in range(steps):
        obs, *_ = env.step({a: 0 for a in env.agents})
        delivered += int(env.decode(obs["robot_0"])["received_mask"][0])
    # Binomial(400, p): 99.9 % interval half-width at p = 0.5 is 3.3·sqrt(400/4) = 33.
    assert abs(delivered - throughput * steps) <= 33


# -- actions and bad input -------------------------------------------------------------------------
def test_goto_cell_drives_the_robot_into_the_cell():
    env = teamgym.make("Foraging-v0", n_robots=1, n_targets=1, **EXACT)
    env.reset(seed=0, options={"targets": [(0.3, 2.1)], "starts": [(0.5, 0.5, 0.0)]})
    grid = env.config.grid
    cell = int(grid.index_of(np.array([12, 8])))
    for _ in range(80):
        env.step({"robot_0": cell})
    assert grid.cell_of(env.state()[:2]).tolist() == [12, 8]


def test_goto_cell_homes_on_a_seen_target_and_stops_there():
    env = teamgym.make("Foraging-v0", n_robots=1, n_targets=1, consume_time=3.0)
    env.reset(seed=0, options={"targets": [(2.05, 1.15)], "starts": [(*CENTRE, 0.0)]})
    cell = int(env.config.grid.index_of(env.config.grid.cell_of(np.array([2.05, 1.15]))))
    for _ in range(60):
        _, _, term, _, infos = env.step({"robot_0": cell})
        if not env.agents:
            break
    assert infos["robot_0"]["success"] and infos["robot_0"]["TG"] < 5.0


def test_cell_outside_the_grid_is_refused_and_changes_nothing():
    env = teamgym.make("Foraging-v0")
    env.reset(seed=0)
    before = env.state()
    with pytest.raises(ValueError, match="robot_1"):
        env.step({"robot_0": 3, "robot_1": 180})
    with pytest.raises((ValueError, TypeError), match="robot_0"):
        env.step({"robot_0": np.nan, "robot_1": 3})
    assert np.array_equal(env.state(), before) and env.cycles == 0


def test_masked_cell_is_refused():
    env = teamgym.make("Foraging-v0", field_size=(3.1, 2.4))  # the last column is a 0.1 m strip
    _, infos = env.reset(seed=0)
    mask = infos["robot_0"]["action_mask"]
    assert mask.sum() == 15 * 12 and mask[15] == 0  # gx = 15 of row 0
    with pytest.raises(ValueError, match="masked"):
        env.step({"robot_0": 15, "robot_1": 0})


def test_nan_velocity_is_refused_naming_the_agent():
    env = velocity_env()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="robot_0"):
        env.step({"robot_0": np.array([np.nan, 0.0], dtype=np.float32), "robot_1": np.zeros(2, dtype=np.float32)})


def test_learned_message_of_the_wrong_size_is_refused():
    env = teamgym.make("Foraging-v0", comm_dim=3)
    env.reset(seed=0)
    bad = {"motion": 0, "message": np.zeros(2, dtype=np.float32)}
    good = {"motion": 0, "message": np.zeros(3, dtype=np.float32)}
    with pytest.raises(ValueError, match="robot_0"):
        env.step({"robot_0": bad, "robot_1": good})
    env.step({"robot_0": good, "robot_1": good})


@pytest.mark.parametrize(
    ("config", "key"),
    [
        ({"task": "surround", "robots_per_target": 3}, "robots_per_target"),
        ({"n_targets": 30, "field_size": (1.0, 1.0)}, "n_robots"),
        ({"camera_fov": 0.0}, "camera_fov"),
        ({"rotational_certainty": 1.5}, "rotational_certainty"),
        ({"field_size": (3.0,)}, "field_size"),
        ({"consume_time": 300.0}, "consume_time"),
        ({"task": "collect"}, "task"),
        ({"observe_novelty": True, "novelty_time": 0.0}, "novelty_time"),
    ],
)
def test_invalid_configs_are_refused_naming_the_key(config, key):
    with pytest.raises(ConfigError, match=key):
        teamgym.make("Foraging-v0", **config)


def test_reset_options_are_checked():
    env = teamgym.make("Foraging-v0")
    with pytest.raises(ValueError, match="targets"):
        env.reset(seed=0, options={"targets": [(5.0, 1.0), (1.0, 1.0), (2.0, 1.0)]})


def test_world_model_observation_is_a_bounded_grid():
    env = teamgym.make("Foraging-v0", observe_world_model=True, obs_format="dict")
    obs, _ = env.reset(seed=2)
    for _ in range(30):
        obs, *_ = env.step({a: 90 for a in env.agents})
    model = obs["robot_0"]["world_model"]
    assert model.shape == (2, 12, 15) and env.observation_space("robot_0").contains(obs["robot_0"])
    assert model.max() > 0  # robot_1 (and possibly targets) are in it


def test_novelty_observation_is_dmaps_search_novelty_of_the_robots_own_model():
    from teamgym.envs.foraging.env import novelty

    env = teamgym.make("Foraging-v0", observe_novelty=True, novelty_time=20.0, obs_format="dict")
    obs, _ = env.reset(seed=2)
    assert "world_model" not in obs["robot_0"]  # the world model is kept but observed only with observe_world_model
    for _ in range(30):
        obs, *_ = env.step({a: 90 for a in env.agents})
    layer = obs["robot_0"]["novelty"]
    last_seen = env.models["robot_0"].last_seen
    age = env.world.time - last_seen
    np.testing.assert_allclose(layer, np.where(np.isinf(last_seen), 1.0, 1.0 - np.exp(-age / 20.0)), rtol=1e-6, atol=1e-7)
    assert layer.min() == 0.0 and (layer == 1.0).any() and env.observation_space("robot_0").contains(obs["robot_0"])
    assert novelty(5.0, np.array([-np.inf, 5.0]), 30.0).tolist() == [1.0, 0.0]
    plain = teamgym.make("Foraging-v0").observation_space("robot_0").shape[0]
    both = teamgym.make("Foraging-v0", observe_novelty=True, observe_world_model=True).observation_space("robot_0").shape[0]
    assert both == plain + 3 * 12 * 15  # novelty after the world model's two layers


def test_own_world_model_is_built_from_own_sightings_as_dmaps_nocomm_builds_its_model():
    from baselines.registry import make_policy

    config = {"n_robots": 4, "observe_world_model": True, "obs_format": "dict"}
    agreement = {}
    for sources in ("own", "all"):
        env = teamgym.make("Foraging-v0", world_model_sources=sources, **config)
        teacher = make_policy("dmaps-nocomm", env)
        obs, infos = env.reset(seed=5)
        teacher.reset(5)
        equal = []
        for _ in range(40):
            actions = teacher.act(obs, infos)  # the teacher perceives this observation, then decides
            for agent in env.agents:
                model = env.models[agent]
                np.testing.assert_array_equal(obs[agent]["world_model"], model.fused())
                if sources == "own":
                    assert model.n_contributors == 1  # nothing received is fused in
                equal.append(np.mean(np.abs(obs[agent]["world_model"] - teacher.planners[agent].model.fused()) < 1e-3))
            obs, _, _, _, infos = env.step(actions)
        agreement[sources] = float(np.mean(equal))
    # the same model as the teacher's but for the camera sector's edge (exact here, quantised in dmaps)
    assert agreement["own"] > 0.98 and agreement["all"] < agreement["own"] - 0.05, agreement
    assert env.observation_space("robot_0") == teamgym.make("Foraging-v0", **config).observation_space("robot_0")


def test_world_model_sources_is_checked():
    with pytest.raises(ValueError, match="world_model_sources"):
        teamgym.make("Foraging-v0", world_model_sources="others")


# -- both tasks through PettingZoo's tests; input handling under hypothesis ----------------------
SURROUND_CASES = [
    pytest.param({"action_type": kind, "obs_format": fmt}, id=f"surround-{kind}-{fmt}")
    for kind in ("goto_cell", "velocity")
    for fmt in ("flat", "dict")
]


@pytest.mark.parametrize("config", SURROUND_CASES)
def test_surround_passes_the_pettingzoo_api_seed_and_render_tests(config):
    from pettingzoo.test import parallel_api_test, parallel_seed_test, render_test, seed_test

    settings = {"task": "surround", "n_targets": 1, "max_cycles": 25, **config}
    parallel_api_test(teamgym.make("Foraging-v0", **settings), num_cycles=30)
    parallel_seed_test(lambda: teamgym.make("Foraging-v0", **settings), num_cycles=15)
    seed_test(lambda: teamgym.make_aec("Foraging-v0", **settings), num_cycles=10)

    def aec(render_mode=None):
        env = teamgym.make_aec("Foraging-v0", render_mode=render_mode, **settings)
        env.metadata = {**env.metadata, "render_modes": ["rgb_array"]}  # "human" is tested in test_env_api
        return env

    render_test(aec)


HYPOTHESIS = settings(max_examples=60, deadline=None, database=None)


@HYPOTHESIS
@given(cell=st.integers().filter(lambda v: not 0 <= v < 180), warmup=st.integers(0, 5), seed=st.integers(0, 2**16))
def test_any_cell_outside_the_grid_is_rejected_and_harmless(cell, warmup, seed):
    env = teamgym.make("Foraging-v0")
    env.reset(seed=seed)
    for _ in range(warmup):
        env.step({a: 90 for a in env.agents})
    before, cycles = env.state(), env.cycles
    with pytest.raises(ValueError, match="robot_1"):
        env.step({"robot_0": 90, "robot_1": cell})
    assert np.array_equal(env.state(), before) and env.cycles == cycles


@HYPOTHESIS
@given(
    v=st.floats(allow_nan=True, allow_infinity=True, width=32),
    w=st.floats(allow_nan=True, allow_infinity=True, width=32),
    seed=st.integers(0, 2**16),
)
def test_velocity_actions_are_accepted_exactly_when_the_space_contains_them(v, w, seed):
    env = velocity_env()
    env.reset(seed=seed)
    action = np.array([v, w], dtype=np.float32)
    before = env.state()
    actions = {"robot_0": action, "robot_1": np.zeros(2, dtype=np.float32)}
    if env.action_space("robot_0").contains(action):
        env.step(actions)
        assert env.cycles == 1
    else:
        with pytest.raises(ValueError, match="robot_0"):
            env.step(actions)
        assert np.array_equal(env.state(), before) and env.cycles == 0


# -- episode length --------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("config", "cycles"),
    [
        ({}, 2000),  # 200 s of 0.1 s steps
        ({"dt": 0.05}, 4000),
        ({"time_limit": 33.3}, 333),
        ({"time_limit": 0.25, "dt": 0.1, "consume_time": 0.1}, 3),
        ({"max_cycles": 500}, 500),  # a set max_cycles still caps
        ({"max_cycles": 5000}, 2000),  # ... and time_limit too
        ({"dt": 1e-4, "substeps": 1, "time_limit": 100_000.0}, 10**6),  # the derived length stops at 10**6
        ({"dt": 1e-4, "substeps": 1, "time_limit": 100_000.0, "max_cycles": 10**9}, 10**9),
    ],
)
def test_episode_length_derives_from_time_limit_and_max_cycles_caps_it(config, cycles):
    c = teamgym.make("Foraging-v0", **config).config
    assert c.max_cycles == config.get("max_cycles")  # None unless set: no stand-in count
    assert c.cycle_limit == cycles == min(c.max_cycles or 10**6, math.ceil(c.time_limit / c.dt - 1e-9))
    assert type(c)(**c.as_dict()).cycle_limit == cycles


def test_episodes_are_truncated_at_the_derived_length():
    env = velocity_env(time_limit=1.0, n_targets=1, consume_time=1.0)
    env.reset(seed=0)
    steps = 0
    while env.agents:
        *_, truncations, _ = env.step(still(env))
        steps += 1
    assert steps == env.config.cycle_limit == 10 and all(truncations.values())


@pytest.mark.parametrize("value", [0, -1, 10**9 + 1, 2.5, True, "many"])
def test_an_invalid_max_cycles_is_a_one_line_error_naming_it(value):
    with pytest.raises(ConfigError, match=f"max_cycles={value!r} is invalid") as caught:
        teamgym.make("Foraging-v0", max_cycles=value)
    assert "\n" not in str(caught.value)


# -- the vectorised sensing phase ---------------------------------------------------------------
@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10**6), n=st.integers(1, 6), t=st.integers(0, 4), spread=st.sampled_from([0.3, 1.0, 3.0]))
def test_cameras_see_what_visibility_sees(seed, n, t, spread):
    """Cameras.seen (occlusion masks built once, skipped for teammates out of range) equals visibility()."""
    from teamgym.envs.foraging.sensing import Cameras

    rng = np.random.default_rng(seed)
    landmarks = landmark_positions(3.0, 2.4, 0.6)
    cameras = Cameras(n, landmarks, 1.0, 1.28, 0.09)
    pose = np.column_stack([1.5 + spread * rng.uniform(-0.5, 0.5, (n, 2)), rng.uniform(-math.pi, math.pi, n)])
    targets = rng.uniform(0, (3.0, 2.4), (4, 2))
    live = np.sort(rng.choice(4, size=t, replace=False))
    seen, distance, bearing = cameras.seen(pose, cameras.view(pose, cameras.points(targets)), live)
    points = np.concatenate([targets[live], pose[:, :2], landmarks])
    skip = np.full((n, len(points)), -1)
    skip[:, t : t + n] = np.arange(n)
    expected, d, b = visibility(pose, points, 1.0, 1.28, pose[:, :2], 0.09, skip)
    expected[np.arange(n), t + np.arange(n)] = False
    assert np.array_equal(seen, expected) and np.array_equal(distance, d) and np.array_equal(bearing, b)


def test_frame_changes_are_the_textbook_products_and_sums():
    from teamgym.envs.foraging.frames import to_field, to_robot

    rng = np.random.default_rng(5)
    v, theta = rng.normal(size=(50, 2)), rng.uniform(-math.pi, math.pi, 50)
    c, s = np.cos(theta), np.sin(theta)
    assert np.array_equal(to_robot(v, c, s), np.column_stack([c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1]]))
    assert np.array_equal(to_field(v, c, s), np.column_stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]]))


def test_one_draw_measures_sightings_then_fixes_as_separate_draws_did():
    from teamgym.envs.foraging.perception import VisionModel
    from teamgym.envs.foraging.sensing import measure_all

    vision = VisionModel(1.0, 1.28, 2.0)
    sightings = (np.array([0.2, 0.9, 0.5]), np.array([0.1, -0.6, 3.1]), np.array([0.95, 0.5, 0.8]))
    fixes = [(0, 0.7, -0.2, 0.65), (2, 0.3, 0.4, 0.9)]  # (robot row, true distance, bearing, Pv)
    (d, b), (fd, fb) = measure_all(vision, sightings, fixes, np.random.default_rng(3))
    rng = np.random.default_rng(3)
    assert np.array_equal(np.stack([d, b]), np.stack(vision.measure(*sightings[:2], sightings[2], rng)))
    for k, (_, true_d, true_b, pv) in enumerate(fixes):  # then one robot's (distance, bearing) error after the other's
        one = vision.measure(np.array([true_d]), np.array([true_b]), np.array([pv]), rng)
        assert (fd[k], fb[k]) == (one[0][0], one[1][0])


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10**6), n=st.integers(2, 9), spread=st.sampled_from([0.3, 1.0]))
def test_occlusion_one_by_one_equals_the_numpy_pass(seed, n, spread):
    """Cameras.seen gives the same bits whether it checks occlusion sighting by sighting or in one numpy pass."""
    from teamgym.envs.foraging import sensing

    rng = np.random.default_rng(seed)
    cameras = sensing.Cameras(n, landmark_positions(3.0, 2.4, 0.6), 1.0, 1.28, 0.09)
    pose = np.column_stack([1.5 + spread * rng.uniform(-0.5, 0.5, (n, 2)), rng.uniform(-math.pi, math.pi, n)])
    view = cameras.view(pose, cameras.points(rng.uniform(0, (3.0, 2.4), (3, 2))))
    live = np.arange(3)
    saved = sensing._SCALAR_CHECKS
    try:
        sensing._SCALAR_CHECKS = 10**9
        one_by_one = cameras.seen(pose, view, live)[0]
        sensing._SCALAR_CHECKS = -1
        vectorised = cameras.seen(pose, view, live)[0]
    finally:
        sensing._SCALAR_CHECKS = saved
    assert np.array_equal(one_by_one, vectorised)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10**6), noise=st.sampled_from([0.5, 1.0, 3.0]))
def test_scalar_pv_and_measurement_equal_the_array_forms(seed, noise):
    """VisionModel.pv_of / measure_one (one object) give the bits of pv / measure_with (arrays)."""
    from teamgym.envs.foraging.perception import VisionModel

    rng = np.random.default_rng(seed)
    vision = VisionModel(1.0, 1.28, noise)
    d, b = rng.uniform(0, 1.0, 30), rng.uniform(-0.64, 0.64, 30)
    pv = vision.pv(d, b)
    assert pv.tolist() == [vision.pv_of(x, y) for x, y in zip(d.tolist(), b.tolist())]
    nd, nb = rng.standard_normal(30) * 3, rng.standard_normal(30) * 3
    md, mb = vision.measure_with(d, b, pv, nd, nb)
    one = [vision.measure_one(*v) for v in zip(d.tolist(), b.tolist(), pv.tolist(), nd.tolist(), nb.tolist())]
    assert (md.tolist(), mb.tolist()) == ([v[0] for v in one], [v[1] for v in one])
