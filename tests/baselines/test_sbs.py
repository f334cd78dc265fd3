"""The SBS baseline of paper 004: behaviour table and conflict resolution, situation recognizer, policy."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import teamgym
from baselines.box_pushing.behaviours import BEHAVIOURS, SBS, primitive_for, select
from baselines.box_pushing.recognizer import RecognizerParams, SituationRecognizer, group_of_bearing
from baselines.registry import make_policy
from teamgym.control.primitives import Primitive
from teamgym.sim.sensors import KHEPERA_RING

FREE = np.full(8, 0.1)
DARK_BACK = np.array([0.2, 0.5, 1.0, 1.0, 0.5, 0.2, 0.0, 0.0])  # lamp straight ahead
STILL = np.zeros(4)
DRIVING = np.array([2.5, 2.5, 2.5, 2.5])  # commanded = actual rotation (rad per step)
STALLED = np.array([1.0, 1.0, 0.0, 0.0])


def recognizer(**overrides):
    params = RecognizerParams(ray_angles=tuple(KHEPERA_RING.tolist()), look_cycles=0, **overrides)
    return SituationRecognizer(params)


def readings(**rays):
    out = FREE.copy()
    for key, value in rays.items():
        out[int(key[1:])] = value
    return out


# -- behaviours ------------------------------------------------------------------------------


def test_sets_hold_the_papers_behaviours():
    assert SBS[1] == (1, 2, 3, 4, 5) == SBS[4]
    assert SBS[2] == tuple(range(1, 10))
    assert SBS[3] == (1, 2, 3, 4, 5, *range(10, 20))
    assert BEHAVIOURS[4].action == "push-straight" and BEHAVIOURS[4].all_of == ("forward-object", "forward-light")


@pytest.mark.parametrize(
    ("sbs", "facts", "number"),
    [
        (1, set(), 1),
        (1, {"left-object"}, None),  # nothing applies: the policy turns away
        (1, {"forward-object", "forward-light"}, 4),
        (1, {"forward-object", "left-light"}, 3),
        (1, {"forward-object", "right-light"}, 5),
        (1, {"forward-object", "forward-light", "no-rotation"}, 2),  # tie of two conditions: the younger number
        (2, {"forward-object", "back-light"}, 6),
        (2, {"forward-object", "forward-light", "left-object"}, 8),  # more specific than B-4
        (2, {"forward-object", "forward-light", "right-object"}, 9),
        (3, {"forward-object", "back-robot", "forward-light", "no-rotation"}, 15),  # the head keeps pushing
        (3, {"left-robot"}, 10),  # negations do not count: B-1 is the least specific
        (3, {"forward-robot"}, 14),
        (3, {"forward-robot-leaving"}, 13),
        (3, {"back-robot"}, 11),
        (3, {"back-robot-leaving"}, 12),
        (3, {"forward-robot", "forward-object", "forward-light"}, 19),
        (3, {"forward-robot", "forward-object", "back-light"}, 18),
        (3, {"forward-robot", "forward-object", "forward-light", "back-robot-leaving"}, 17),
        (1, {"forward-robot", "forward-object", "forward-light"}, 4),  # SBS-1 knows no robots
    ],
)
def test_conflict_resolution(sbs, facts, number):
    chosen = select(sbs, frozenset(facts))
    assert (chosen.number if chosen else None) == number


FACTS = [
    "forward-object",
    "left-object",
    "right-object",
    "back-object",
    "forward-light",
    "left-light",
    "right-light",
    "back-light",
    "no-rotation",
    "forward-robot",
    "left-robot",
    "right-robot",
    "back-robot",
    "forward-robot-leaving",
    "back-robot-leaving",
]


@settings(max_examples=300, deadline=None, database=None)
@given(st.sampled_from([1, 2, 3, 4]), st.sets(st.sampled_from(FACTS)))
def test_selection_follows_footnote_1(sbs, facts):
    facts = frozenset(facts)
    chosen = select(sbs, facts)
    applicable = [BEHAVIOURS[n] for n in SBS[sbs] if BEHAVIOURS[n].applies(facts)]
    if chosen is None:
        assert applicable == []
        return
    assert chosen.number in SBS[sbs] and chosen.applies(facts)
    for other in applicable:
        assert other.specificity < chosen.specificity or (
            other.specificity == chosen.specificity and other.number >= chosen.number
        )
    assert isinstance(primitive_for(chosen, facts), Primitive)


def test_following_moves_towards_the_robot_of_the_condition():
    assert primitive_for(BEHAVIOURS[10], frozenset({"right-robot"})) is Primitive.FOLLOW_RIGHT
    assert primitive_for(BEHAVIOURS[10], frozenset({"left-robot", "right-robot"})) is Primitive.FOLLOW_LEFT
    assert primitive_for(BEHAVIOURS[13], frozenset({"forward-robot-leaving"})) is Primitive.FOLLOW_FORWARD
    assert primitive_for(BEHAVIOURS[16], frozenset()) is Primitive.FOLLOW_BACK
    assert primitive_for(BEHAVIOURS[17], frozenset()) is Primitive.FOLLOW_BACK
    assert primitive_for(BEHAVIOURS[19], frozenset()) is Primitive.SIDE_AND_PUSH


# -- recognizer -------------------------------------------------------------------------------


def test_sensor_groups_and_light_directions():
    r = recognizer()
    assert r.situation == "S1"
    facts = r.update(readings(r0=0.01, r2=0.015, r5=0.05, r7=0.019), DARK_BACK, DRIVING)
    assert {"left-object", "forward-object", "back-object", "forward-light"} <= facts
    assert "right-object" not in facts
    assert "left-light" in r.update(FREE, np.roll(DARK_BACK, -2), DRIVING)
    assert "back-light" in r.update(FREE, np.array([0, 0, 0, 0, 0, 0.3, 1.0, 0.3]), DRIVING)
    assert "no-light" in r.update(FREE, np.full(8, 0.4), DRIVING)
    groups = [group_of_bearing(a) for a in KHEPERA_RING]
    assert groups == ["left", "forward", "forward", "forward", "forward", "right", "back", "back"]


def test_no_rotation_after_stall_cycles():
    r = recognizer(stall_cycles=3)
    seen = [("no-rotation" in r.update(readings(r2=0.0), DARK_BACK, STALLED)) for _ in range(4)]
    assert seen == [False, False, True, True]
    assert "no-rotation" not in r.update(readings(r2=0.0), DARK_BACK, DRIVING)


def test_m_from_a_change_while_standing_still():
    r = recognizer(tm=2.0)
    r.update(readings(r3=0.08), DARK_BACK, DRIVING)
    r.update(readings(r3=0.05), DARK_BACK, DRIVING)  # changed, but the robot itself moved
    assert not r.m
    facts = r.update(readings(r3=0.06), DARK_BACK, STILL)
    assert r.m and r.situation == "S2" and "forward-robot" in facts
    for _ in range(19):
        r.update(FREE, DARK_BACK, STILL)
    assert r.m and "forward-robot-leaving" in r.facts  # it left; ¬M only after Tm
    for _ in range(2):
        r.update(FREE, DARK_BACK, STILL)
    assert not r.m and r.situation == "S1"
    assert [(t.before, t.after) for t in r.transitions] == [("S1", "S2"), ("S2", "S1")]


def test_leaving_is_remembered_for_leaving_time():
    r = recognizer(leaving_time=0.45)
    r.update(readings(r6=0.05), DARK_BACK, STILL)
    assert "back-robot" in r.update(readings(r6=0.07), DARK_BACK, STILL)
    steps = [r.update(FREE, DARK_BACK, DRIVING) for _ in range(7)]
    assert ["back-robot-leaving" in f for f in steps] == [True] * 5 + [False] * 2


def test_a_robot_seen_leaving_while_standing_still_is_leaving():
    # Section 3.4: "forward/back-robot-leaving means that another robot which was sensed
    # forward/back becomes not to be sensed". Standing still, a forward reading that moves out
    # of range is a moving object (AS-1) that stopped being sensed, even if it was never marked.
    r = recognizer(leaving_time=0.25)
    r.update(readings(r2=0.09), DARK_BACK, DRIVING)  # sighted while driving: no M check
    facts = r.update(FREE, DARK_BACK, STILL)  # standing still, the reading left the range
    assert r.m and "forward-robot-leaving" in facts and "forward-robot" not in facts
    assert "back-robot-leaving" not in facts
    later = [r.update(FREE, DARK_BACK, STILL) for _ in range(3)]
    assert ["forward-robot-leaving" in f for f in later] == [True, True, False]
    # Driving, the same disappearance is the robot's own motion: nothing is inferred.
    r = recognizer()
    r.update(readings(r6=0.09), DARK_BACK, DRIVING)
    assert "back-robot-leaving" not in r.update(FREE, DARK_BACK, DRIVING) and not r.m


def test_a_robot_that_stops_moving_is_forgotten():
    r = recognizer(mark_patience=5)
    r.update(readings(r1=0.05), DARK_BACK, STILL)
    r.update(readings(r1=0.07), DARK_BACK, STILL)
    facts = [r.update(readings(r1=0.07), DARK_BACK, STILL) for _ in range(6)]
    assert "forward-robot" in facts[3] and "forward-robot" not in facts[5]
    assert "forward-robot-leaving" not in facts[5]  # it did not leave, it stopped


def test_marks_turn_with_the_robot():
    r = recognizer()
    r.update(readings(r2=0.05), DARK_BACK, STILL)
    r.update(readings(r2=0.07), DARK_BACK, STILL)
    quarter = np.pi / 2 * 0.053 / 2 / 0.008  # wheel rotation for a 90° left turn in place
    facts = r.update(readings(r5=0.07), DARK_BACK, np.array([-quarter, quarter, -quarter, quarter]))
    assert "right-robot" in facts and "forward-robot" not in facts


def stall_against_a_wall(r, cycles):
    r.update(readings(r2=0.0, r3=0.0), DARK_BACK, DRIVING)  # drive into contact
    for _ in range(cycles):
        r.update(readings(r2=0.0, r3=0.0), DARK_BACK, STALLED)
    r.update(FREE, DARK_BACK, DRIVING)


def test_t_lost_after_more_than_tt_immovable_collisions_and_regained_by_pushing():
    r = recognizer(tt=3, stall_cycles=2, push_cycles=4)
    for k in range(4):
        assert r.t, k
        stall_against_a_wall(r, 2)
    assert not r.t and r.situation == "S4"
    for _ in range(3):
        r.update(readings(r2=0.002, r3=0.002), DARK_BACK, DRIVING)
    assert not r.t
    r.update(readings(r2=0.002, r3=0.002), DARK_BACK, DRIVING)
    assert r.t and r.immovable_collisions == 0 and r.situation == "S1"


def test_default_tt_is_the_papers_ten_collisions():
    """Section 4: Tt = 10. T survives ten immovable collisions and is lost at the eleventh."""
    r = recognizer()
    assert r.params.tt == 10
    for k in range(11):
        assert r.t, k
        stall_against_a_wall(r, r.params.stall_cycles)
    assert not r.t


def test_pushing_a_recognized_robot_is_no_evidence_of_a_light_box():
    r = recognizer(tt=0, stall_cycles=1, push_cycles=2)
    stall_against_a_wall(r, 1)
    assert not r.t
    r.update(readings(r2=0.03), DARK_BACK, STILL)
    r.update(readings(r2=0.002, r3=0.01), DARK_BACK, STILL)  # a robot moved in ahead
    assert "forward-robot" in r.facts
    for _ in range(5):
        r.update(readings(r2=0.002, r3=0.002), DARK_BACK, DRIVING)
    assert not r.t


def test_looks_last_one_to_look_cycles_steps():
    params = RecognizerParams(ray_angles=tuple(KHEPERA_RING.tolist()), look_cycles=4)
    lengths = set()
    for seed in range(20):
        r = SituationRecognizer(params, np.random.default_rng(seed))
        r.update(FREE, DARK_BACK, DRIVING)
        r.update(readings(r2=0.08), DARK_BACK, DRIVING)  # something comes into range ahead
        n = 0
        while r.looking:
            n += 1
            r.update(readings(r2=0.08), DARK_BACK, STILL)
        lengths.add(n)
    assert lengths == {1, 2, 3, 4}


# -- policy ------------------------------------------------------------------------------------


def test_policy_needs_the_primitive_action_set():
    with pytest.raises(TypeError, match="primitives"):
        make_policy("sbs", teamgym.make("BoxPushing-v0", action_type="wheels"))
    env = teamgym.make("BoxPushing-v0")
    with pytest.raises(TypeError, match="unknown recognizer parameter"):
        make_policy("sbs", env, tx=3)
    with pytest.raises(ValueError, match="fixed_sbs"):
        make_policy("sbs", env, fixed_sbs=7)
    assert make_policy("sbs", env, tm=30.0, tt=7).params.tt == 7


def play(policy_name, seed, steps, **config):
    env = teamgym.make("BoxPushing-v0", **config)
    policy = make_policy(policy_name, env)
    observations, infos = env.reset(seed=seed)
    policy.reset(seed)
    actions_seen = []
    for _ in range(steps):
        if not env.agents:
            break
        actions = policy.act({a: observations[a] for a in env.agents}, infos)
        actions_seen.append(actions)
        observations, _, _, _, infos = env.step(actions)
    return env, policy, actions_seen


def test_policy_is_repeatable_and_sbs1_uses_sbs1_only():
    _, first, a = play("sbs", 3, 300, situation="S3")
    _, _, b = play("sbs", 3, 300, situation="S3")
    assert a == b
    assert set(first.activations) - set(range(20)) == set()
    _, ablation, _ = play("sbs1", 3, 300, situation="S3")
    assert set(ablation.activations) <= {0, 1, 2, 3, 4, 5}


def test_one_robot_pushes_a_light_box_to_the_lamp():
    env, policy, _ = play("sbs", 0, 3000, situation="S1")
    assert env.episode_success()
    assert policy.activations[4] + policy.activations[3] + policy.activations[5] > 0


def test_heavy_box_added_to_s2_switches_both_robots_to_s3():
    """Section 4.2: once both robots recognize S2, a heavy box is added; each recognizer then reaches S3."""
    env = teamgym.make("BoxPushing-v0", n_robots=2, n_light_boxes=2, n_spare_boxes=1, boxes_to_goal=3)
    policy = make_policy("sbs", env, tt=5)  # fewer immovable collisions than the default 10: a short test
    observations, infos = env.reset(seed=5)
    policy.reset(seed=5)
    added = None
    for _ in range(2000):
        observations, _, _, _, infos = env.step(policy.act({a: observations[a] for a in env.agents}, infos))
        if added is None and set(policy.situations().values()) == {"S2"}:
            added = policy.recognizers["robot_0"].time
            env.add_box(heavy=True)
        if added is not None and set(policy.situations().values()) == {"S3"}:
            break
    assert added is not None
    for recognizer in policy.recognizers.values():
        after = [t for t in recognizer.transitions if t.time > added]
        assert after and after[-1].after == "S3" and all(t.before in ("S2", "S3") for t in after)


def test_removing_a_robot_changes_the_survivors_situation():
    env = teamgym.make("BoxPushing-v0", n_robots=2, n_light_boxes=1, n_heavy_boxes=1, boxes_to_goal=2)
    policy = make_policy("sbs", env, tm=10.0)
    observations, infos = env.reset(seed=0)
    policy.reset(seed=0)
    removed = None
    for _ in range(600):
        observations, _, _, _, infos = env.step(policy.act({a: observations[a] for a in env.agents}, infos))
        survivor = policy.recognizers["robot_0"]
        if removed is None and survivor.m:
            removed = survivor.time
            env.remove_robot("robot_1")
        if removed is not None and not survivor.m:
            break
    assert removed is not None and not survivor.m
    lapse = survivor.transitions[-1]
    assert lapse.before in ("S2", "S3") and lapse.after in ("S1", "S4")
    assert lapse.time - survivor.last_m_time > 10.0 and lapse.time > removed


def test_a_line_of_two_robots_pushes_the_heavy_box_towards_the_lamp():
    """The physics premise of S3 under the sbs rules: a robot that pushes a stalled robot ahead of it
    (it sees an object, not a recognized robot: the one ahead never moved while it looked) adds its
    motor force; the line moves the heavy box that neither robot moves alone (docs/box_pushing.md)."""
    env = teamgym.make("BoxPushing-v0", n_robots=2, n_light_boxes=0, n_heavy_boxes=1, max_cycles=400)
    observations, infos = env.reset(seed=0)
    box = env.world[env.box_names()[0]]
    box.body.position = box.control.position = (0.5, 0.45)
    box.body.angle = box.control.angle = 0.0
    env.world.space.reindex_shapes_for_body(box.body)
    radius = env.spec_robot.radius
    for k, agent in enumerate(env.agents):  # in a line behind the box, facing the lamp
        env.robots[agent].teleport((0.5 - 0.08 - radius - 0.004 - k * (2 * radius + 0.012), 0.45), 0.0)
    env.world.read_states()
    env._read_sensors(env.agents)
    observations = env._collect_observations()
    policy = make_policy("sbs", env)
    policy.reset(seed=0)
    start = box.position[0]
    for _ in range(300):
        if not env.agents:
            break
        observations, _, _, _, infos = env.step(policy.act({a: observations[a] for a in env.agents}, infos))
    assert box.position[0] - start > 0.3
    assert policy.activations[4] + policy.activations[15] > 100  # pushing, not leaving (B-2)
