"""Paper 003's coordination protocol (section 3) on Rendezvous-v0, with a choice of planner.

Two agents, ``robot_0`` (Agent 1, which assembles the whole path) and ``robot_1`` (Agent 2),
each with its own beliefs (section 5: *AgentPath*, *OtherAgentPath*, *Environment*): its place
P_i, the partner's place P_j and next place P_{j+1}, the current whole path and the ways known
to be blocked. They coordinate only by the messages of :mod:`teamgym.envs.rendezvous.messages`,
sent through the env's channel. Each env step an agent that stands at a place:

1. reads its inbox (Steps 1–3, 7): BLOCKED updates the map; NEXT/PRESENT update P_{j+1}/P_j;
   REPLAN updates both and starts a re-planning phase; PATH (Agent 2) adopts the whole path;
2. detects the blocked ways of its place (Step 5) and reports each new one (BLOCKED);
3. while re-planning (Phases 1–2): Agent 2 sends PRESENT(P_i) and waits for a PATH; Agent 1,
   once it knows P_j, plans from P_i to P_j with the known blocked ways and sends the PATH;
4. while executing (Phases 3–4): if P_i = P_j it waits (Step 4: met); it takes the next place
   P_{i+1} on the path toward the partner; if that way is blocked it sends REPLAN(P_i, way)
   (Step 6); otherwise it goes and sends NEXT (Step 8) — if P_{i+1} = P_{j+1} the robots
   approach each other there, and the env stops them ``meet_distance`` apart. It waits where
   the partner is coming to its place. NEXT is ``(P_{i+1}, path checksum, P_i)``: the next and
   present positions of section 5 plus the plan it follows.

Timing of Phase 3 (``execution``). The paper's messages are instantaneous next to the robots'
motion: both agents come back to Phase 3 together once Agent 1 sends the whole path
(section 5), and a re-planning request ends the partner's execution "when the corresponding
robot reaches the next position" (section 5, *Re_Planning*; Step 3: "stop the controlled robot
at the end of the current way", Step 7 at a place). Here a message takes one env step, so:

* ``"paper"`` (default): Agent 1 launches a new plan one step after sending its PATH, when
  Agent 2 receives it, so the robots set off together and neither runs on while the PATH
  travels. In lockstep (``stage_end="all"``, every robot moves one way per step) an agent also
  stands one step at each place it reaches before going on (Step 5: it "waits for the robot's
  answer" to the check): a REPLAN the partner sent on reaching its own place meanwhile stops it
  at this place (Step 7), and one that arrives while it is on a way stops it at the next place
  (Step 3); the new plan starts there. With ``stage_end="any"`` a standing step lasts until the
  partner's next arrival, so that wait is not made (a request reaching a robot on a way still
  stops it at the next place). On Figs. 5–7 the fourth plan starts at place 7 as in the paper.
* ``"eager"`` (the behaviour before 2026-12-02; policy ``bidir-astar-eager``): Agent 1 moves in the step it sends a
  PATH and an agent moves on in the step it reaches a place, so on Figs. 5–7 the red robot
  runs two places on (to 18) while the PATH and then the REPLAN travel.

The planner (``planner``): ``bidir-astar`` is the paper's distributed bidirectional A*
(section 4, not always optimal), ``bidir-astar-opt`` its optimal variant, ``astar`` one-sided
A*, ``centralized`` networkx's shortest path. Agent 1 runs the search for both agents; the
search's own per-iteration messages (Agent 2's current paths) are counted in the planner's
result, not sent through the channel (a search finishes within one control step).

An agent that finds itself or its partner off the current path (a new plan crossed a move
still under way, which the paper's synchronous description does not meet) goes back to
Phase 1; Agent 1 plans to the place the partner is heading for, and a PRESENT from the
partner (sent only in Phase 1) makes it plan again unless the partner stands where the current
plan ends.

Lossy channels (not in the paper, which assumes delivery): an agent repeats the message it
waits on every step — PRESENT until a PATH arrives, PATH until Agent 2 answers with a NEXT
carrying that path's checksum; a standing agent repeats NEXT with its own place — so a lost
message delays, never deadlocks. The env counts a repeated PATH once.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from baselines.policy import Policy
from baselines.rendezvous.search import PLANNERS
from teamgym.envs.base import TeamEnv
from teamgym.envs.rendezvous.messages import Kind, Record, decode, encode

EXECUTIONS = ("paper", "eager")
"""Timings of Phase 3 (``RendezvousProtocol(execution=...)``); see the module docstring."""


def check_message_len(env: TeamEnv) -> None:
    """A whole path over every place, with the other records of a step, must fit one message."""
    needed = len(env.place_index) + 32
    if env.config.message_len < needed:
        raise ValueError(
            f"message_len={env.config.message_len} is too short for whole paths on map {env.config.map!r} "
            f"({len(env.place_index)} places); set message_len >= {needed}"
        )


def checksum(path: list[int]) -> int:
    """A 24-bit fingerprint of a path, by which Agent 2 confirms the plan it executes.

    Below 2²⁴ so that it survives the float32 values of flat observations exactly.
    """
    value = 17
    for place in path:
        value = (value * 1_000_003 + place + 1) % 16_777_213
    return value


@dataclass
class AgentBeliefs:
    """One agent's knowledge (section 5's belief sets)."""

    place: int = -1
    partner_place: int = -1
    partner_next: int = -1
    path: list[int] = field(default_factory=list)  # whole path, robot_0's place first
    plan: int = 0  # number of the plan in ``path`` (0: none yet)
    blocked: set[frozenset[int]] = field(default_factory=set)
    replanning: bool = True  # Phase 1 at the start
    acknowledged: int = -1  # Agent 1: the checksum of the last path Agent 2 confirmed
    awaiting_present: bool = False  # Agent 1 asked for a re-plan: plan only from the partner's PRESENT
    launching: bool = False  # Agent 1 sent a new PATH this step: its Phase 3 starts next step, with Agent 2's
    checked: int = -1  # the place the robot has stood at since an earlier decision (Step 5 answered), -1 after a move


class RendezvousProtocol(Policy):
    """Section 3's protocol for two robots; see the module docstring."""

    name = "bidir-astar"
    env_ids: ClassVar[tuple[str, ...]] = ("Rendezvous-v0",)
    observation_fields: ClassVar[tuple[str, ...]] = ("place", "target", "neighbours", "blocked", "messages", "message_mask")
    required_config: ClassVar[dict[str, Any]] = {"action_type": "next_place", "protocol_messages": True}

    def __init__(self, env: TeamEnv, planner: str = "bidir-astar", execution: str = "paper") -> None:
        super().__init__(env)
        if planner not in PLANNERS:
            raise ValueError(f"unknown planner {planner!r}; choose one of {sorted(PLANNERS)}")
        if execution not in EXECUTIONS:
            raise ValueError(f"unknown execution {execution!r}; choose one of {list(EXECUTIONS)}")
        if env.config.n_robots != 2 or env.config.action_type != "next_place" or not env.config.protocol_messages:
            raise ValueError("the protocol of paper 003 needs n_robots=2, action_type='next_place' and protocol_messages=True")
        check_message_len(env)
        self.planner = PLANNERS[planner]
        self.execution = execution
        #: Agent 1 starts a new plan when Agent 2 receives it (``"paper"``), not while the PATH travels.
        self.launch_together = execution == "paper"
        #: In lockstep (``stage_end="all"``) a robot stands one step at each place it reaches (Step 5's check).
        self.check_step = execution == "paper" and env.config.stage_end == "all"
        self.graph = env.graph
        self.wait = env.max_degree
        self.length = env.config.message_len
        self.beliefs: dict[str, AgentBeliefs] = {}

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.beliefs = {a: AgentBeliefs() for a in self.env.possible_agents}

    def act(self, observations: dict[str, np.ndarray], infos: dict[str, dict[str, Any]] | None = None) -> dict[str, Any]:
        actions = {}
        for agent, observation in observations.items():
            fields = self.env.decode(observation)
            move, records = self._decide(agent, fields)
            actions[agent] = {"move": move, "message": encode(records, self.length)}
        return actions

    # -- one agent ------------------------------------------------------------------------
    def _decide(self, agent: str, fields: dict[str, np.ndarray]) -> tuple[int, list[Record]]:
        me = self.beliefs[agent]
        first = agent == self.env.possible_agents[0]
        records: list[Record] = []
        self._read_inbox(me, fields, first)
        me.place = int(fields["place"][0])
        if int(fields["target"][0]) >= 0:  # on a way: finish it (the env ignores the choice)
            return self.wait, records
        records += self._detect(me, fields)
        if me.replanning:
            records += self._replan(me, first)
        if me.replanning or me.launching:  # Phases 1-2, or Agent 1's PATH still on its way to Agent 2
            me.launching, me.checked = False, me.place
            return self.wait, records
        move, more = self._execute(me, fields)
        me.checked = me.place if move == self.wait else -1
        if first and not me.replanning and me.acknowledged != checksum(me.path):
            more.append((Kind.PATH, (0, *me.path)))  # repeated until Agent 2 confirms it (the env counts it once)
        return move, records + more

    def _read_inbox(self, me: AgentBeliefs, fields: dict[str, np.ndarray], first: bool) -> None:
        for row, valid in zip(fields["messages"], fields["message_mask"]):
            if not valid:
                continue
            for kind, args in decode(row):
                if kind == Kind.BLOCKED and len(args) == 2:
                    me.blocked.add(frozenset(args))
                elif kind == Kind.PRESENT and args:
                    me.partner_place = me.partner_next = args[0]
                    me.awaiting_present = False
                    # The partner is in Phase 1: plan again, unless it stands where the plan ends
                    # (its PRESENT crossed the PATH in the channel).
                    me.replanning = me.replanning or (first and (not me.path or args[0] != me.path[-1]))
                elif kind == Kind.NEXT and len(args) == 3:
                    me.partner_next, me.partner_place = args[0], args[2]
                    me.acknowledged = args[1]
                elif kind == Kind.REPLAN and len(args) == 3:
                    me.partner_place, me.partner_next = args[0], -1
                    me.blocked.add(frozenset(args[1:]))
                    me.replanning = True
                elif kind == Kind.PATH and not first and len(args) >= 2:
                    path = list(args[1:])
                    if path != me.path or me.replanning:
                        me.path, me.plan, me.replanning = path, me.plan + 1, False
                        me.partner_place, me.partner_next = path[0], -1

    def _detect(self, me: AgentBeliefs, fields: dict[str, np.ndarray]) -> list[Record]:
        """Step 5: the blocked ways of the place; new ones are reported to the partner."""
        records: list[Record] = []
        for q, blocked in zip(fields["neighbours"].astype(int).tolist(), fields["blocked"].tolist()):
            way = frozenset((me.place, q))
            if q >= 0 and blocked and way not in me.blocked:
                me.blocked.add(way)
                records.append((Kind.BLOCKED, (me.place, q)))
        return records

    def _replan(self, me: AgentBeliefs, first: bool) -> list[Record]:
        """Phases 1–2: Agent 2 reports its place; Agent 1 plans once it knows both places."""
        if not first:
            return [(Kind.PRESENT, (me.place,))]
        if me.partner_place < 0 or me.awaiting_present:
            return [(Kind.PRESENT, (me.place,))]
        goal = me.partner_next if me.partner_next >= 0 else me.partner_place  # where the partner will stand
        result = self.planner(self.graph, me.place, goal, me.blocked)
        if not result.found:
            return [(Kind.PRESENT, (me.place,))]  # wait for news (a way may reopen only in another episode)
        me.path, me.plan, me.replanning = list(result.path), me.plan + 1, False
        me.launching = self.launch_together
        return [(Kind.PATH, (int(result.expansions or 0), *me.path))]

    def _execute(self, me: AgentBeliefs, fields: dict[str, np.ndarray]) -> tuple[int, list[Record]]:
        """Phases 3–4 (Steps 4–8): the next place toward the partner along the path."""
        path = me.path if me is self.beliefs[self.env.possible_agents[0]] else me.path[::-1]
        here = [(Kind.NEXT, (me.place, checksum(me.path), me.place))]  # standing: repeated each step
        partner = me.partner_next if me.partner_next >= 0 else me.partner_place
        if me.place not in path or (partner >= 0 and partner not in path):
            # Off the plan (a plan crossed a move in the channel): back to Phase 1.
            me.replanning = True
            return self.wait, self._replan(me, me is self.beliefs[self.env.possible_agents[0]])
        if me.place == me.partner_place:
            return self.wait, here  # Step 4: met
        k = path.index(me.place)
        if k + 1 >= len(path) or path[k + 1] == me.partner_place and me.partner_next == me.place:
            return self.wait, here  # the partner is coming here
        nxt = path[k + 1]
        if frozenset((me.place, nxt)) in me.blocked:  # Step 6
            me.replanning = True
            me.awaiting_present = me is self.beliefs[self.env.possible_agents[0]]  # Step 3: the partner stops first
            return self.wait, [(Kind.REPLAN, (me.place, me.place, nxt))]
        if self.check_step and me.checked != me.place:
            return self.wait, here  # Step 5: the check's answer; a partner's REPLAN sent meanwhile stops it here
        neighbours = fields["neighbours"].astype(int).tolist()
        return neighbours.index(nxt), [(Kind.NEXT, (nxt, checksum(me.path), me.place))]
