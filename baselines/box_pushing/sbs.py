"""Adaptive action selection by situated behaviour sets, paper 004 (``--policy sbs`` / ``sbs1``).

Every robot runs its own :class:`~baselines.box_pushing.recognizer.SituationRecognizer` on its own
sensor readings (no communication) and, every 100 ms action cycle, fires one behaviour of
the set for its situation: SBS-1 in S1, SBS-2 in S2, SBS-3 in S3, SBS-4 (wandering with
SBS-1) in S4 (sections 2.3 and 3). While a multi-cycle primitive runs the robot keeps
sensing but does not select. When no behaviour applies the robot turns away with
direction-change: B-1 (go-ahead) explicitly excludes objects ahead or at the sides, and
the paper gives no rule for, e.g., an object only at a side or an object ahead with the
light behind (in SBS-1); direction-change is its one avoiding action. ``sbs1`` is the ablation that uses SBS-1 in every
situation (the paper's motivation for SBS-2: harmful interactions, section 3.3).
``sbs-literal`` is ``sbs`` with ``reading="literal"``: footnote 1 counting every literal,
B-17–B-19 as printed and X-robot only within the 20 mm of X-object
(:data:`~baselines.box_pushing.behaviours.READINGS`; ``docs/box_pushing.md``, reading 11).

Statistics for the experiments: ``activations`` (how often each behaviour fired, by
number; 0 counts cycles in which none applied), ``situation_steps`` (robot-steps spent in
each recognized situation) and ``recognizers[agent].transitions``.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import fields, replace
from typing import Any

from baselines.box_pushing.behaviours import primitive_for, select
from baselines.box_pushing.behaviours import reading as rule_reading
from baselines.box_pushing.oracle import TrueRobotBearings
from baselines.box_pushing.recognizer import RecognizerParams, SituationRecognizer
from baselines.policy import Policy
from teamgym.control.primitives import Primitive
from teamgym.envs.box_pushing.actions import PrimitiveAction


class SituatedBehaviourSets(Policy):
    """Situated behaviour sets SBS-1..SBS-4 with a per-robot situation recognizer.

    Parameters
    ----------
    env:
        A ``BoxPushing-v0`` or ``-v1`` env with ``action_type="primitives"``.
    fixed_sbs:
        Use this SBS whatever the situation (``1`` for the ``sbs1`` ablation); ``None`` adapts.
    recognition:
        ``"sensors"`` (the paper's M check) or ``"oracle"`` (diagnostic: robots recognized from
        the simulator's state, :mod:`baselines.box_pushing.oracle`; the ``sbs-oracle`` policy).
    **recognizer:
        Overrides of :class:`~baselines.box_pushing.recognizer.RecognizerParams` (e.g. ``tm=60.0``, ``tt=10``).
        ``look_cycles=0`` never stops to look (no M check while standing still): in S1, with
        no other robot to notice, it only drops the 1-3-cycle stops, and it is the teacher of
        the ``boxpushing-s1-ppo`` clone (a memoryless clone cannot tell a look's ``stop`` from
        the readings; ``docs/training.md``).
    reading:
        The rule table's reading: ``"shipped"`` (positive conditions counted, B-17–B-19 with
        ``forward-object``, robot marks to sensor range) or ``"literal"`` (every literal counted,
        B-17–B-19 as printed, ``robot_facts="touching"``; the ``sbs-literal`` policy). An explicit
        ``robot_facts`` override wins over the reading's.
    """

    name = "sbs"
    env_ids = ("BoxPushing-v0", "BoxPushing-v1")
    observation_fields = ("proximity", "light", "encoders", "busy")
    required_config = {"action_type": "primitives"}

    def __init__(
        self, env, fixed_sbs: int | None = None, recognition: str = "sensors", reading: str = "shipped", **recognizer: Any
    ) -> None:
        super().__init__(env)
        if not isinstance(getattr(env, "action_type", None), PrimitiveAction):
            raise TypeError(f"{type(self).__name__} needs BoxPushing-v0 or -v1 with action_type='primitives'")
        if fixed_sbs not in (None, 1, 2, 3, 4):
            raise ValueError(f"fixed_sbs must be None or 1..4, got {fixed_sbs!r}")
        if recognition not in ("sensors", "oracle"):
            raise ValueError(f"recognition must be 'sensors' or 'oracle', got {recognition!r}")
        self.rules = rule_reading(reading)
        known = {f.name for f in fields(RecognizerParams)}
        unknown = sorted(set(recognizer) - known)
        if unknown:
            raise TypeError(f"unknown recognizer parameter(s) {unknown}; known: {sorted(known)}")
        c = env.config
        # A change counts only beyond the readings' noise: 3 standard deviations of the
        # difference of two noisy readings (√2 σ), additive and relative (BoxPushing-v1).
        spread = 3 * math.sqrt(2)
        base = RecognizerParams(
            dt=c.dt,
            change_threshold=RecognizerParams.change_threshold + spread * c.noise_level("sensor_noise"),
            change_relative=spread * c.noise_level("sensor_noise_relative"),
            object_threshold=env.object_threshold,
            sensor_range=c.sensor_range,
            wheel_radius=env.spec_robot.wheel_radius,
            wheel_base=env.spec_robot.wheel_base,
            ray_angles=tuple(env.ring.angles.tolist()),
            robot_facts=self.rules.robot_facts,
        )
        self.params = replace(base, **recognizer)
        self.fixed_sbs = fixed_sbs
        self.oracle = (
            TrueRobotBearings(c.sensor_range, self.params.change_threshold, self.params.mark_patience)
            if recognition == "oracle"
            else None
        )
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.recognizers: dict[str, SituationRecognizer] = {}
        self.activations: Counter[int] = Counter()
        self.situation_steps: Counter[str] = Counter()
        self.last_behaviour: dict[str, int] = {}
        self.looks = 0
        if self.oracle is not None:
            self.oracle.reset()

    def act(self, observations, infos=None):
        actions = {}
        decode = self.env.decode
        true_robots = self.oracle.update(self.env) if self.oracle is not None else {}
        for agent, obs in observations.items():
            recognizer = self.recognizers.get(agent)
            if recognizer is None:
                recognizer = self.recognizers[agent] = SituationRecognizer(self.params, self.np_random)
            fields_ = decode(obs)
            facts = recognizer.update(fields_["proximity"], fields_["light"], fields_["encoders"], true_robots.get(agent))
            situation = recognizer.situation
            self.situation_steps[situation] += 1
            if fields_["busy"][0] > 0.5:
                actions[agent] = int(Primitive.STOP)  # ignored by the env while busy
                continue
            if recognizer.looking:
                actions[agent] = int(Primitive.STOP)
                self.looks += 1
                continue
            behaviour = select(self.fixed_sbs or int(situation[1]), facts, self.rules)
            number = behaviour.number if behaviour is not None else 0
            self.activations[number] += 1
            self.last_behaviour[agent] = number
            actions[agent] = int(primitive_for(behaviour, facts) if behaviour is not None else Primitive.DIRECTION_CHANGE)
        return actions

    def situations(self) -> dict[str, str]:
        """The situation each robot currently recognizes."""
        return {agent: r.situation for agent, r in self.recognizers.items()}
