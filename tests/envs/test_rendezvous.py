"""Rendezvous-v0 (paper 003): ways, blocking and detection, the next-place macro action, meeting, messages."""

import dataclasses
import math

import networkx as nx
import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

from teamgym.envs.config import ConfigError
from teamgym.envs.rendezvous import RendezvousConfig, parallel_env
from teamgym.envs.rendezvous.messages import Kind, decode, encode, used_length

SQUARE = dict(
    map="square4", start_places=("A", "C"), protocol_messages=True
)  # A(0.5,0.5) B(2.5,0.5) C(2.5,2.5) D(0.5,2.5), diagonal A–C


def silent(env, move):
    """An action with no message."""
    return {"move": move, "message": np.full(env.config.message_len, -1, dtype=np.int32)}


def place_of(env, agent):
    return env.place_id(env._place[env.possible_agents.index(agent)])


def slot(env, agent, place_id):
    i = env.possible_agents.index(agent)
    row = env.neighbour_table[env._place[i]].tolist()
    return row.index(env.place_index[place_id])


def test_api_on_the_square_map():
    parallel_api_test(parallel_env(**SQUARE, max_cycles=200), num_cycles=30)


def test_blocked_way_is_detected_at_its_place_and_masked():
    env = parallel_env(**SQUARE, blocked_ways=(("A", "C"),))
    obs, infos = env.reset(seed=0)
    fields = env.decode(obs["robot_0"])
    diagonal = slot(env, "robot_0", "C")
    assert fields["blocked"][diagonal] == 1 and env.action_mask("robot_0")[diagonal] == 0
    assert infos["robot_0"]["action_mask"]["move"][diagonal] == 0 and infos["robot_0"]["action_mask"]["message"] is None
    assert infos["robot_0"]["blocked_known"] == 1
    with pytest.raises(ValueError, match="masked"):
        env.step({"robot_0": silent(env, diagonal), "robot_1": silent(env, env.max_degree)})


def test_a_step_lasts_until_a_robot_reaches_its_next_place():
    env = parallel_env(**SQUARE)
    env.reset(seed=0)
    *_, infos = env.step({"robot_0": silent(env, slot(env, "robot_0", "B")), "robot_1": silent(env, env.max_degree)})
    assert env.place_id(infos["robot_0"]["place"]) == "B"
    length = 2.0 * env.config.scale
    assert env.world.time == pytest.approx(length / 0.1, rel=0.25)


def test_robots_meet_and_succeed():
    env = parallel_env(**SQUARE)
    env.reset(seed=0)
    *_, infos = env.step({"robot_0": silent(env, slot(env, "robot_0", "C")), "robot_1": silent(env, slot(env, "robot_1", "A"))})
    for _ in range(20):
        if not env.agents:
            break
        *_, infos = env.step({a: silent(env, env.max_degree) for a in env.agents})
    assert env.episode_success() and infos["robot_0"]["success"]
    assert "meeting_time" in infos["robot_0"] and infos["robot_0"]["robot_collisions"] == 0
    positions = np.array([r.position for r in env.robots.values()])
    assert np.linalg.norm(positions[0] - positions[1]) <= env.config.meet_distance


def test_a_robot_on_a_way_finishes_it_and_the_obstacle_comes_after():
    env = parallel_env(**SQUARE, blockings=(("A", "B", 0.5),))
    env.reset(seed=0)
    env.step({"robot_0": silent(env, slot(env, "robot_0", "B")), "robot_1": silent(env, env.max_degree)})
    assert place_of(env, "robot_0") == "B"  # reached B although A–B was blocked on the way
    assert any(name.startswith("blocker_") for name in env.world.entities)


def test_path_messages_are_scored_against_the_known_map():
    env = parallel_env(**SQUARE)
    env.reset(seed=0)
    a, b, c, d = (env.place_index[p] for p in "ABCD")
    detour = encode([(Kind.PATH, (7, a, b, c))], env.config.message_len)
    obs, *_, infos = env.step({"robot_0": {"move": env.max_degree, "message": detour}, "robot_1": silent(env, env.max_degree)})
    expected = (2.0 + 2.2) / math.hypot(2.0, 2.0)  # A–B (2 m) + B–C (2.2 m) over the diagonal
    assert infos["robot_0"]["optimality"] == pytest.approx(expected)
    assert infos["robot_0"]["plans"] == 1 and infos["robot_0"]["expansions"] == 7
    assert env.decode(obs["robot_1"])["message_mask"][0] == 1


def test_messages_reach_the_partner_through_the_channel():
    env = parallel_env(**SQUARE, comm_latency=1)
    env.reset(seed=0)
    message = encode([(Kind.PRESENT, (env.place_index["A"],))], env.config.message_len)
    obs, *_ = env.step({"robot_0": {"move": env.max_degree, "message": message}, "robot_1": silent(env, env.max_degree)})
    assert env.decode(obs["robot_1"])["message_mask"][0] == 0  # one step of latency
    obs, *_, infos = env.step({a: silent(env, env.max_degree) for a in env.agents})
    fields = env.decode(obs["robot_1"])
    assert fields["message_mask"][0] == 1 and fields["message_sender"][0] == 0
    assert decode(fields["messages"][0]) == [(Kind.PRESENT, (env.place_index["A"],))]
    assert infos["robot_0"]["bytes_sent"] == 4 * used_length(message)


def test_random_blocking_keeps_the_map_connected():
    env = parallel_env(map="square4", block_rate=50.0, max_cycles=300, protocol_messages=True)
    env.reset(seed=3)
    for _ in range(30):
        if not env.agents:
            break
        env.step({a: silent(env, env.max_degree) for a in env.agents})
    ways = [env.way_ends[k] for k in range(len(env.way_ends)) if k not in env._blocked]
    graph = nx.Graph(ways)
    graph.add_nodes_from(range(len(env.place_index)))
    assert env._blocked and nx.is_connected(graph)


def test_robots_stay_inside_the_corridors():
    env = parallel_env(map="square4", action_type="velocity", protocol_messages=False, max_cycles=150)
    env.reset(seed=1)
    rng = np.random.default_rng(0)
    while env.agents:
        env.step({a: np.array([0.4, rng.uniform(-3, 3)], dtype=np.float32) for a in env.agents})
        for x, y in env.world.robot_states[:, :2].tolist():
            gaps = [_distance_to_segment((x, y), env.places_xy[a], env.places_xy[b]) for a, b in env.way_ends]
            gaps += [math.dist((x, y), p) for p in env.places_xy.tolist()]
            assert min(gaps) <= env.config.corridor_width * 0.6 + 0.01


def _distance_to_segment(p, a, b):
    a, b, p = np.asarray(a), np.asarray(b), np.asarray(p)
    t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * (b - a))))


@pytest.mark.parametrize(
    ("key", "value", "fragment"),
    [
        ("start_places", ("A", "Z"), "unknown place"),
        ("start_places", ("A", "A"), "distinct"),
        ("blocked_ways", (("A", "Z"),), "does not have"),
        ("speeds", (0.1, 0.5), "speeds"),
        ("n_robots", 1, "n_robots"),
        ("map", "nowhere", "map="),
    ],
)
def test_bad_config_is_refused_everywhere(key, value, fragment):
    with pytest.raises(ConfigError, match=fragment):
        parallel_env(**{"map": "square4", key: value})
    with pytest.raises(ConfigError, match=fragment):
        dataclasses.replace(RendezvousConfig(map="square4"), **{key: value})


def test_blocking_every_way_between_the_starts_is_refused_at_make():
    with pytest.raises(ConfigError, match="without a path"):
        parallel_env(map="square4", start_places=("A", "C"), blocked_ways=(("A", "B"), ("A", "C"), ("A", "D")))


def test_block_way_between_steps_is_detected_and_replayed_by_copies():
    import copy

    env = parallel_env(**SQUARE)
    env.reset(seed=0)
    with pytest.raises(KeyError, match="no way"):
        env.block_way("B", "D")
    env.block_way("A", "B")
    clone = copy.deepcopy(env)
    for e in (env, clone):
        e.step({a: silent(e, e.max_degree) for a in e.agents})
    assert env.action_mask("robot_0")[slot(env, "robot_0", "B")] == 0
    np.testing.assert_array_equal(env.state(), clone.state())


def test_a_way_that_cannot_be_passed_is_abandoned_and_known_blocked():
    from teamgym.envs.rendezvous.scene import blocker_vertices
    from teamgym.sim.objects import StaticPolygon

    env = parallel_env(**SQUARE, max_cycles=3000)
    env.reset(seed=0)
    a, b = env.place_index["A"], env.place_index["B"]
    # An obstacle the env does not know of (not a blocked way): the robot finds out by trying.
    env.world.add(StaticPolygon("crate", blocker_vertices(tuple(env.places_xy[a]), tuple(env.places_xy[b]), 0.14)))
    *_, infos = env.step({"robot_0": silent(env, slot(env, "robot_0", "B")), "robot_1": silent(env, env.max_degree)})
    assert infos["robot_0"]["failed_moves"] == 1
    assert env.action_mask("robot_0").tolist() == [0] * env.max_degree + [1]  # driving back: only "wait"
    for _ in range(10):
        if env._target[0] < 0:
            break
        env.step({x: silent(env, env.max_degree) for x in env.agents})
    assert place_of(env, "robot_0") == "A" and env.action_mask("robot_0")[slot(env, "robot_0", "B")] == 0


def test_robots_of_different_speeds_meet_nearer_the_slow_one():
    # Steps 4 and 8: no meeting place is fixed in advance; the faster robot covers more of the path.
    from baselines import make_policy, run_episode

    env = parallel_env(start_places=("1", "38"), speeds=(0.05, 0.15), protocol_messages=True, stage_end="any")
    result = run_episode(env, make_policy("bidir-astar", env), seed=0)
    assert result.success
    slow, fast = (result.metrics[a]["path_length"] for a in env.possible_agents)
    assert fast > 2 * slow


def test_a_collision_between_robots_spoils_the_meeting():
    env = parallel_env(**SQUARE)
    env.reset(seed=0)
    env._arrays.robot_collisions[env._copy] = 1  # as if the robots had bumped on the way
    env._arrays.met[env._copy] = True
    assert not env.episode_success()


def test_blocked_ways_that_cut_the_map_are_refused_for_random_starts():
    with pytest.raises(ConfigError, match="random start places"):
        parallel_env(map="square4", blocked_ways=(("A", "B"), ("A", "C"), ("A", "D")))


@pytest.mark.parametrize("n", [2, 3, 5])
def test_pair_distances_are_the_norms_and_their_mean_bit_for_bit(n):
    env = parallel_env(n_robots=n)
    env.reset(seed=0)
    rng = np.random.default_rng(n)
    for _ in range(50):
        env.world.robot_states = rng.uniform(0.0, 5.0, size=(n, 6))  # a new array, as every read of the world gives
        pos = env.world.robot_states[:, :2]
        expected = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)
        _, distances, mean = env._pair_distances()
        assert np.array_equal(np.array(distances).reshape(n, n), expected)
        assert mean == float(expected.sum() / (n * (n - 1)))


def test_nearest_place_is_the_argmin_of_the_norms_within_half_a_corridor():
    env = parallel_env()
    env.reset(seed=0)
    rng, half = np.random.default_rng(1), env.config.corridor_width / 2
    places = env.places_xy
    for trial in range(3000):
        centre = places[rng.integers(len(places))]
        x, y = (centre + rng.normal(0.0, half, 2) * (0.01, 1.0, 2.0)[trial % 3]).tolist()
        d = np.linalg.norm(places - np.array((x, y)), axis=1)
        k = int(np.argmin(d))
        env._arrays.nearest_seen[env._copy][0] = ()
        assert env._nearest_place(0, (x, y, 0.0)) == (k if d[k] <= half else int(env._place[0]))


def test_neighbour_offsets_are_each_slots_place_minus_the_robot():
    env = parallel_env(map="square4", start_places=("A", "C"), neighbour_offsets=True)
    obs, _ = env.reset(seed=0)
    plain = parallel_env(map="square4", start_places=("A", "C"))
    plain_obs, _ = plain.reset(seed=0)
    for agent in env.possible_agents:
        fields = env.decode(obs[agent])
        x, y = fields["pose"][:2]
        for k, place in enumerate(fields["neighbours"].astype(int).tolist()):
            expected = env.places_xy[place] - (x, y) if place >= 0 else (0.0, 0.0)
            np.testing.assert_allclose(fields["neighbour_xy"][k], expected, atol=1e-6)
        # the other fields are those of the env without the option
        np.testing.assert_array_equal(obs[agent][: plain_obs[agent].size], plain_obs[agent])
    b = slot(env, "robot_0", "B")
    obs, *_ = env.step({"robot_0": b, "robot_1": env.max_degree})
    fields = env.decode(obs["robot_0"])
    assert env.place_id(int(fields["place"][0])) == "B"
    np.testing.assert_allclose(fields["neighbour_xy"][slot(env, "robot_0", "A")], (-2.0 * env.config.scale, 0.0), atol=0.02)
