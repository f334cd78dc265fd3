"""Behaviours B-1..B-19 and the situated behaviour sets SBS-1..SBS-4 of paper 004 (section 3).

A behaviour is "if a state then an action": a conjunction of sensed states (negated with
``¬``; B-10's disjunction is written as its own ``any`` clause) and a primitive action. When
several behaviours of the active set apply, footnote 1 decides: (1) the more specific
behaviour, the one with more conditions, then (2) the one with the younger (smaller) number.

Two readings of the rules (:data:`READINGS`, ``docs/box_pushing.md``, readings 5, 6 and 11):

* ``"shipped"`` (``sbs``, the default): footnote 1 counts *positive* conditions only (a
  disjunction counts one), and B-17–B-19 carry an extra ``forward-object`` (:data:`BEHAVIOURS`).
* ``"literal"`` (``sbs-literal``): footnote 1 counts every printed literal, negations and each
  disjunct included, and B-17–B-19 are as printed (:data:`BEHAVIOURS_AS_PRINTED`); it goes with
  the recognizer's ``robot_facts="touching"`` (X-robot only where the 20 mm X-object holds).

B-10 is flagged in both (``Behaviour.lost``): its printed condition "left-robot ∨ right-robot ∨"
ends in a dangling ``∨``, a third disjunct lost in the text; both readings use the two printed ones.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from teamgym.control.primitives import Primitive


@dataclass(frozen=True)
class Behaviour:
    """Behaviour ``number``: if every literal of ``all_of`` holds (and one of ``any_of``, if given) then ``action``.

    ``lost`` counts literals of the printed rule that are lost in the text (B-10: 1); they are
    neither checked nor counted.
    """

    number: int
    all_of: tuple[str, ...]
    action: str
    any_of: tuple[str, ...] = ()
    lost: int = 0

    @property
    def specificity(self) -> int:
        """Number of stimuli the behaviour responds to: its positive conditions (a disjunction counts as one).

        Negated conditions (absences, as in B-1 "nothing ahead or at the sides") do not make a
        behaviour more specific; see docs/box_pushing.md for why.
        """
        return sum(not literal.startswith("¬") for literal in self.all_of) + (1 if self.any_of else 0)

    @property
    def conditions(self) -> int:
        """Number of printed literals: negations and each disjunct count (footnote 1 read literally)."""
        return len(self.all_of) + len(self.any_of)

    def applies(self, facts: frozenset[str]) -> bool:
        for literal in self.all_of:
            if literal.startswith("¬"):
                if literal[1:] in facts:
                    return False
            elif literal not in facts:
                return False
        return not self.any_of or any(literal in facts for literal in self.any_of)


B = Behaviour
#: B-1..B-19 of sections 3.2–3.4, the shipped reading: B-17–B-19 with ``forward-object`` added (reading 6).
BEHAVIOURS: dict[int, Behaviour] = {
    b.number: b
    for b in (
        B(1, ("¬forward-object", "¬left-object", "¬right-object"), "go-ahead"),
        B(2, ("forward-object", "no-rotation"), "direction-change"),
        B(3, ("forward-object", "left-light"), "push-clockwise"),
        B(4, ("forward-object", "forward-light"), "push-straight"),
        B(5, ("forward-object", "right-light"), "push-counterclockwise"),
        B(6, ("forward-object", "back-light"), "direction-change"),
        B(7, ("forward-object", "back-object"), "stop"),
        B(8, ("forward-light", "forward-object", "left-object"), "turn-right"),
        B(9, ("forward-light", "forward-object", "right-object"), "turn-left"),
        B(10, (), "following", ("left-robot", "right-robot"), lost=1),
        B(11, ("¬forward-robot", "back-robot"), "go-ahead"),
        B(12, ("¬forward-robot", "back-robot-leaving"), "stop"),
        B(13, ("forward-robot-leaving",), "following"),
        B(14, ("forward-robot",), "stop"),
        B(15, ("forward-object", "back-robot", "forward-light"), "push-straight"),
        B(16, ("forward-object", "back-robot-leaving"), "following"),
        B(17, ("forward-robot", "forward-object", "back-robot-leaving"), "following"),
        B(18, ("forward-robot", "forward-object", "¬forward-light"), "direction-change"),
        B(19, ("forward-robot", "forward-object", "forward-light"), "side&push"),
    )
}

#: B-1..B-19 exactly as printed: B-17–B-19 without the added ``forward-object``.
BEHAVIOURS_AS_PRINTED: dict[int, Behaviour] = BEHAVIOURS | {
    n: replace(BEHAVIOURS[n], all_of=tuple(x for x in BEHAVIOURS[n].all_of if x != "forward-object")) for n in (17, 18, 19)
}

#: The behaviour numbers of each situated behaviour set (sections 3.2–3.5).
SBS: dict[int, tuple[int, ...]] = {
    1: (1, 2, 3, 4, 5),
    2: tuple(range(1, 10)),
    3: (1, 2, 3, 4, 5, *range(10, 20)),
    4: (1, 2, 3, 4, 5),
}

ACTIONS: dict[str, Primitive] = {
    "direction-change": Primitive.DIRECTION_CHANGE,
    "push-clockwise": Primitive.PUSH_CLOCKWISE,
    "push-counterclockwise": Primitive.PUSH_COUNTERCLOCKWISE,
    "push-straight": Primitive.PUSH_STRAIGHT,
    "turn-left": Primitive.TURN_LEFT,
    "turn-right": Primitive.TURN_RIGHT,
    "go-ahead": Primitive.GO_AHEAD,
    "stop": Primitive.STOP,
    "side&push": Primitive.SIDE_AND_PUSH,
}
_FOLLOW = {
    "forward": Primitive.FOLLOW_FORWARD,
    "left": Primitive.FOLLOW_LEFT,
    "right": Primitive.FOLLOW_RIGHT,
    "back": Primitive.FOLLOW_BACK,
}


@dataclass(frozen=True)
class Reading:
    """A reading of the rule table: its behaviours and footnote 1's count of conditions."""

    name: str
    behaviours: dict[int, Behaviour]
    every_literal: bool  # footnote 1 counts every literal (else the positive conditions only)
    robot_facts: str  # the recognizer's ``RecognizerParams.robot_facts`` that goes with it

    def specificity(self, behaviour: Behaviour) -> int:
        """Footnote 1's count of ``behaviour``'s conditions under this reading."""
        return behaviour.conditions if self.every_literal else behaviour.specificity


READINGS: dict[str, Reading] = {
    "shipped": Reading("shipped", BEHAVIOURS, every_literal=False, robot_facts="marks"),
    "literal": Reading("literal", BEHAVIOURS_AS_PRINTED, every_literal=True, robot_facts="touching"),
    # Diagnostic (issue 26's probe): the literal count and X-robot, B-17–B-19 as shipped.
    "literal-count": Reading("literal-count", BEHAVIOURS, every_literal=True, robot_facts="touching"),
}


def reading(name: str) -> Reading:
    """The rule-table reading ``name`` (``"shipped"``, ``"literal"`` or the diagnostic ``"literal-count"``)."""
    if name not in READINGS:
        raise ValueError(f"reading must be one of {sorted(READINGS)}, got {name!r}")
    return READINGS[name]


def select(sbs: int, facts: frozenset[str], rules: Reading = READINGS["shipped"]) -> Behaviour | None:
    """The behaviour of SBS-``sbs`` that fires on ``facts`` under ``rules`` (footnote 1), or None if none applies."""
    best: Behaviour | None = None
    best_count = -1
    for number in SBS[sbs]:
        behaviour = rules.behaviours[number]
        if behaviour.applies(facts):
            count = rules.specificity(behaviour)
            if count > best_count:
                best, best_count = behaviour, count
    return best


def primitive_for(behaviour: Behaviour, facts: frozenset[str]) -> Primitive:
    """The primitive that executes ``behaviour``'s action.

    ``following`` moves towards the robot its condition names: B-10 the left (else right)
    robot, B-13 forward, B-16 and B-17 back (section 3.4: "the direction in which another
    robot was sensed or left").
    """
    if behaviour.action != "following":
        return ACTIONS[behaviour.action]
    literals = [x for x in (*behaviour.all_of, *behaviour.any_of) if x.endswith("-robot-leaving")]
    literals += [x for x in behaviour.any_of if x in facts]
    return _FOLLOW[literals[0].split("-", 1)[0]] if literals else Primitive.FOLLOW_FORWARD
