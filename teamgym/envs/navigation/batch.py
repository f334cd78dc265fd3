"""``NavigationBatch``: K copies of Navigation-v0 stepped together in one process, arrays in and out.

For RL frameworks that want many env copies per process (SB3 through
:class:`baselines.rl.sb3_env.TeamVecEnv`, or a framework of your own). Actions are one array
``(K, N, *action_shape)``; observations ``(K, N, D)``, rewards, terminations and truncations
``(K, N)`` come back as arrays. Each copy keeps its own pymunk world (stepped one after the
other; physics is deterministic per copy), while everything numpy computes — poses,
distances, contacts, progress, arrivals, rewards, observations — is one pass over all copies
(:class:`~teamgym.envs.navigation.team_state.TeamState`). A copy steps exactly as a single
``Navigation`` env with the same seed and actions would: same observations, rewards and
metrics bit for bit (tests/test_navigation_batch.py).

Copies are real :class:`~teamgym.envs.navigation.env.Navigation` envs (``batch.copies[k]``)
whose per-step arrays live in the batch; use them for metrics (``_metrics``), success
(``episode_success()``) and state, not to step. A robot that arrives or is truncated leaves
``active``; its rows read zero reward and ``False`` flags afterwards, and its actions are
ignored. A copy whose robots are all done stops stepping until :meth:`reset_copy`; there is
no automatic reset (the caller decides when and with which seed). Trails are not recorded
and nothing renders. Learned messages (``comm_dim``) and ``obs_format="dict"`` are not supported
(observations are flat; ``batch.layout.decode`` names their fields). A batch, and each of its
copies alone, survives ``pickle`` and ``copy.deepcopy`` mid-episode and continues identically,
as a single env does: every copy logs the joint actions it was stepped with since its last base
(``TeamEnv``, "copying and pickling") and re-bases at the cycles a single env would.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from teamgym.envs.base import EpisodeOverError
from teamgym.envs.config import ConfigError
from teamgym.envs.navigation.env import Navigation
from teamgym.envs.navigation.team_state import TeamState
from teamgym.envs.spaces import ActionRowsChecker

__all__ = ["NavigationBatch"]


class NavigationBatch:
    """``n_copies`` Navigation-v0 copies with one config, stepped with arrays (see the module docstring)."""

    def __init__(self, n_copies: int, **config: Any) -> None:
        if not isinstance(n_copies, int) or isinstance(n_copies, bool) or n_copies < 1:
            raise ValueError(f"n_copies must be an integer >= 1, got {n_copies!r}")
        if config.get("comm_dim"):
            raise ConfigError("NavigationBatch does not support learned messages (comm_dim > 0)")
        if config.get("obs_format", "flat") != "flat":
            raise ConfigError("NavigationBatch observations are flat arrays (obs_format='flat'); decode them with batch.layout")
        config.pop("render_mode", None)
        self._config_kwargs = dict(config)
        self.copies: list[Navigation] = []
        first = Navigation(**config)
        self.config = first.config
        self.possible_agents: list[str] = list(first.possible_agents)
        self.layout = first.layout
        self.action_space: spaces.Space = first.action_space(self.possible_agents[0])
        self.observation_space = self.layout.flat_space()
        self._action_type = first.action_type
        self._checker = ActionRowsChecker(self.action_space)
        self.team = TeamState(self.config, 0, first.ring.width)
        n = self.config.n_robots
        #: ``(K, N)``: robots in their episode (they act, are stepped and observed).
        self.active = np.zeros((0, n), dtype=bool)
        self._observations = np.zeros((0, n, self.layout.size), dtype=np.float32)
        self._add(first)
        for _ in range(n_copies - 1):
            self.add_copy()

    @property
    def n_copies(self) -> int:
        return len(self.copies)

    @property
    def n_robots(self) -> int:
        return self.config.n_robots

    def add_copy(self) -> int:
        """Append a copy (not yet reset); returns its index."""
        return self._add(Navigation(**self._config_kwargs))

    def truncate(self, n_copies: int) -> None:
        """Drop the copies from index ``n_copies`` on (at least one copy stays)."""
        if n_copies < 1:
            raise ValueError(f"a batch keeps at least one copy, got n_copies={n_copies}")
        for env in self.copies[n_copies:]:
            env.close()
        del self.copies[n_copies:]
        self.team.shrink(len(self.copies))
        self.active = self.active[: len(self.copies)].copy()
        self._observations = self._observations[: len(self.copies)].copy()

    def _add(self, env: Navigation) -> int:
        k = len(self.copies)
        self.team.grow(k + 1)
        env._bind(self.team, k)
        self.copies.append(env)
        self.active = np.concatenate([self.active, np.zeros((1, self.n_robots), dtype=bool)])
        self._observations = np.concatenate([self._observations, np.zeros((1, *self._observations.shape[1:]), np.float32)])
        return k

    # -- episodes --------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None) -> np.ndarray:
        """Reset every copy (copy ``k`` with ``seed + k``); returns the observations ``(K, N, D)``."""
        for k in range(self.n_copies):
            self.reset_copy(k, None if seed is None else seed + k, options)
        return self._observations.copy()

    def reset_copy(self, k: int, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict[str, dict]]:
        """Start a new episode in copy ``k``; returns its observations ``(N, D)`` and its infos (per agent)."""
        if not 0 <= k < self.n_copies:
            raise IndexError(f"copy {k} does not exist; the batch has {self.n_copies} copies")
        env = self.copies[k]
        observations, infos = env.reset(seed=seed, options=options)
        self.active[k] = [agent in observations for agent in self.possible_agents]
        self._observe(env._ks, self._observations[k : k + 1])
        return self._observations[k].copy(), infos

    def episode_over(self) -> np.ndarray:
        """``(K,)``: copies whose robots are all done (or that were never reset)."""
        return ~self.active.any(axis=1)

    # -- stepping --------------------------------------------------------------------
    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """One control step of every copy with an active robot.

        ``actions``: ``(K, N, *action_shape)`` (``(K, N)`` for discrete actions); rows of robots
        that are not active are ignored. Returns observations ``(K, N, D)`` (every robot's; a
        robot that finished now has its final one), rewards, terminations and truncations
        ``(K, N)`` (zero and ``False`` for robots that were not active).
        """
        live = self.active.copy()
        fresh = [k for k, env in enumerate(self.copies) if env.world is None]
        if fresh:
            raise EpisodeOverError(f"NavigationBatch.step(): copies {fresh} were never reset; call reset() or reset_copy(k)")
        if not live.any():
            raise EpisodeOverError("NavigationBatch.step() with no active robot: reset copies first")
        shape = (self.n_copies, self.n_robots, *self._checker._shape)
        array = np.asarray(actions) if not isinstance(actions, np.ndarray) else actions
        if array.shape != shape:
            raise ValueError(f"actions have shape {array.shape}, expected {shape} (copies, robots, action)")
        rows_k, rows_i = np.nonzero(live)
        names = [self.possible_agents[i] for i in rows_i.tolist()]
        checked = self._checker.check(array[rows_k, rows_i], names)
        stepping = np.flatnonzero(live.any(axis=1))
        self._log_actions(rows_k, rows_i, names, checked)
        self._command(rows_k, rows_i, checked)
        team, everything = self.team, slice(None)
        commands = np.array([[robot.command for robot in env.robot_list] for env in self.copies], dtype=float)
        team.command(everything, live, commands)
        for k in stepping.tolist():
            env = self.copies[k]
            if self.config.actuation_delay > 0:
                env._delay_actuation(env.robot_list, env.np_random)
            env.world.step(reuse_states=True)  # nothing moves a copy's bodies between its steps
            env.cycles += 1
        worlds = [env.world for env in self.copies]
        team.read(everything, np.stack([w.robot_states for w in worlds]), np.stack([w.mover_states for w in worlds]))
        team.update_distances(everything)
        hits = np.array([w.contacts_per(self.possible_agents) for w in worlds])
        team.after_physics(everything, live, hits)
        cycles = np.array([env.cycles for env in self.copies])
        arriving = team.check_goals(everything, live, cycles * self.config.dt)
        rewards = team.rewards(everything, live)
        self._sense(live & ~arriving)
        terminated = live & team.arrived
        truncated = live & ~terminated & (cycles >= self.config.cycle_limit)[:, None]
        self._observe(everything, self._observations)
        done = terminated | truncated
        if done.any():
            self._finish(done)
        for k in stepping.tolist():
            self.copies[k]._rebase_if_due()  # at the cycles a single env re-bases (TeamEnv.rebase_cycles)
        return self._observations.copy(), rewards, terminated, truncated

    def _observe(self, ks: slice, out: np.ndarray) -> None:
        """The observations of copies ``ks`` into ``out``, saturated at the layout's bounds (as a single env's)."""
        self.team.observe(ks, self.layout, out)
        self.layout.clip(out)

    def _log_actions(self, rows_k: np.ndarray, rows_i: np.ndarray, names: list[str], checked: np.ndarray) -> None:
        """Each stepping copy logs its joint action as its own ``step`` would, so a copy pickles and replays exactly."""
        joint: dict[int, dict[str, Any]] = {}
        discrete = checked.ndim == 1
        for k, name, action in zip(rows_k.tolist(), names, checked.tolist() if discrete else checked):
            joint.setdefault(k, {})[name] = action
        for k, actions in joint.items():
            self.copies[k]._log.append(("step", actions))

    def _sense(self, sensing: np.ndarray) -> None:
        """Proximity rings of the ``sensing`` robots (k, N): rays only where something is within range.

        Noiseless rings of robots with nothing near read ``sensor_range`` in one numpy step; the
        other copies read through their env (which casts the rays and draws the noise).
        """
        free = self.team.sensing_free(slice(None))
        ring = self.copies[0].ring
        if ring.noiseless:
            clear = sensing & free
            self.team.proximity[clear] = ring.max_range
            sensing = sensing & ~free
        for k in np.flatnonzero(sensing.any(axis=1)).tolist():
            rows = np.flatnonzero(sensing[k])
            self.copies[k]._read_proximity(rows, free[k, rows])

    def _command(self, rows_k: np.ndarray, rows_i: np.ndarray, actions: np.ndarray) -> None:
        """Set the body command of every active robot (the action type's :meth:`commands`, else its ``act`` per robot)."""
        commands = self._action_type.commands(actions)
        copies, names = self.copies, self.possible_agents
        if commands is None:
            act = self._action_type.act
            for k, i, action in zip(rows_k.tolist(), rows_i.tolist(), actions):
                env = copies[k]
                env.robot_list[i].set_command(*act(env, names[i], action))
            return
        for k, i, (v, omega) in zip(rows_k.tolist(), rows_i.tolist(), commands.tolist()):
            copies[k].robot_list[i].set_command(v, omega)

    def _finish(self, done: np.ndarray) -> None:
        """Robots that finished leave ``active`` and their copy's ``agents`` and stop (as in ``TeamEnv.step``)."""
        self.active &= ~done
        for k in np.flatnonzero(done.any(axis=1)).tolist():
            env = self.copies[k]
            finished = {self.possible_agents[i] for i in np.flatnonzero(done[k]).tolist()}
            env.live_agents = [a for a in env.live_agents if a not in finished]
            for agent in finished:
                env.robots[agent].set_command(0.0, 0.0)

    # -- copying and pickling --------------------------------------------------------
    def __getstate__(self) -> dict:
        """The config and each copy's own pickled state (its reset and the joint actions it was stepped with)."""
        return {"config": self._config_kwargs, "copies": [env.__getstate__() for env in self.copies], "active": self.active}

    def __setstate__(self, state: dict) -> None:
        copies = state["copies"]
        self.__init__(len(copies), **state["config"])
        for k, copy_state in enumerate(copies):
            env = Navigation.__new__(Navigation)
            env.__setstate__(copy_state)  # replays its episode in a state of its own
            if env.world is not None:
                for name in self.team._allocate(0):
                    getattr(self.team, name)[k] = getattr(env._team, name)[0]
                self.team.obstacle_shapes[k] = env._team.obstacle_shapes[0]
            env._bind(self.team, k)
            self.copies[k] = env
            if env.world is not None:
                self._observe(env._ks, self._observations[k : k + 1])
        self.active = np.array(state["active"], dtype=bool)

    # -- reading ---------------------------------------------------------------------
    def infos(self, k: int) -> dict[str, dict[str, Any]]:
        """Copy ``k``'s metrics of every robot (``possible_agents``), with ``success`` (the episode contract)."""
        env = self.copies[k]
        success = bool(env.episode_success())
        return {agent: {**env._schema_info(env._metrics(agent)), "success": success} for agent in self.possible_agents}
