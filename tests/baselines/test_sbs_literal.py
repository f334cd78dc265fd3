"""``sbs-literal``: paper 004's footnote 1, B-17–B-19 and X-robot read literally, beside the shipped ``sbs``."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import teamgym
from baselines.box_pushing.behaviours import BEHAVIOURS, BEHAVIOURS_AS_PRINTED, READINGS, SBS, reading, select
from baselines.box_pushing.recognizer import RecognizerParams, SituationRecognizer
from baselines.registry import make_policy
from teamgym.sim.sensors import KHEPERA_RING

SHIPPED, LITERAL = READINGS["shipped"], READINGS["literal"]
FREE = np.full(8, 0.1)
LAMP_AHEAD = np.array([0.2, 0.5, 1.0, 1.0, 0.5, 0.2, 0.0, 0.0])
STILL = np.zeros(4)


def test_b17_to_b19_are_as_printed_and_b10_is_flagged():
    assert BEHAVIOURS_AS_PRINTED[17].all_of == ("forward-robot", "back-robot-leaving")
    assert BEHAVIOURS_AS_PRINTED[18].all_of == ("forward-robot", "¬forward-light")
    assert BEHAVIOURS_AS_PRINTED[19].all_of == ("forward-robot", "forward-light")
    assert all("forward-object" in BEHAVIOURS[n].all_of for n in (17, 18, 19))  # the shipped reading 6
    assert {n for n in BEHAVIOURS if BEHAVIOURS[n] != BEHAVIOURS_AS_PRINTED[n]} == {17, 18, 19}
    # "B-10 If left-robot∨right-robot ∨ then following": a third disjunct is lost in the text.
    assert BEHAVIOURS[10].lost == BEHAVIOURS_AS_PRINTED[10].lost == 1
    assert {n for n, b in BEHAVIOURS.items() if b.lost} == {10}
    assert BEHAVIOURS[1].conditions == 3 and BEHAVIOURS[1].specificity == 0
    assert BEHAVIOURS[10].conditions == 2 and BEHAVIOURS[10].specificity == 1


@pytest.mark.parametrize(
    ("sbs", "facts", "shipped", "literal"),
    [
        # Footnote 1 literally: B-1's three negations are three conditions, more than B-11's two.
        (3, {"back-robot"}, 11, 1),
        (3, {"forward-robot-leaving"}, 13, 1),
        (3, {"back-robot-leaving"}, 12, 1),
        # B-19 as printed has two conditions: it ties with B-4 and loses to the younger number.
        (3, {"forward-robot", "forward-object", "forward-light"}, 19, 4),
        (3, {"forward-robot", "forward-object", "no-light", "back-robot-leaving"}, 17, 16),
        # Where the readings agree.
        (3, {"forward-robot", "forward-object", "back-light"}, 18, 18),
        (3, {"forward-object", "back-robot", "forward-light"}, 15, 15),
        (3, {"left-robot", "left-object"}, 10, 10),
        (3, {"forward-robot", "forward-object"}, 18, 18),
        (3, {"forward-robot"}, 14, 1),  # only with robot_facts="marks": "touching" implies forward-object
        (2, {"forward-light", "forward-object", "left-object"}, 8, 8),
        (1, {"forward-object", "forward-light", "no-rotation"}, 2, 2),
        (1, set(), 1, 1),
    ],
)
def test_each_reading_picks_by_its_count(sbs, facts, shipped, literal):
    facts = frozenset(facts)
    assert select(sbs, facts).number == select(sbs, facts, SHIPPED).number == shipped
    assert select(sbs, facts, LITERAL).number == literal


FACTS = [
    "forward-object",
    "left-object",
    "right-object",
    "back-object",
    "forward-light",
    "left-light",
    "right-light",
    "back-light",
    "no-light",
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
def test_literal_selection_takes_the_most_literals_then_the_younger_number(sbs, facts):
    facts = frozenset(facts)
    chosen = select(sbs, facts, LITERAL)
    applicable = [b for n, b in BEHAVIOURS_AS_PRINTED.items() if n in SBS[sbs] and b.applies(facts)]
    if chosen is None:
        assert applicable == []
        return
    assert chosen in applicable
    best = max(len(b.all_of) + len(b.any_of) for b in applicable)
    assert chosen.number == min(b.number for b in applicable if len(b.all_of) + len(b.any_of) == best)


def recognizer(robot_facts):
    params = RecognizerParams(ray_angles=tuple(KHEPERA_RING.tolist()), look_cycles=0, leaving_time=0.25, robot_facts=robot_facts)
    return SituationRecognizer(params)


def forward(distance):
    out = FREE.copy()
    out[2] = distance
    return out


def test_x_robot_holds_only_where_the_20mm_x_object_holds():
    marks, touching = recognizer("marks"), recognizer("touching")
    for r in (marks, touching):
        r.update(forward(0.07), LAMP_AHEAD, STILL)
    # A robot moving 5 cm ahead, seen by the M check: a mark in both, X-robot only with marks.
    far = [r.update(forward(0.05), LAMP_AHEAD, STILL) for r in (marks, touching)]
    assert marks.m and touching.m and len(marks.marks) == len(touching.marks) == 1
    assert "forward-robot" in far[0] and "forward-robot" not in far[1] and "forward-object" not in far[1]
    assert "forward-robot-leaving" not in far[1]  # never sensed within 20 mm: it cannot leave
    # It comes within 20 mm: forward-robot in both.
    near = [r.update(forward(0.015), LAMP_AHEAD, STILL) for r in (marks, touching)]
    assert all({"forward-robot", "forward-object"} <= f for f in near)
    # It backs off to 3 cm: still marked, but touching reads it as leaving for leaving_time.
    after = [[r.update(forward(0.03), LAMP_AHEAD, STILL) for _ in range(4)] for r in (marks, touching)]
    assert all("forward-robot" in f and "forward-robot-leaving" not in f for f in after[0])
    assert [("forward-robot" in f, "forward-robot-leaving" in f) for f in after[1]] == [(False, True)] * 3 + [(False, False)]


def test_policy_readings_and_bad_values():
    env = teamgym.make("BoxPushing-v0", situation="S3")
    shipped, literal = make_policy("sbs", env), make_policy("sbs-literal", env)
    assert shipped.rules is SHIPPED and shipped.params.robot_facts == "marks"
    assert literal.rules is LITERAL and literal.params.robot_facts == "touching"
    ablation = make_policy("sbs", env, reading="literal", robot_facts="marks")  # counting only
    assert ablation.rules is LITERAL and ablation.params.robot_facts == "marks"
    with pytest.raises(ValueError, match="reading must be one of"):
        make_policy("sbs", env, reading="verbatim")
    with pytest.raises(ValueError, match="robot_facts must be"):
        make_policy("sbs", env, robot_facts="near")
    assert reading("literal") is LITERAL
    # The diagnostic literal-count: the literal count with the shipped B-19 (three conditions) beats B-4.
    ahead = frozenset({"forward-robot", "forward-object", "forward-light"})
    assert select(3, ahead, reading("literal-count")).number == 19 and select(3, ahead, LITERAL).number == 4


def test_literal_reading_leaves_b14_b17_b19_unreachable_in_sbs3():
    """With X-robot ⇒ X-object, B-14 loses to B-18/B-19, B-17 to B-3–B-5/B-16 and B-19 to B-4."""
    groups = ("forward", "left", "right", "back")
    bits = [f"{g}-object" for g in groups] + ["no-rotation", "forward-robot-leaving", "back-robot-leaving"]
    bits += [f"{g}-robot" for g in groups]
    lights = [f"{g}-light" for g in groups] + ["no-light"]
    fired = {"shipped": set(), "literal": set()}
    for mask in range(1 << len(bits)):
        facts = {b for i, b in enumerate(bits) if mask >> i & 1}
        touching = all(f"{g}-object" in facts for g in groups if f"{g}-robot" in facts)
        for light in lights:
            for name in ("shipped", "literal") if touching else ("shipped",):
                chosen = select(3, frozenset(facts | {light}), READINGS[name])
                fired[name].add(chosen.number if chosen else 0)
    assert fired["shipped"] == {0, *SBS[3]}
    assert fired["literal"] == {0, *SBS[3]} - {14, 17, 19}


def test_literal_reading_changes_an_sbs3_rollout_and_is_repeatable():
    def run(name):
        env = teamgym.make("BoxPushing-v0", situation="S3")
        policy = make_policy(name, env, fixed_sbs=3)
        observations, infos = env.reset(seed=0)
        policy.reset(0)
        seen = []
        for _ in range(300):
            actions = policy.act({a: observations[a] for a in env.agents}, infos)
            seen.append(actions)
            observations, _, _, _, infos = env.step(actions)
        return seen, policy.activations

    literal, fired = run("sbs-literal")
    assert run("sbs-literal")[0] == literal
    shipped, shipped_fired = run("sbs")
    assert shipped != literal
    assert shipped_fired[14] > 0 and fired[14] == 0
