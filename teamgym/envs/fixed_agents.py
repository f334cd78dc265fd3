"""``fixed_agents=True``: a fixed agent list for engines that need one (TorchRL, BenchMARL, SuperSuit vector envs).

Without it, ``env.agents`` holds the live robots: robots that finish (a Navigation robot at its
goal, a BoxPushing robot removed or broken down) leave it, spare robots join it when an event
adds them. With it, :class:`FixedRoster` keeps ``env.agents == env.possible_agents`` from
``reset`` until the team's episode ends (every live robot terminated or truncated), then ``[]``;
``env.live_agents`` still holds the robots in the episode now. An agent is *present* while it is
live, including the step in which it ends (that step's observation, reward and infos are its
real ones). An agent that is not present (a spare not yet added, a robot after its last step):

* observes the *absent row*: zeros (clipped into a field's bounds where 0 is outside them)
  with the observation field ``present`` = 0 (``present`` = 1 for present agents; the field
  exists with ``fixed_agents=True`` only), and, where the observation carries a mask, an
  all-admissible mask;
* gets reward 0; its action is optional and ignored (it must still lie in the action space);
* reports ``terminated = truncated = False`` until the team's episode ends, so a robot that
  ends early (arrives, is removed) reports ``False`` on its last step too and reads
  ``present`` = 0 from the next step on (PettingZoo's API test requires that an agent reported
  done leaves ``agents``);
* keeps its last infos (a spare: the schema's values until known) with ``present`` = 0, the
  team's current ``success`` and an all-admissible ``action_mask``.

At the team's last step every agent reports done: a present agent as without
``fixed_agents``; an agent that ended earlier ``terminated=True``; a spare that never joined
``truncated=True`` if the episode ends at its time limit, else ``terminated=True``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from teamgym.envs.infos import InfoKey
from teamgym.envs.spaces import Field

if TYPE_CHECKING:
    from teamgym.envs.base import TeamEnv

#: The observation field of ``fixed_agents=True``: 1 while the agent is present, 0 otherwise.
PRESENT = Field("present", (1,), 0, 1, np.int8)
#: Its key in ``infos[agent]`` (1 or 0, as the observation field).
PRESENT_INFO = InfoKey("metric", 0, sentinel=False)


class FixedRoster:
    """The fixed agent list of one env and what its absent agents observe and report."""

    def __init__(self, env: TeamEnv) -> None:
        self.possible: list[str] = list(env.possible_agents)
        self.agents: list[str] = []
        space = env.layout.flat_space()
        self.absent_row = np.clip(np.zeros(space.shape, dtype=np.float32), space.low, space.high)
        self.absent_row[env.layout.slices[PRESENT.name]] = 0.0
        #: How each agent that ended before the team did ended ("terminated" or "truncated").
        self._ended: dict[str, str] = {}
        self._infos: dict[str, dict[str, Any]] = {}

    def reset(self) -> None:
        self.agents = list(self.possible)
        self._ended = {}
        self._infos = {}

    def live_actions(self, env: TeamEnv, actions: dict) -> dict:
        """``actions`` of the live agents only; those of absent agents are checked against their space and dropped."""
        rows, live = env._row, set(env.live_agents)
        unknown = [a for a in actions if a not in rows]
        if unknown:
            raise KeyError(f"actions for unknown agent(s) {unknown}; agents are {self.agents}")
        for agent, action in actions.items():
            if agent not in live:
                env._checkers[agent].check(agent, action)
        return {a: action for a, action in actions.items() if a in live}

    def observations(self, rows: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Flat rows of every agent: the present agents' ``rows``, the absent row for the others."""
        return {a: rows[a] if a in rows else self.absent_row.copy() for a in self.possible}

    def infos(self, env: TeamEnv, infos: dict[str, dict[str, Any]], success: bool) -> dict[str, dict[str, Any]]:
        """Infos of every agent: the present agents' ``infos`` (remembered), the absent agents' last ones."""
        out = {}
        for agent in self.possible:
            if agent in infos:
                info = infos[agent]
                info[PRESENT.name] = 1
                self._infos[agent] = dict(info)
            else:
                info = dict(self._infos.get(agent, env._info_template))
                info[PRESENT.name] = 0
                info["success"] = success
                if "action_mask" in info:
                    info["action_mask"] = env.action_type.info_mask(env._all_admissible())
            out[agent] = info
        return out

    def step(
        self, env: TeamEnv, rewards: dict[str, float], terminations: dict[str, bool], truncations: dict[str, bool]
    ) -> tuple[dict[str, float], dict[str, bool], dict[str, bool]]:
        """Rewards and end flags of every agent after a step (call once ``env.live_agents`` is trimmed)."""
        for agent, terminated in terminations.items():
            if terminated or truncations[agent]:
                self._ended[agent] = "terminated" if terminated else "truncated"
        rewards = {a: rewards.get(a, 0.0) for a in self.possible}
        if env.live_agents:
            return rewards, dict.fromkeys(self.possible, False), dict.fromkeys(self.possible, False)
        timed_out = env.cycles >= env.config.cycle_limit
        ends = {a: self._ended.get(a, "truncated" if timed_out else "terminated") for a in self.possible}
        self.agents = []
        return rewards, {a: e == "terminated" for a, e in ends.items()}, {a: e == "truncated" for a, e in ends.items()}
