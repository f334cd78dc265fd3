"""Action types of Rendezvous-v0: the next place (a macro action) and protocol messages.

``NextPlaceAction``: ``Discrete(D + 1)`` with ``D`` the map's largest degree. Slot ``k < D``
is the ``k``-th neighbour of the robot's place (neighbours in map order), slot ``D`` waits.
One ``step`` lasts until some moving robot reaches its next place (or no robot moves); a
robot already on a way finishes it, so while it moves only its way's slot and "wait"
(both: continue) are admissible. Ways the robot knows to be blocked are masked.

``WithRecords`` adds the protocol's message (:mod:`teamgym.envs.rendezvous.messages`):
``Dict(move=..., message=Box(-1, 2³¹−1, (message_len,), int32))``, broadcast through the
env's channel (kind ``"protocol"``) when it holds a record.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from gymnasium import spaces

from teamgym.control.way_following import WayFollower
from teamgym.envs.actions import ActionType, WithMessage
from teamgym.envs.rendezvous.messages import used_length
from teamgym.envs.spaces import MaskedDiscrete

if TYPE_CHECKING:
    from teamgym.envs.rendezvous.state import RendezvousArrays
    from teamgym.sim.robot import DiffDriveRobot
    from teamgym.sim.world import World


class WayTask(Protocol):
    """What :class:`NextPlaceAction` reads of its task (Rendezvous implements it).

    ``_arrays`` holds the episode state of the copies (:class:`~teamgym.envs.rendezvous.state.RendezvousArrays`),
    ``_copy`` is this task's row; the map comes as ``neighbour_table`` (per place, the neighbour in each
    slot, −1 padding), ``slot_ways`` (the way behind each slot, −1 padding) and ``places`` (positions, m).
    """

    _arrays: RendezvousArrays
    _copy: int
    _row: dict[str, int]
    neighbour_table: np.ndarray
    slot_ways: list[list[int]]
    places: list[tuple[float, float]]
    robot_list: list[DiffDriveRobot]
    world: World

    def _poses(self) -> list[tuple[float, float, float]]: ...


class NextPlaceAction(ActionType):
    """The next place to go to (a macro action run by the way-following controllers of :mod:`teamgym.control.way_following`).

    ``followers``: one :class:`WayFollower` per robot row; ``stage_end``: ``"any"`` (a stage ends when
    one moving robot arrives) or ``"all"`` (when every one has).
    """

    name = "next_place"
    is_macro = True
    has_masks = True

    def __init__(self, max_degree: int, followers: Sequence[WayFollower] = (), stage_end: str = "any") -> None:
        self.max_degree = max_degree
        self.followers = list(followers)
        self.stage_end = stage_end

    def space(self) -> MaskedDiscrete:
        return MaskedDiscrete(self.max_degree + 1)

    def start(self, env: WayTask, actions: dict[str, Any]) -> None:
        """Start the chosen ways; a robot already on a way finishes it, "wait" stays."""
        state, k, wait = env._arrays, env._copy, self.max_degree
        place, origin, target, move_start = state.place[k], state.origin[k], state.target[k], state.move_start[k]
        row, table, now = env._row, env.neighbour_table, env.world.time
        for agent, slot in actions.items():
            i = row[agent]
            if target[i] >= 0 or int(slot) == wait:
                continue
            origin[i] = place[i]
            target[i] = table[place[i], int(slot)]
            move_start[i] = now

    def act(self, env: WayTask, agent: str, action: Any) -> tuple[float, float]:
        """The way-following controller's command for ``agent`` (zero when standing)."""
        i = env._row[agent]
        state, k = env._arrays, env._copy
        target = int(state.target[k, i])
        if target < 0:
            return 0.0, 0.0
        poses, places = env._poses(), env.places
        return self.followers[i].command(poses[i], places[int(state.origin[k, i])], places[target], nearest_ahead(i, poses))

    def drive(self, env: WayTask, agents: Iterable[str]) -> None:
        """Set the command of every robot of ``agents`` (:meth:`act` for each, in one pass over the copy's rows)."""
        state, k = env._arrays, env._copy
        targets = state.target[k].tolist()
        robots, row = env.robot_list, env._row
        if max(targets) < 0:
            for agent in agents:
                robots[row[agent]].set_command(0.0, 0.0)
            return
        origins, poses, places, followers = state.origin[k].tolist(), env._poses(), env.places, self.followers
        for agent in agents:
            i = row[agent]
            target = targets[i]
            if target < 0:
                robots[i].set_command(0.0, 0.0)
            else:
                ahead = nearest_ahead(i, poses)
                robots[i].set_command(*followers[i].command(poses[i], places[origins[i]], places[target], ahead))

    def stage_over(self, env: WayTask) -> bool:
        """The stage ends on meeting, when no robot moves, or (``stage_end="any"``) when one reaches its next place."""
        state, k = env._arrays, env._copy
        if state.met[k] or max(state.target[k].tolist()) < 0:
            return True
        return self.stage_end == "any" and True in state.arrived_now[k].tolist()

    def mask(self, env: WayTask, agent: str) -> np.ndarray:
        """Admissible slots: unblocked ways from the robot's place (as it knows them) and "wait"."""
        i = env._row[agent]
        state, k = env._arrays, env._copy
        mask = np.zeros(self.max_degree + 1, dtype=np.int8)
        mask[self.max_degree] = 1
        place, target = int(state.place[k, i]), int(state.target[k, i])
        if target >= 0:
            row = env.neighbour_table[place].tolist()
            if target in row:  # a robot driving back from a way it could not pass has only "wait"
                mask[row.index(target)] = 1
            return mask
        known = state.known[k, i]
        for slot, way in enumerate(env.slot_ways[place]):
            if way >= 0 and not known[way]:
                mask[slot] = 1
        return mask

    def describe(self, action: Any) -> str:
        return "wait" if int(action) == self.max_degree else f"neighbour slot {int(action)}"


def nearest_ahead(i: int, poses: list[tuple[float, float, float]]) -> float:
    """Distance from robot ``i`` to the nearest other robot within 60° of its heading (inf if none)."""
    x, y, theta = poses[i]
    best = math.inf
    for j, (xj, yj, _) in enumerate(poses):
        if j != i:
            d = math.hypot(xj - x, yj - y)
            if d < best and abs(math.remainder(math.atan2(yj - y, xj - x) - theta, math.tau)) < math.pi / 3:
                best = d
    return best


class WithRecords(WithMessage):
    """A move plus a protocol message (see the module docstring)."""

    motion_key = "move"

    def message_space(self) -> spaces.Box:
        return spaces.Box(-1, np.iinfo(np.int32).max, shape=(self.length,), dtype=np.int32)

    def send(self, env, agent: str, message: Any) -> None:
        """Transmit the records only (4 bytes a value, no padding); the env scores PATH records."""
        values = np.asarray(message, dtype=np.int32)
        used = used_length(values)
        if used:
            env.channel.send(agent, values[:used].astype(np.float32), size=4 * used, kind="protocol")
            env.note_message(agent, values[:used])
