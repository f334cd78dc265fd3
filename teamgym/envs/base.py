"""``TeamEnv``: the PettingZoo parallel-env base every teamgym task derives from.

The base owns the episode protocol (seeding, agent bookkeeping, action checking,
truncation, rendering); a task fills in five hooks:

* ``_build(rng)`` creates the :class:`~teamgym.sim.world.World` and its entities;
* ``_command_context(agent)`` gives action types what they need (optional);
* ``_observe(out)`` writes every live agent's observation into a preallocated array;
* ``_evaluate()`` returns rewards and terminations after a step;
* ``_metrics(agent)`` returns the per-agent metrics put into ``infos``.

``_advance(actions)`` (one control step by default) may be overridden by envs whose actions
last several control steps (macro actions).
"""

from __future__ import annotations

import copy
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from teamgym.envs.actions import ActionType, CommandContext
from teamgym.envs.config import EnvConfig
from teamgym.envs.spaces import ObservationLayout, check_action
from teamgym.sim.render import Overlay, Renderer, robot_colour
from teamgym.sim.robot import DiffDriveRobot
from teamgym.sim.world import World


class EpisodeOverError(RuntimeError):
    """``step()`` was called on an env whose episode has ended (or never started)."""


class TeamEnv(ParallelEnv):
    """A multi-robot task on the shared simulator, as a PettingZoo ``ParallelEnv``."""

    metadata: ClassVar[dict[str, Any]] = {
        "name": "teamgym_base",
        "render_modes": ["human", "rgb_array"],
        "render_fps": 10,
        "is_parallelizable": True,
    }
    config_class: ClassVar[type[EnvConfig]] = EnvConfig
    pixels_per_metre: ClassVar[float] = 200.0

    def __init__(self, render_mode: str | None = None, **config: Any) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode={render_mode!r} is not supported; choose one of {self.metadata['render_modes']} or None"
            )
        self.render_mode = render_mode
        self.config = self.config_class.from_kwargs(**config)
        self.possible_agents: list[str] = self._agent_names()
        self.agents: list[str] = []
        self.action_type: ActionType = self._make_action_type()
        self.layout: ObservationLayout = self._make_layout()
        self._observation_spaces = {a: self.layout.space() for a in self.possible_agents}
        self._action_spaces = {a: self.action_type.space() for a in self.possible_agents}
        self.world: World | None = None
        self.robots: dict[str, DiffDriveRobot] = {}
        self.np_random = np.random.default_rng()
        self.cycles = 0
        self._renderer: Renderer | None = None
        self._trails: dict[str, list[tuple[float, float]]] = {}
        self._object_trails: dict[str, list[tuple[float, float]]] = {}
        self._log: list[tuple] = []

    # -- hooks for subclasses --------------------------------------------------------
    def _agent_names(self) -> list[str]:
        raise NotImplementedError

    def _make_action_type(self) -> ActionType:
        raise NotImplementedError

    def _make_layout(self) -> ObservationLayout:
        raise NotImplementedError

    def _build(self, rng: np.random.Generator) -> None:
        """Create ``self.world`` and ``self.robots`` (agent name -> robot) for a new episode."""
        raise NotImplementedError

    def _command_context(self, agent: str) -> CommandContext:
        return CommandContext()

    def _observe(self, out: np.ndarray) -> None:
        """Fill row ``i`` of ``out`` with the observation of ``self.agents[i]``."""
        raise NotImplementedError

    def _evaluate(self) -> tuple[dict[str, float], dict[str, bool]]:
        """Rewards and terminations of the live agents after a step."""
        raise NotImplementedError

    def _metrics(self, agent: str) -> dict[str, Any]:
        return {}

    def episode_success(self) -> bool:
        """Whether the episode has reached the task's goal (the episode contract).

        Every env defines it; ``infos[agent]["success"]`` holds its value after ``reset`` and
        every ``step``, so the evaluation CLI, the SB3 adapter and the experiments read only that.
        """
        raise NotImplementedError(f"{type(self).__name__} must define episode_success()")

    def _before_physics(self) -> None:
        """Called after commands are set and before the world steps (e.g. to draw delays)."""

    def _overlay(self) -> Overlay:
        return Overlay()

    # -- spaces ----------------------------------------------------------------------
    def observation_space(self, agent: str) -> spaces.Space:
        try:
            return self._observation_spaces[agent]
        except KeyError:
            raise KeyError(f"unknown agent {agent!r}; possible agents are {self.possible_agents}") from None

    def action_space(self, agent: str) -> spaces.Space:
        try:
            return self._action_spaces[agent]
        except KeyError:
            raise KeyError(f"unknown agent {agent!r}; possible agents are {self.possible_agents}") from None

    # -- episode protocol ------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None):
        if options is not None and not isinstance(options, dict):
            raise TypeError(f"reset options must be a dict or None, got {type(options).__name__}")
        self._log = [("reset", self.np_random.bit_generator.state, seed, copy.deepcopy(options))]
        if seed is not None:
            self.np_random = np.random.default_rng(seed)
        self.agents = list(self.possible_agents)
        self.cycles = 0
        self._build(self.np_random)
        self._trails = {a: [self.robots[a].position] for a in self.agents}
        self._object_trails = {}
        self._record_object_trails()
        observations = self._collect_observations()
        infos = self._collect_infos()
        if self.render_mode == "human":
            self.render()
        return observations, infos

    def step(self, actions: dict):
        if self.world is None:
            raise EpisodeOverError(f"{type(self).__name__}.step() called before reset()")
        if not self.agents:
            raise EpisodeOverError(
                f"{type(self).__name__}.step() called after the episode ended (all agents are done); call reset()"
            )
        checked = self._check_actions(actions)
        self._log.append(("step", checked))
        self._advance(checked)
        rewards, terminations = self._evaluate()
        truncated = self.cycles >= self.config.max_cycles
        truncations = {a: truncated and not terminations[a] for a in self.agents}
        observations = self._collect_observations()
        infos = self._collect_infos()
        self.agents = [a for a in self.agents if not (terminations[a] or truncations[a])]
        for agent in terminations:
            if terminations[agent] or truncations[agent]:
                self.robots[agent].set_command(0.0, 0.0)
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    def _advance(self, actions: dict) -> None:
        """Apply checked joint actions and advance the world: one control step by default.

        Macro-action envs override this to run several control steps per ``step()`` (their
        ``_evaluate`` then covers the whole stretch); ``self.cycles`` counts control steps.
        """
        action_type, no_context = self.action_type, CommandContext()
        for agent, action in actions.items():
            context = self._command_context(agent) if action_type.needs_context else no_context
            self.robots[agent].set_command(*action_type.command(action, context))
        self._before_physics()
        self.world.step()
        self.cycles += 1
        self._record_trails()

    def _record_trails(self) -> None:
        states = self.world.robot_states
        index = {robot.name: i for i, robot in enumerate(self.world.robots)} if len(states) else {}
        for agent in self.agents:
            row = index.get(agent)
            point = tuple(states[row, :2].tolist()) if row is not None else self.robots[agent].position
            self._trails[agent].append(point)
        self._record_object_trails()

    def _record_object_trails(self) -> None:
        """Append the position of every moving obstacle and box (added ones start a new trail)."""
        world, trails = self.world, self._object_trails
        states = world.mover_states
        if len(states) == len(world.movers):  # batch read after the last step (or at reset)
            points = [tuple(p) for p in states[:, :2].tolist()]
        else:
            points = [m.position for m in world.movers]
        for mover, point in zip(world.movers, points):
            trails.setdefault(mover.name, []).append(point)
        for box in world.boxes:
            trails.setdefault(box.name, []).append(box.position)

    def _check_actions(self, actions: dict) -> dict:
        """Validate every action before anything changes; raise naming the culprit."""
        if not isinstance(actions, dict):
            raise TypeError(f"actions must be a dict from agent name to action, got {type(actions).__name__}")
        unknown = [a for a in actions if a not in self.possible_agents]
        if unknown:
            raise KeyError(f"actions for unknown agent(s) {unknown}; live agents are {self.agents}")
        finished = [a for a in actions if a not in self.agents]
        if finished:
            raise ValueError(f"actions for agent(s) {finished} whose episode is over; live agents are {self.agents}")
        missing = [a for a in self.agents if a not in actions]
        if missing:
            raise ValueError(f"no action for live agent(s) {missing}; every live agent must act each step")
        return {a: check_action(a, actions[a], self._action_spaces[a]) for a in self.agents}

    def _collect_observations(self) -> dict[str, np.ndarray]:
        out = np.zeros((len(self.agents), self.layout.size), dtype=np.float32)
        self._observe(out)
        return {a: out[i] for i, a in enumerate(self.agents)}

    def _collect_infos(self) -> dict[str, dict[str, Any]]:
        success = bool(self.episode_success())
        infos = {a: self._metrics(a) for a in self.agents}
        for info in infos.values():
            info["success"] = success
        return infos

    # -- rendering -------------------------------------------------------------------
    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            return None
        if self.world is None:
            raise EpisodeOverError("render() called before reset()")
        if self._renderer is None or self._renderer.world is not self.world:
            self._renderer = Renderer(self.world, self.pixels_per_metre)
        overlay = self._overlay()
        for i, agent in enumerate(self.possible_agents):
            if agent in self._trails:
                overlay.paths.append((self._trails[agent], robot_colour(i)))
        frame = self._renderer.draw(overlay)
        if self.render_mode == "human":
            self._renderer.show(frame, self.metadata["render_fps"])
            return None
        return frame

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # -- helpers ---------------------------------------------------------------------
    def trajectories(self) -> dict[str, list[tuple[float, float]]]:
        """Positions (m) of every robot at every step of the current episode."""
        return {a: list(points) for a, points in self._trails.items()}

    def object_trajectories(self) -> dict[str, list[tuple[float, float]]]:
        """Positions (m) of every moving obstacle and box at every step it was in the world."""
        return {name: list(points) for name, points in self._object_trails.items()}

    def decode(self, observation: np.ndarray) -> dict[str, np.ndarray]:
        """Named fields of a flat observation (see :class:`ObservationLayout`)."""
        return self.layout.decode(observation)

    # -- copying and pickling ---------------------------------------------------------
    # Chipmunk keeps solver state that pymunk cannot pickle (accumulated joint impulses and
    # cached contacts used for warm starting), so a pickled space continues slightly
    # differently. An env is therefore pickled as its config plus the log of everything
    # that changed it since the last reset (the RNG state and seed of that reset, every
    # checked joint action and every recorded event) and rebuilt by replaying the log: the
    # simulation is deterministic, so the copy continues exactly as the original would.
    # Subclasses route run-time events (adding robots, opening doors...) through
    # :meth:`_record` so that they are replayed too.
    def _record(self, method: str, *args: Any) -> None:
        """Log a call of ``self.<method>(*args)`` made during the episode, for replay."""
        self._log.append(("call", method, copy.deepcopy(args)))

    def __getstate__(self) -> dict:
        return {
            "render_mode": self.render_mode,
            "config": self.config.as_dict(),
            "log": self._log,
            "np_random": self.np_random.bit_generator.state,
            "spaces": (self._observation_spaces, self._action_spaces),
        }

    def __setstate__(self, state: dict) -> None:
        self.__init__(render_mode=None, **state["config"])
        for entry in state["log"]:
            if entry[0] == "reset":
                _, rng_state, seed, options = entry
                self.np_random.bit_generator.state = rng_state
                self.reset(seed=seed, options=options)
            elif entry[0] == "step":
                self.step(entry[1])
            else:
                getattr(self, entry[1])(*entry[2])
        self.np_random.bit_generator.state = state["np_random"]
        self._observation_spaces, self._action_spaces = state["spaces"]
        self.render_mode = state["render_mode"]

    def __deepcopy__(self, memo: dict) -> TeamEnv:
        clone = type(self).__new__(type(self))
        clone.__setstate__(copy.deepcopy(self.__getstate__(), memo))
        memo[id(self)] = clone
        return clone

    def copy(self) -> TeamEnv:
        """An independent copy of the env mid-episode (same as ``copy.deepcopy``)."""
        return copy.deepcopy(self)
