"""Rendezvous-v0: robots meet as soon as possible on a graph of places and ways (paper 003).

``n_robots`` Khepera-like robots (default 2) start at places of a graph map (default the
38-place map of the paper's Figs. 5–7, ``teamgym/maps/data/graphs``). In the world, map
coordinates are multiplied by ``scale`` (m per map unit); every way is a corridor
``corridor_width`` wide and every place a small clearing, walled unless
``corridor_walls=False``. Ways become blocked by an obstacle in their middle: from the start
(``blocked_ways``), at given times (``blockings``: ``(a, b, t)``) or at random
(``block_rate`` per second, only ways whose loss keeps the map connected). A robot detects
the blocked ways of the place it stands at (section 1); a robot already on a way finishes it
(the obstacle is put in place once the way is clear). A robot that cannot get through a way
within three times its travel time (plus 5 s) drives back and counts the way as blocked
(``failed_moves``). The team succeeds when every pair of
robots is within ``meet_distance`` (centres) and no two robots have collided; the episode
ends when they meet either way. A robot stops short of a robot ahead.

Robots talk only through the core channel (``comm_*`` keys): with ``protocol_messages`` every
action carries a message of integer records (:mod:`teamgym.envs.rendezvous.messages`: whole
path, re-planning request, present and next position, blocked way), so a lossy or delayed
channel can be studied. The env scores every whole path announced (PATH records): its cost
over networkx's shortest-path cost between its ends on the map as the team knows it at that
moment (the ways detected blocked so far): ``optimality`` (1.0 is optimal).

Observations (flat float32 or ``obs_format="dict"``), D = the map's largest degree:

=================  ===========  ===========================================================
field              shape        meaning
=================  ===========  ===========================================================
``pose``           (3,)         own x, y (m), heading θ (rad)
``place``          (1,)         index of the last place reached
``target``         (1,)         index of the place being driven to, −1 when standing
``progress``       (1,)         fraction of the current way done (0 when standing)
``neighbours``     (D,)         indices of the place's neighbours in map order, −1 padding
``blocked``        (D,)         1 where the robot has detected that way blocked
``proximity``      (8,)         Khepera ring distances (m)
``neighbour_xy``   (D, 2)       world offset (m) of each neighbour's place from the robot, 0
                                padding (``neighbour_offsets=True``, for learned policies)
``messages``       (N−1, L)     protocol messages received this step (``protocol_messages``)
``message_sender`` (N−1,)       sender index, −1 padding
``message_mask``   (N−1,)       1 for a message, 0 for padding
=================  ===========  ===========================================================

Actions (``action_type``): ``"next_place"`` (a macro action: one ``step`` lasts until some
moving robot reaches its next place; masks in ``infos[agent]["action_mask"]``) or
``"velocity"`` (v, ω). With ``stage_end="all"`` a step lasts until every moving robot has
arrived (the robots move one way per step together, as in the paper's simulation). With
``protocol_messages`` the action is ``{"move": ..., "message": ...}``
and ``infos[agent]["action_mask"]`` takes the form gymnasium's ``Dict.sample(mask=...)`` takes,
``{"move": mask, "message": None}`` (``env.action_mask(agent)`` gives the array).

Reward, shared per control step: ``progress_reward`` × (decrease of the mean distance between
robots, m) − ``time_penalty`` − ``collision_penalty`` per contact, + ``meet_bonus`` on meeting.
Metrics in ``infos``: ``meeting_time`` (s, once met), ``path_length`` (own, m), ``place``,
``collisions``, ``robot_collisions`` (between robots, the team's), ``blocked_known`` (ways this
robot detected blocked), ``plans`` and ``replans`` (whole paths announced, and those after the
first), ``stale_plans`` (paths through a way the team already knew blocked), ``expansions``
(nodes expanded, as the planners declare them), ``optimality`` (worst announced path so far)
and the channel's message and byte counts.
"""

from __future__ import annotations

import math
from typing import Any

import networkx as nx
import numpy as np
from gymnasium import spaces

from teamgym.control.poses import PoseRows
from teamgym.control.way_following import WayFollower
from teamgym.envs.actions import ActionType, VelocityAction
from teamgym.envs.base import EpisodeOverError, TeamEnv
from teamgym.envs.bounds import region
from teamgym.envs.config import ConfigError
from teamgym.envs.infos import InfoKey, categorical, metrics, unknown
from teamgym.envs.rendezvous.actions import NextPlaceAction, WithRecords
from teamgym.envs.rendezvous.config import RendezvousConfig
from teamgym.envs.rendezvous.messages import MESSAGE_VALUE_MAX, Kind, decode
from teamgym.envs.rendezvous.phases import RendezvousPhases
from teamgym.envs.rendezvous.scene import blocker_vertices, corridor_walls
from teamgym.envs.rendezvous.state import RendezvousArrays
from teamgym.envs.spaces import Field, ObservationLayout
from teamgym.maps.walls import JoinedWalls
from teamgym.sim.objects import StaticPolygon, Wall
from teamgym.sim.render import Overlay, robot_colour
from teamgym.sim.robot import DiffDriveRobot, RobotSpec
from teamgym.sim.scene import StaticScene
from teamgym.sim.sensors import KHEPERA_RING, ProximityRing
from teamgym.sim.world import World

__all__ = ["Rendezvous", "RendezvousConfig", "env", "parallel_env"]

_MARGIN = 0.1  # m of floor around the map
_DEFAULT_SPEED = 0.1


class Rendezvous(TeamEnv):
    """Rendezvous on a graph of places and ways (paper 003). See the module docstring."""

    metadata = {**TeamEnv.metadata, "name": "rendezvous_v0"}
    rebase_cycles = 600  # replaying 600 control cycles takes about 0.1-0.2 s (TeamEnv: copying and pickling)
    config_class = RendezvousConfig
    config: RendezvousConfig
    pixels_per_metre = 150.0
    phases_class = RendezvousPhases  # the step's phases over RendezvousArrays rows (one pass for a batch's copies)

    # -- construction ------------------------------------------------------------------
    def _agent_names(self) -> list[str]:
        return [f"robot_{i}" for i in range(self.config.n_robots)]

    def _setup(self) -> None:
        c = self.config
        self.map = c.graph_map
        self.uses_channel = c.protocol_messages
        ids = self.map.place_ids
        self.place_index = {p: i for i, p in enumerate(ids)}
        self.places_xy = np.array([[_MARGIN + p.x * c.scale, _MARGIN + p.y * c.scale] for p in self.map.places])
        neighbours = [[self.place_index[q] for q in self.map.neighbours(p)] for p in ids]
        self.max_degree = max(len(n) for n in neighbours)
        self.neighbour_table = np.full((len(ids), self.max_degree), -1, dtype=np.int64)
        for i, row in enumerate(neighbours):
            self.neighbour_table[i, : len(row)] = row
        self.way_index = {frozenset((self.place_index[w.a], self.place_index[w.b])): k for k, w in enumerate(self.map.ways)}
        #: Per place, the way index behind each neighbour slot (−1 padding); ``places``: ``places_xy`` as tuples.
        self.slot_ways = [
            [self.way_index[frozenset((p, q))] if q >= 0 else -1 for q in row]
            for p, row in enumerate(self.neighbour_table.tolist())
        ]
        self.places = [tuple(xy) for xy in self.places_xy.tolist()]
        self.way_ends = [(self.place_index[w.a], self.place_index[w.b]) for w in self.map.ways]
        #: The map as a graph over place indices (map units): node ``pos``, edge ``length`` and ``way`` index.
        self.graph = nx.Graph()
        for i, p in enumerate(self.map.places):
            self.graph.add_node(i, pos=(p.x, p.y))
        for k, (a, b) in enumerate(self.way_ends):
            self.graph.add_edge(a, b, length=float(self.map.ways[k].length), way=k)
        self.spec_robot = RobotSpec(max_wheel_speed=max(0.4, c.max_speed))
        self.ring = ProximityRing(KHEPERA_RING, c.sensor_range, c.sensor_noise)
        speeds = c.speeds or (_DEFAULT_SPEED,) * c.n_robots
        self.followers = [WayFollower(speed=v, stop_distance=0.9 * c.meet_distance) for v in speeds]
        #: Time allowed per robot and way driven ``(i, from, to)``: three times its length at the robot's speed, plus 5 s.
        self.move_timeouts = {
            (i, a, b): 3.0 * float(np.linalg.norm(self.places_xy[b] - self.places_xy[a])) / follower.speed + 5.0
            for i, follower in enumerate(self.followers)
            for a, b in (*self.way_ends, *((b, a) for a, b in self.way_ends))
        }
        n, w = c.n_robots, len(self.way_ends)
        self.state_space = spaces.Box(-np.inf, np.inf, shape=(5 * n + w,), dtype=np.float32)
        self._use_rows(RendezvousArrays(n, len(ids), w, self.ring.width, c.sensor_range, 1), 0)
        walls = corridor_walls(self.map, c.scale, c.corridor_width, _MARGIN) if c.corridor_walls else []
        #: The corridor walls as one entity (:mod:`teamgym.maps.walls`), built once and placed in every
        #: episode's world first (see :mod:`teamgym.sim.scene`).
        self._scene = StaticScene(
            [JoinedWalls("walls", [Wall(f"wall_{k}", a, b, 0.01) for k, (a, b) in enumerate(walls)])] if walls else []
        )

    def _make_action_type(self) -> ActionType:
        c = self.config
        motion: ActionType = (
            NextPlaceAction(self.max_degree, self.followers, c.stage_end)
            if c.action_type == "next_place"
            else VelocityAction(self.spec_robot)
        )
        #: The way-following action type, when it is the motion (the phases drive its robots in one pass).
        self.next_place = motion if isinstance(motion, NextPlaceAction) else None
        return WithRecords(motion, c.message_len) if c.protocol_messages else motion

    def _make_layout(self) -> ObservationLayout:
        c, d, n = self.config, self.max_degree, len(self.place_index)
        low, high = region(c, self._world_size(), c.corridor_walls, self.spec_robot.max_wheel_speed)
        fields = [
            Field("pose", (3,), [*low, -math.pi], [*high, math.pi]),
            Field("place", (1,), 0, n - 1),
            Field("target", (1,), -1, n - 1),
            Field("progress", (1,), 0.0, 1.0),
            Field("neighbours", (d,), -1, n - 1),
            Field("blocked", (d,), 0, 1, np.int8),
            Field("proximity", (len(KHEPERA_RING),), 0.0, c.sensor_range),
        ]
        if c.neighbour_offsets:
            reach = float(max(self._world_size()))
            fields.append(Field("neighbour_xy", (d, 2), -reach, reach))
        if c.protocol_messages:
            k = c.n_robots - 1
            fields += [
                Field("messages", (k, c.message_len), -1, MESSAGE_VALUE_MAX, np.int32),
                Field("message_sender", (k,), -1, c.n_robots - 1, np.int32),
                Field("message_mask", (k,), 0, 1, np.int8),
            ]
        return ObservationLayout(fields)

    def _world_size(self) -> tuple[float, float]:
        """The world (m): the map scaled, with ``_MARGIN`` of floor around it."""
        width, height = self.map.size
        return 2 * _MARGIN + width * self.config.scale, 2 * _MARGIN + height * self.config.scale

    # -- episodes ----------------------------------------------------------------------
    def _build(self, rng: np.random.Generator) -> None:
        c = self.config
        self.world = World(self._world_size(), **c.world_options())
        self._scene.place(self.world)
        n = c.n_robots
        if c.start_places:
            starts = np.array([self.place_index[p] for p in c.start_places])
        else:
            starts = rng.choice(len(self.place_index), size=n, replace=False)
        headings = rng.uniform(-np.pi, np.pi, size=n)
        self.robots = {}
        for agent, place, heading in zip(self.possible_agents, starts.tolist(), headings.tolist()):
            x, y = self.places_xy[place]
            self.robots[agent] = self.world.add(DiffDriveRobot(agent, (float(x), float(y)), heading, self.spec_robot))
        self.robot_list = list(self.robots.values())
        self._arrays.start(self._copy, starts.astype(np.int64), sorted(c.blockings, key=lambda b: b[2]))
        self._pose_rows = PoseRows()
        self._distances: tuple[np.ndarray | None, list[float], float] = (None, [], 0.0)
        for a, b in c.blocked_ways:
            self._block(self.way_index[frozenset((self.place_index[a], self.place_index[b]))])
        self.world.read_states()
        self._update_state()
        self._arrays.distance[self._copy] = self._mean_distance()
        self._check_goals()
        self._sense()

    # -- per-episode state (this copy's rows of ``self._arrays``) ---------------------------
    def _use_rows(self, team: RendezvousArrays, k: int) -> None:
        """Keep this env's episode state in copy row ``k`` of ``team`` (a batch's; see :class:`RendezvousArrays`)."""
        self._arrays, self._copy = team, k

    def _episode_state(self) -> dict[str, Any]:
        """The base's, with this copy's rows of ``_arrays`` in place of the arrays (a batch's hold every copy)."""
        state = super()._episode_state()
        team, k = state.pop("_arrays"), state.pop("_copy")
        state["_episode_rows"] = team.row(k)
        return state

    def _adopt_episode_state(self, state: dict[str, Any]) -> None:
        rows = state.pop("_episode_rows")
        super()._adopt_episode_state(state)
        self._arrays.set_row(self._copy, rows)

    @property
    def _place(self) -> np.ndarray:
        """Each robot's last place (a view of this copy's row)."""
        return self._arrays.place[self._copy]

    @property
    def _target(self) -> np.ndarray:
        """Each robot's next place, −1 standing (a view of this copy's row)."""
        return self._arrays.target[self._copy]

    @property
    def _blocked(self) -> set[int]:
        """The ways blocked so far (a new set)."""
        return self._arrays.blocked_set(self._copy)

    def note_message(self, agent: str, values: np.ndarray) -> None:
        """Score the whole paths a message announces (PATH records; see the module docstring).

        A PATH equal to the last one the same robot announced is a retransmission, not a new plan.
        """
        state, k = self._arrays, self._copy
        announced = state.announced[k]
        for kind, args in decode(values):
            if kind == Kind.PATH and len(args) >= 2:
                path = list(args[1:])
                if announced.get(agent) == path:
                    continue
                announced[agent] = path
                state.expansions[k] += max(0, args[0])
                state.plans[k].append(self._optimality(path))

    def _optimality(self, path: list[int]) -> float:
        """Cost of ``path`` over the shortest-path cost between its ends on the map as the team knows it.

        A path through a way the team knows to be blocked (its planner had not heard of it yet, e.g.
        over a lossy channel) is counted in ``stale_plans`` and scored with its own ways taken as
        open. A path that is not a walk on the map scores ``inf``.
        """
        if len(path) < 1 or not all(0 <= p < len(self.place_index) for p in path):
            return math.inf
        ways = [self.way_index.get(frozenset((a, b))) for a, b in zip(path, path[1:])]
        if any(k is None for k in ways):
            return math.inf
        known = set(np.flatnonzero(self._arrays.known[self._copy].any(axis=0)).tolist())
        if known & set(ways):
            self._arrays.stale_plans[self._copy] += 1
            known -= set(ways)
        cost = sum(self.graph.edges[a, b]["length"] for a, b in zip(path, path[1:]))
        best = self._shortest_cost(path[0], path[-1], known)
        return 1.0 if best == 0 and cost == 0 else cost / best if best > 0 else math.inf

    def _shortest_cost(self, a: int, b: int, blocked: set[int]) -> float:
        def weight(u: int, v: int, data: dict) -> float | None:
            return None if data["way"] in blocked else data["length"]

        try:
            return float(nx.shortest_path_length(self.graph, a, b, weight=weight))
        except nx.NetworkXNoPath:
            return math.inf

    # -- step phases (the lone env's; a batch runs RendezvousPhases over its copies) --------
    def _update_state(self) -> None:
        """Arrivals at places, give-ups, contacts; obstacles waiting for a way to clear are put in place."""
        state, k = self._arrays, self._copy
        poses, time, places = self._poses(), self.world.time, self.places
        state.arrived_now[k] = False
        targets, starts, place = state.target[k].tolist(), state.move_start[k].tolist(), state.place[k]
        for i, target in enumerate(targets):
            if target < 0:
                place[i] = self._nearest_place(i, poses[i])
            elif self.followers[i].arrived(poses[i], places[target]):
                place[i], state.target[k, i] = target, -1
                state.arrived_now[k, i] = True
                self._on_arrival(target)
            elif time - starts[i] > self.move_timeouts[i, int(state.origin[k, i]), target]:
                self._abandon_move(i)
        self._note_contacts()

    def _note_contacts(self) -> None:
        """Contacts of the last control step; obstacles waiting for a way to clear are put in place."""
        state, k = self._arrays, self._copy
        contacts = self.world.contacts
        if contacts:
            hits = self.world.contacts_per(self.possible_agents)
            state.collisions[k] += hits
            state.new_contacts[k] = hits
            state.robot_collisions[k] += sum(1 for ct in contacts if ct.a in self._row and ct.b in self._row)
            state.any_contact[k] = True
        elif state.any_contact[k]:  # the counts of the last step with contacts: 0 now
            state.new_contacts[k] = 0
            state.any_contact[k] = False
        if state.blocked_order[k] and not state.placed[k][state.blocked[k]].all():
            self._place_waiting_blockers()

    def _place_waiting_blockers(self) -> None:
        """Blocked ways whose obstacle waits for the way to clear get it once no robot is on them."""
        state, k = self._arrays, self._copy
        for way in [w for w in state.blocked_set(k) if not state.placed[k, w] and not state.on_way(k, self.way_ends[w])]:
            self._place_blocker(way)

    def _apply_events(self) -> None:
        c, time = self.config, self.world.time
        pending = self._arrays.pending[self._copy]
        while pending and pending[0][2] <= time + 1e-9:
            a, b, _ = pending.pop(0)
            self._block(self.way_index[frozenset((self.place_index[a], self.place_index[b]))])
        if c.block_rate > 0 and self.np_random.random() < c.block_rate * c.dt:
            self._block_random()

    def _check_goals(self) -> None:
        state, k = self._arrays, self._copy
        if state.met[k]:
            return
        meet = self.config.meet_distance
        if all(d <= meet for d in self._pair_distances()[1]):
            state.met[k] = True
            state.meeting_time[k] = self.world.time

    def _accumulate_rewards(self, total: np.ndarray) -> None:
        c, state, k = self.config, self._arrays, self._copy
        distance = self._mean_distance()
        reward = c.progress_reward * (float(state.distance[k]) - distance) - c.time_penalty
        state.distance[k] = distance
        if state.met[k] and float(state.meeting_time[k]) == self.world.time:
            reward += c.meet_bonus
        if state.any_contact[k]:
            total += reward - c.collision_penalty * state.new_contacts[k]
        else:  # the same values: every count is 0
            total += reward - c.collision_penalty * 0.0

    def _sense(self) -> None:
        """Proximity rings; a robot standing at a place detects that place's blocked ways.

        Only observations read the rings, so rings that draw no noise are read when the step
        observes (:meth:`_read_rings`), once per macro step instead of every control step: no
        body moves in between, so the readings are the same.
        """
        state, k = self._arrays, self._copy
        if self.ring.noiseless:
            state.rings_due[k] = True
        else:
            self._read_rings()
        if state.blocked_order[k]:
            self._detect_blocked()

    def _detect_blocked(self) -> None:
        """Robots standing at a place learn which of its ways are blocked."""
        state, k = self._arrays, self._copy
        blocked, known = state.blocked[k], state.known[k]
        for i, (place, target) in enumerate(zip(state.place[k].tolist(), state.target[k].tolist())):
            if target < 0:
                for way in self.slot_ways[place]:
                    if way >= 0 and blocked[way]:
                        known[i, way] = True

    def _terminations(self) -> dict[str, bool]:
        return dict.fromkeys(self.live_agents, bool(self._arrays.met[self._copy]))

    def episode_success(self) -> bool:
        """The robots met (every pair within ``meet_distance``) without a collision between robots."""
        if self.world is None:
            return False
        state, k = self._arrays, self._copy
        return bool(state.met[k]) and int(state.robot_collisions[k]) == 0

    # -- helpers -------------------------------------------------------------------------
    def _poses(self) -> list[tuple[float, float, float]]:
        """``(x, y, θ)`` of every robot as Python floats, read once per reading of ``world.robot_states``."""
        return self._pose_rows(self.world.robot_states)

    def _pair_distances(self) -> tuple[np.ndarray | None, list[float], float]:
        """Centre distances of all ordered robot pairs (row-major, n × n) and their mean over pairs i ≠ j.

        Computed once per reading of ``world.robot_states``; the values are those of
        ``np.linalg.norm(pos[:, None] - pos[None], axis=2)`` (``sqrt(dx² + dy²)``) and of its
        ``sum() / (n (n − 1))``, which for two robots is their one distance.
        """
        states = self.world.robot_states
        if self._distances[0] is not states:
            points = [(x, y) for x, y, _ in self._poses()]
            n = len(points)
            d = [math.sqrt((xi - xj) * (xi - xj) + (yi - yj) * (yi - yj)) for xi, yi in points for xj, yj in points]
            if n == 2 and d[0] == 0.0 and d[3] == 0.0:  # the sum 0 + d + d + 0, halved, is d
                self._distances = (states, d, d[1])
            else:
                self._distances = (states, d, float(np.array(d).reshape(n, n).sum() / (n * (n - 1))))
        return self._distances

    def _mean_distance(self) -> float:
        return self._pair_distances()[2]

    def _on_arrival(self, place: int) -> None:
        """``arrival_blockings``: ways that become blocked when a robot reaches a place for the n-th time."""
        visits = self._arrays.visits[self._copy]
        visits[place] += 1
        for a, b, at, visit in self.config.arrival_blockings:
            if self.place_index[at] == place and visits[place] == visit:
                self._block(self.way_index[frozenset((self.place_index[a], self.place_index[b]))])

    def _abandon_move(self, i: int) -> None:
        """A robot that cannot get through a way (an obstacle in its corridor): it drives back, and
        the way counts as blocked and known to it, as a blocked way seen from its place would."""
        state, k = self._arrays, self._copy
        origin, target = int(state.origin[k, i]), int(state.target[k, i])
        way = self.way_index[frozenset((origin, target))]
        state.block(k, way)
        state.known[k, i, way] = True
        state.failed_moves[k, i] += 1
        state.target[k, i], state.origin[k, i] = origin, target  # return to where it came from
        state.move_start[k, i] = self.world.time
        state.arrived_now[k, i] = True

    def _nearest_place(self, i: int, pose: tuple[float, float, float]) -> int:
        """The nearest place if it is within half a corridor width of robot ``i`` at ``pose``, else its place.

        Only places with ``|dx|, |dy| <= w / 2`` are measured: a distance ``sqrt(dx² + dy²)`` is
        at least ``|dx|`` and ``|dy|``, so the others are farther than ``w / 2`` (and than any
        place within it). A robot standing still is not looked up again.
        """
        x, y = pose[0], pose[1]
        cache = self._arrays.nearest_seen[self._copy]
        seen = cache[i]
        if not seen or seen[0] != x or seen[1] != y:
            half, best, k = self.config.corridor_width / 2, math.inf, -1
            for j, (px, py) in enumerate(self.places):
                dx = px - x
                if -half <= dx <= half:
                    dy = py - y
                    if -half <= dy <= half and (d := math.sqrt(dx * dx + dy * dy)) < best:
                        best, k = d, j
            seen = cache[i] = (x, y, k, best <= half)
        return seen[2] if seen[3] else int(self._arrays.place[self._copy, i])

    def block_way(self, a: str, b: str) -> None:
        """Block way ``a``–``b`` now, between steps (its obstacle appears once no robot is on it).

        Recorded, so copies and pickles replay it. Raises ``KeyError`` naming the way if the map
        has no such way, :class:`EpisodeOverError` outside an episode.
        """
        if self.world is None or not self.live_agents:
            raise EpisodeOverError("block_way() needs a running episode; call reset() first")
        ends = frozenset((self.place_index.get(a, -1), self.place_index.get(b, -2)))
        if ends not in self.way_index:
            raise KeyError(f"block_way: map {self.map.name!r} has no way ({a!r}, {b!r})")
        self._record("block_way", a, b)
        self._block(self.way_index[ends])

    def _block(self, way: int) -> None:
        """Block ``way``; its obstacle appears now unless a robot is on the way (or it is already there).

        A way blocked twice (a scheduled blocking of a way blocked at random, say) keeps its one
        obstacle (the second blocking used to add a second obstacle of the same name, a ValueError).
        """
        state, k = self._arrays, self._copy
        state.block(k, way)
        if not state.placed[k, way] and not state.on_way(k, self.way_ends[way]):
            self._place_blocker(way)

    def _place_blocker(self, way: int) -> None:
        a, b = self.way_ends[way]
        vertices = blocker_vertices(tuple(self.places_xy[a]), tuple(self.places_xy[b]), self.config.corridor_width)
        state, k = self._arrays, self._copy
        state.blockers[k][way] = self.world.add(StaticPolygon(f"blocker_{way}", vertices))
        state.placed[k, way] = True

    def _block_random(self) -> None:
        """Block a random way that is not blocked and whose loss keeps the map connected."""
        blocked = self._arrays.blocked_set(self._copy)
        candidates = [k for k in range(len(self.way_ends)) if k not in blocked]
        if not candidates:
            return
        k = candidates[int(self.np_random.integers(len(candidates)))]
        a, b = self.way_ends[k]
        if math.isfinite(self._shortest_cost(a, b, blocked | {k})):
            self._block(k)

    # -- state, metrics, rendering -------------------------------------------------------
    def _read_rings(self) -> None:
        state, k = self._arrays, self._copy
        self.ring.read_rows(self.world, self.robot_list, self.world.robot_states, self.np_random, state.proximity[k])
        state.rings_due[k] = False

    def _observe(self, out: np.ndarray) -> None:
        state, k = self._arrays, self._copy
        if state.rings_due[k]:
            self._read_rings()
        layout, poses, fields = self.layout, self._poses(), self.layout.slices
        place_at, target_at, progress_at = fields["place"], fields["target"], fields["progress"]
        neighbours_at, blocked_at, proximity_at = fields["neighbours"], fields["blocked"], fields["proximity"]
        places, targets, known, proximity = state.place[k].tolist(), state.target[k].tolist(), state.known[k], state.proximity[k]
        offsets_at = fields.get("neighbour_xy")
        for row, agent in enumerate(self.live_agents):
            i, buffer = self._row[agent], out[row]
            x, y, theta = poses[i]
            buffer[0:3] = (x, y, math.remainder(theta, math.tau))
            place = places[i]
            buffer[place_at] = place
            buffer[target_at] = targets[i]
            buffer[progress_at] = self._progress(i)
            buffer[neighbours_at] = self.neighbour_table[place]
            buffer[blocked_at] = [way >= 0 and bool(known[i, way]) for way in self.slot_ways[place]]
            buffer[proximity_at] = proximity[i]
            if offsets_at is not None:
                buffer[offsets_at] = self._neighbour_offsets(place, x, y)
            if self.config.protocol_messages:
                packed = self.channel.inbox_array(agent, self.config.message_len, self.config.n_robots - 1, kind="protocol")
                layout.view(buffer, "messages")[:] = packed.payload
                layout.view(buffer, "message_sender")[:] = packed.sender
                layout.view(buffer, "message_mask")[:] = packed.mask

    def _neighbour_offsets(self, place: int, x: float, y: float) -> np.ndarray:
        """``(D · 2,)``: per neighbour slot of ``place``, its place's ``(x, y)`` minus the robot's (m); 0 padding."""
        row = self.neighbour_table[place]
        offsets = np.zeros((len(row), 2))
        used = row >= 0
        offsets[used] = self.places_xy[row[used]] - (x, y)
        return offsets.ravel()

    def _progress(self, i: int) -> float:
        state, k = self._arrays, self._copy
        if state.target[k, i] < 0:
            return 0.0
        a, b = self.places_xy[state.origin[k, i]], self.places_xy[state.target[k, i]]
        squared = float(np.dot(b - a, b - a))
        done = float(np.dot(self.world.robot_states[i, :2] - a, b - a)) / max(squared, 1e-12)
        return float(np.clip(done, 0.0, 1.0))

    def _info_keys(self) -> dict[str, InfoKey]:
        """Counts from reset on; ``optimality`` (worst plan cost ratio) NaN until a plan exists, ``meeting_time`` (s)
        NaN until the robots meet; ``place`` is categorical (``place_id`` names it)."""
        counts = ("path_length", "collisions", "robot_collisions", "blocked_known", "plans", "replans", "expansions")
        keys = {**metrics(*counts, "stale_plans", "failed_moves"), **categorical("place")}
        return {**keys, **unknown("optimality", "meeting_time")}

    def _metrics(self, agent: str) -> dict[str, Any]:
        i, state, k = self._row[agent], self._arrays, self._copy
        plans = state.plans[k]
        metrics: dict[str, Any] = {
            "path_length": float(self.robot_list[i].odometer),
            "place": int(state.place[k, i]),
            "collisions": int(state.collisions[k, i]),
            "robot_collisions": int(state.robot_collisions[k]),
            "blocked_known": int(state.known[k, i].sum()),
            "plans": len(plans),
            "replans": max(0, len(plans) - 1),
            "expansions": int(state.expansions[k]),
            "stale_plans": int(state.stale_plans[k]),
            "failed_moves": int(state.failed_moves[k, i]),
        }
        if plans:
            metrics["optimality"] = float(max(plans))
        if state.met[k]:
            metrics["meeting_time"] = float(state.meeting_time[k])
        return metrics

    def place_id(self, index: int) -> str:
        """The map id of place ``index`` (observations and infos hold indices)."""
        return self.map.place_ids[int(index)]

    def state(self) -> np.ndarray:
        if self.world is None:
            raise RuntimeError("state() called before reset()")
        states, team, k = self.world.robot_states, self._arrays, self._copy
        robots = np.column_stack([states[:, :3], team.place[k], team.target[k]]).ravel()
        blocked = team.blocked[k].astype(float)
        return np.concatenate([robots, blocked]).astype(np.float32)

    def _overlay(self) -> Overlay:
        overlay = Overlay(
            points=[(tuple(self.places_xy[p]), robot_colour(i)) for i, p in enumerate(self._target.tolist()) if p >= 0]
        )
        blocked = self._arrays.blocked[self._copy]
        for k, (a, b) in enumerate(self.way_ends):
            colour = (200, 40, 40) if blocked[k] else (200, 200, 200)
            overlay.paths.append(([tuple(self.places_xy[a]), tuple(self.places_xy[b])], colour))
        return overlay

    def _check_feasible(self) -> None:
        """The robots can meet: their start places (every place, for random starts) stay joined despite ``blocked_ways``."""
        blocked = {self.way_index[frozenset((self.place_index[a], self.place_index[b]))] for a, b in self.config.blocked_ways}
        starts = [self.place_index[p] for p in self.config.start_places] or list(range(len(self.place_index)))
        open_map = self.graph.copy()
        open_map.remove_edges_from([self.way_ends[k] for k in blocked])
        reach = nx.node_connected_component(open_map, starts[0])
        if not set(starts) <= reach:
            where = "the start places" if self.config.start_places else "the map (random start places)"
            raise ConfigError(f"RendezvousConfig: blocked_ways leave {where} without a path between them")


def parallel_env(render_mode: str | None = None, **config: Any) -> Rendezvous:
    """The PettingZoo parallel env (same as ``teamgym.make("Rendezvous-v0", ...)``)."""
    return Rendezvous(render_mode=render_mode, **config)


def env(render_mode: str | None = None, **config: Any):
    """The AEC form of the env, through PettingZoo's ``parallel_to_aec``."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(render_mode=render_mode, **config))
