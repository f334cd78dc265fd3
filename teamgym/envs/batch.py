"""``TeamBatch``: K copies of one teamgym env stepped together, arrays in and out (``teamgym.make_batch``).

For RL frameworks that want many env copies per process (SB3 through
:class:`baselines.rl.sb3_env.TeamVecEnv`, RLlib, or a loop of your own). Every env id, action
type and observation format has one. The array API, with ``K`` copies and ``N`` =
``len(possible_agents)`` robot rows per copy (rows follow ``possible_agents``):

* ``reset(seed)``: every copy starts an episode (copy ``k`` with ``seed + k``); returns the observations;
* ``step(actions)``: ``actions`` is ``(K, N, *action_shape)`` (``(K, N)`` for discrete actions;
  a dict of such arrays for a ``Dict`` action space, e.g. with ``comm_dim``); rows of robots
  that are not ``active`` are ignored. Returns observations, rewards, terminations and
  truncations, the last three ``(K, N)`` (zero and ``False`` for rows that were not active);
* ``active``: ``(K, N)`` robots in their episode (they act and are observed);
* ``reset_copy(k, seed)``: a new episode in copy ``k``; its observations ``(N, ...)`` and infos;
* ``infos(k)``: copy ``k``'s infos of every robot in its world (the env's schema, with ``success``);
* ``action_masks()``: ``(K, N, M)`` int8 masks (all ones for inactive rows), or ``None`` without masks.

Observations: ``obs_format="flat"`` gives one ``(K, N, D)`` float32 array (decode its fields
with ``batch.layout``); ``"dict"`` a dict of arrays ``(K, N, *field_shape)`` with the mask
field; ``"masked"`` ``{"observation": (K, N, D), "action_mask": (K, N, M)}``. Rows that are not
active hold zeros, except the one step on which a robot finishes: then its row is its final
observation.

The step itself is the env's own (:mod:`teamgym.envs.step_loop`), run over the group of
copies that have an active robot; a copy steps exactly as a single env with the same seed
and actions would, bit for bit (tests/envs/test_batch.py). A task whose per-step state lives in
arrays over copies (Navigation) computes those phases in one numpy pass for all copies.

``auto_reset=True``: a copy whose robots are all done starts its next episode at the end of
that step, continuing its own random stream (as ``reset()`` without a seed); the returned rows
are the new episode's, and :attr:`final_observations` / :attr:`final_infos` hold the finished
episode's last ones for the copies reset in the step. Without it a finished copy stops stepping
until :meth:`reset_copy`. Copies are real envs (``batch.copies[k]``): read their metrics,
``state()`` and ``episode_success()``; step them through the batch. ``render(k)`` draws copy
``k`` (``render_mode="rgb_array"``); copies record trajectories only with ``trails=True``.
``fixed_agents`` is the PettingZoo face's option; a batch always has fixed rows and ``active``.
A batch, and each of its copies alone, survives ``pickle`` and ``copy.deepcopy`` mid-episode.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from teamgym.envs.base import EpisodeOverError, TeamEnv
from teamgym.envs.config import ConfigError
from teamgym.envs.reset_input import check_seed
from teamgym.envs.spaces import ActionChecker, ActionRowsChecker
from teamgym.envs.step_loop import step_group

__all__ = ["TeamBatch"]

#: Most copies one batch holds (a typo such as 10**9 fails at once instead of exhausting memory).
MAX_COPIES = 1_000_000


def _check_options(n_copies: Any, auto_reset: Any, render_mode: Any, trails: Any) -> None:
    if not isinstance(n_copies, int) or isinstance(n_copies, bool) or not 1 <= n_copies <= MAX_COPIES:
        raise ValueError(f"n_copies must be an integer in [1, {MAX_COPIES}], got {n_copies!r}")
    for name, value in (("auto_reset", auto_reset), ("trails", trails)):
        if not isinstance(value, bool):
            raise TypeError(f"{name} must be True or False, got {value!r}")
    if render_mode not in (None, "rgb_array"):
        raise ValueError(f"a batch renders with render_mode='rgb_array' or None, got {render_mode!r}")


class TeamBatch:
    """``n_copies`` copies of ``env_class`` with one ``config``, stepped with arrays (see the module docstring)."""

    def __init__(
        self,
        env_class: type[TeamEnv],
        n_copies: int,
        config: dict[str, Any] | None = None,
        *,
        auto_reset: bool = False,
        render_mode: str | None = None,
        trails: bool = False,
    ) -> None:
        _check_options(n_copies, auto_reset, render_mode, trails)
        config = dict(config or {})
        config.pop("render_mode", None)
        first = env_class(render_mode=render_mode, **config)
        if first.config.fixed_agents:
            raise ConfigError(
                f"{type(first.config).__name__}: fixed_agents=True is an option of the PettingZoo env; a batch always "
                "reports every robot's row, with `active` flagging the robots in their episode"
            )
        self.env_class = env_class
        self.auto_reset, self.render_mode, self.trails = auto_reset, render_mode, trails
        self._config_kwargs = config
        self.config = first.config
        self.possible_agents: list[str] = list(first.possible_agents)
        self.layout = first.layout
        agent = self.possible_agents[0]
        self.action_space: spaces.Space = first.action_space(agent)
        self.observation_space: spaces.Space = first.observation_space(agent)
        self._row_checker = (
            ActionRowsChecker(self.action_space) if isinstance(self.action_space, (spaces.Box, spaces.Discrete)) else None
        )
        self._checker = ActionChecker(self.action_space)
        self._mask_size = first._mask_size
        n = len(self.possible_agents)
        self.copies: list[TeamEnv] = []
        self._phases = env_class.phases_class(self.copies)
        #: ``(K, N)``: robots in their episode (they act, are stepped and observed).
        self.active = np.zeros((0, n), dtype=bool)
        self._flat = np.zeros((0, n, self.layout.size), dtype=np.float32)
        self._masks = np.ones((0, n, self._mask_size or 0), dtype=np.int8)
        self.final_observations: dict[int, Any] = {}
        self.final_infos: dict[int, dict[str, dict[str, Any]]] = {}
        self._append(first)
        for _ in range(n_copies - 1):
            self.add_copy()

    # -- copies ----------------------------------------------------------------------
    @property
    def n_copies(self) -> int:
        return len(self.copies)

    @property
    def n_robots(self) -> int:
        return len(self.possible_agents)

    def add_copy(self) -> int:
        """Append a copy (not yet reset); returns its index."""
        return self._append(self.env_class(render_mode=self.render_mode, **self._config_kwargs))

    def truncate(self, n_copies: int) -> None:
        """Drop the copies from index ``n_copies`` on (at least one copy stays)."""
        if not isinstance(n_copies, int) or n_copies < 1:
            raise ValueError(f"a batch keeps at least one copy, got n_copies={n_copies!r}")
        for env in self.copies[n_copies:]:
            env.close()
        del self.copies[n_copies:]
        self._resize()

    def _append(self, env: TeamEnv) -> int:
        env.records_trails = self.trails
        self.copies.append(env)
        self._resize()
        return len(self.copies) - 1

    def _resize(self) -> None:
        """Arrays follow the list of copies (kept rows keep their values); the phases regroup the copies."""
        k, n = len(self.copies), self.n_robots

        def fit(array: np.ndarray, fill: int) -> np.ndarray:
            if len(array) >= k:
                return array[:k].copy()
            extra = np.full((k - len(array), *array.shape[1:]), fill, dtype=array.dtype)
            return np.concatenate([array, extra])

        self.active = fit(self.active, 0)
        self._flat = fit(self._flat, 0)
        self._masks = fit(self._masks, 1)
        assert self.active.shape == (k, n)
        self._phases.regroup()

    # -- episodes --------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None) -> Any:
        """Reset every copy (copy ``k`` with ``seed + k``); returns the observations of every copy."""
        seed = check_seed(seed)
        for k in range(self.n_copies):
            self._start(k, None if seed is None else seed + k, options)
        return self._observations(slice(None))

    def reset_copy(self, k: int, seed: int | None = None, options: dict | None = None) -> tuple[Any, dict[str, dict]]:
        """Start a new episode in copy ``k``; returns its observations (rows ``(N, ...)``) and its infos (per agent)."""
        self._check_copy_index(k)
        infos = self._start(k, seed, options)
        return self._observations(k), infos

    def _check_copy_index(self, k: Any) -> None:
        if not isinstance(k, (int, np.integer)) or isinstance(k, bool) or not 0 <= k < self.n_copies:
            raise IndexError(f"copy {k!r} does not exist; the batch has {self.n_copies} copies")

    def _start(self, k: int, seed: int | None, options: dict | None) -> dict[str, dict]:
        env = self.copies[k]
        _, infos = env.reset(seed=seed, options=options)
        self._read_copy(k)
        return infos

    def _read_copy(self, k: int) -> None:
        """Copy ``k``'s active rows, observations and masks from the env (after a reset)."""
        env = self.copies[k]
        self.active[k] = False
        self.active[k, env._live_rows()] = True
        self._phases.observe([k], self._flat)
        self._read_masks([k])

    def episode_over(self) -> np.ndarray:
        """``(K,)``: copies whose robots are all done (or that were never reset)."""
        return ~self.active.any(axis=1)

    # -- stepping --------------------------------------------------------------------
    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray]:
        """One ``step`` of every copy with an active robot (see the module docstring for shapes)."""
        fresh = [k for k, env in enumerate(self.copies) if env.world is None]
        if fresh:
            raise EpisodeOverError(f"TeamBatch.step(): copies {fresh} were never reset; call reset() or reset_copy(k)")
        live = self.active.copy()
        if not live.any():
            raise EpisodeOverError("TeamBatch.step() with no active robot: reset copies first")
        joint, rows = self._check_actions(actions, live)
        group = sorted(joint)
        step_group(self._phases, group, [joint[k] for k in group], rows)
        rewards = np.zeros(live.shape)
        terminated = np.zeros(live.shape, dtype=bool)
        truncated = np.zeros(live.shape, dtype=bool)
        self._phases.end(group, rewards, terminated, truncated)
        self._phases.observe(group, self._flat)
        self._read_masks(group)
        observations = self._observations(slice(None))
        done = terminated | truncated
        names, active, copies = self.possible_agents, self.active, self.copies
        counts = active.sum(axis=1).tolist()
        ended = set(np.flatnonzero(done.any(axis=1)).tolist())
        for k in group:
            env = copies[k]
            if k in ended:
                env._close_step([names[i] for i in np.flatnonzero(done[k]).tolist()])
            if k in ended or len(env.live_agents) != counts[k]:  # robots left or joined
                active[k] = False
                active[k, env._live_rows()] = True
            env._rebase_if_due()
        self.final_observations, self.final_infos = {}, {}
        if self.auto_reset:
            self._auto_reset(group, observations)
        return observations, rewards, terminated, truncated

    def _auto_reset(self, group: list[int], observations: Any) -> None:
        """Copies of ``group`` whose episode ended start their next one (their own random streams)."""
        for k in group:
            if self.active[k].any():
                continue
            self.final_infos[k] = self.infos(k)
            self.final_observations[k] = _rows_of(observations, k)
            self._start(k, None, None)
            _write_rows(observations, k, self._observations(k))

    def _check_actions(self, actions: Any, live: np.ndarray) -> tuple[dict[int, dict[str, Any]], Any]:
        """Every active row's action checked (and its mask) before anything changes; per copy, a joint action dict."""
        rows_k, rows_i = np.nonzero(live)
        names = [self.possible_agents[i] for i in rows_i.tolist()]
        expected = (self.n_copies, self.n_robots)
        if isinstance(self.action_space, spaces.Dict):
            if not isinstance(actions, dict):
                raise TypeError(f"actions for a Dict action space are a dict of arrays, got {type(actions).__name__}")
            for key, value in actions.items():
                if np.shape(value)[:2] != expected:
                    raise ValueError(f"actions[{key!r}] has shape {np.shape(value)}, expected {expected} + the field's shape")
            chosen = [{key: np.asarray(value)[k, i] for key, value in actions.items()} for k, i in zip(rows_k, rows_i)]
            checked = [self._checker.check(name, a) for name, a in zip(names, chosen)]
            arrays = None
        else:
            array = actions if isinstance(actions, np.ndarray) else np.asarray(actions)
            shape = (*expected, *(self.action_space.shape or ()))
            if array.shape != shape:
                raise ValueError(f"actions have shape {array.shape}, expected {shape} (copies, robots, action)")
            picked = array[rows_k, rows_i]
            if self._row_checker is not None:
                arrays = self._row_checker.check(picked, names)
                checked = arrays.tolist() if arrays.ndim == 1 else list(arrays)
            else:
                checked = [self._checker.check(name, a) for name, a in zip(names, picked)]
                arrays = None
        joint: dict[int, dict[str, Any]] = {}
        for k, name, action in zip(rows_k.tolist(), names, checked):
            joint.setdefault(k, {})[name] = action
        if self._mask_size is not None:
            for k, acts in joint.items():
                env = self.copies[k]
                for name, action in acts.items():
                    env._check_admissible(name, action)
        return joint, None if arrays is None else (rows_k, rows_i, arrays)

    # -- reading ---------------------------------------------------------------------
    def _read_masks(self, group: list[int]) -> None:
        if self._mask_size is None:
            return
        row_of = self.copies[0]._row
        for k in group:
            self._masks[k] = 1
            for agent, mask in self.copies[k]._masks.items():
                self._masks[k, row_of[agent]] = mask

    def action_masks(self) -> np.ndarray | None:
        """``(K, N, M)`` int8 action masks (1 = admissible; rows not active: all ones), ``None`` without masks."""
        return None if self._mask_size is None else self._masks.copy()

    def _observations(self, ks: int | slice) -> Any:
        """Observations of copies ``ks`` in ``obs_format`` (copies of the batch's arrays)."""
        flat = self._flat[ks].copy()
        fmt = self.config.obs_format
        if fmt == "flat":
            return flat
        if fmt == "masked":
            return {"observation": flat, "action_mask": self._mask_rows(ks)}
        lead, slices = flat.shape[:-1], self.layout.slices
        fields = {f.name: flat[..., slices[f.name]].reshape(*lead, *f.shape).astype(f.dtype) for f in self.layout.fields}
        if self._mask_size is not None:
            fields[self.copies[0]._mask_field] = self._masks[ks].copy()
        return fields

    def _mask_rows(self, ks: int | slice) -> np.ndarray:
        if self._mask_size is not None:
            return self._masks[ks].copy()
        n = int(self.action_space.n)
        return np.ones((*self._flat[ks].shape[:-1], n), dtype=np.int8)

    def infos(self, k: int) -> dict[str, dict[str, Any]]:
        """Copy ``k``'s infos of every robot in its world (``possible_agents`` order), with ``success``."""
        self._check_copy_index(k)
        env = self.copies[k]
        if env.world is None:
            raise EpisodeOverError(f"TeamBatch.infos({k}): copy {k} was never reset")
        present = [a for a in self.possible_agents if a in env.robots]
        return env._infos_of(present, bool(env.episode_success()))

    def render(self, k: int = 0) -> np.ndarray | None:
        """Copy ``k``'s frame (``render_mode="rgb_array"``), or ``None`` without a render mode."""
        self._check_copy_index(k)
        return self.copies[k].render()

    def close(self) -> None:
        for env in self.copies:
            env.close()

    # -- copying and pickling --------------------------------------------------------
    def __getstate__(self) -> dict:
        """The options, and each copy's own pickled state (its base and the joint actions since)."""
        options = {"auto_reset": self.auto_reset, "render_mode": self.render_mode, "trails": self.trails}
        return {
            "env_class": self.env_class,
            "config": self._config_kwargs,
            "options": options,
            "copies": [env.__getstate__() for env in self.copies],
        }

    def __setstate__(self, state: dict) -> None:
        copies = state["copies"]
        TeamBatch.__init__(self, state["env_class"], len(copies), state["config"], **state["options"])
        for k, copy_state in enumerate(copies):
            env = self.env_class.__new__(self.env_class)
            env.__setstate__(copy_state)  # replays its episode in a state of its own
            env.records_trails = self.trails
            self.copies[k] = env
        self._phases.regroup()
        for k, env in enumerate(self.copies):
            if env.world is not None:
                self._read_copy(k)


def _rows_of(observations: Any, k: int) -> Any:
    if isinstance(observations, dict):
        return {key: value[k].copy() for key, value in observations.items()}
    return observations[k].copy()


def _write_rows(observations: Any, k: int, rows: Any) -> None:
    if isinstance(observations, dict):
        for key, value in observations.items():
            value[k] = rows[key]
    else:
        observations[k] = rows
