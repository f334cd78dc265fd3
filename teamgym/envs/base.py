"""``TeamEnv``: the PettingZoo parallel-env base every teamgym task derives from.

The base owns the episode protocol (seeding, agent bookkeeping, action checking, the
communication channel, truncation, the episode contract, rendering, copying). A task
implements these hooks:

* ``_agent_names()`` (from the config alone);
* ``_setup()`` once, after the config is parsed and the agents are named (build what depends
  only on the config: robot specs, sensors, maps), then ``_make_action_type()`` and ``_make_layout()``;
* ``_build(rng)``: a new episode's :class:`~teamgym.sim.world.World`, robots and initial readings
  (``self.reset_options`` holds the ``options`` given to ``reset``, as ``_check_reset_options``
  returned them; messages sent here are delivered before the first observation);
* ``_observe(out)``: every live agent's flat observation into a preallocated array (the base
  then saturates it at the layout's finite bounds, :meth:`ObservationLayout.clip`);
* ``episode_success()``: the episode contract;

and may declare ``reset_option_keys`` with ``_check_reset_options(options)`` (validate every
option before the reset changes anything), and override the step phases, which :meth:`TeamEnv.step` runs in this order:

1. **control**: ``action_type.start`` once, then per control step ``action_type.act`` for
   every acting agent and ``_before_physics()``;
2. **physics**: the world steps Δt, trails are recorded;
3. **state**: ``_update_state()`` reads the world into the task's state (positions, contacts, progress);
4. **events**: ``_apply_events()`` (scheduled run-time changes: robots or boxes added, removed);
5. **goals**: ``_check_goals()`` (arrivals, deliveries, exploration complete);
6. **rewards**: ``_accumulate_rewards(total)`` adds this control step's rewards (macro actions sum them);
7. **sensing**: ``_sense()`` reads the robots' sensors;

   phases 1–7 repeat while a macro action type says its stage goes on;
8. **communication**: the channel delivers this step's messages;
9. **agents**: robots admitted by events join; ``_terminations()`` decides who ends;
   ``_metrics(agent)`` (through ``_metrics_of``) fills ``infos``; finished agents leave ``live_agents``.

Task code reads ``self.live_agents`` (the robots in the episode now). ``agents``, PettingZoo's
list, is the same list unless ``fixed_agents=True`` (:mod:`teamgym.envs.fixed_agents`): then it
holds every possible agent until the team's episode ends.
"""

from __future__ import annotations

import copy
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from teamgym.envs.actions import ActionType, UnitScaled, WithMessage
from teamgym.envs.config import ConfigError, EnvConfig
from teamgym.envs.fixed_agents import PRESENT, PRESENT_INFO, FixedRoster
from teamgym.envs.infos import COUNT, InfoKey, metrics
from teamgym.envs.reset_input import check_option_keys, check_seed
from teamgym.envs.spaces import ActionChecker, Field, ObservationLayout
from teamgym.envs.step_loop import CopyPhases, StepOutcome, step_group
from teamgym.envs.trails import TrailArchive
from teamgym.sim import snapshot
from teamgym.sim.channel import Channel, ChannelConfig
from teamgym.sim.render import Overlay, Renderer, robot_colour
from teamgym.sim.robot import DiffDriveRobot
from teamgym.sim.world import FixedRecord, World

if TYPE_CHECKING:
    from teamgym.envs.batch import TeamBatch

#: Outcome of ``_check_feasible`` per (env class, config): None or the error message.
_FEASIBILITY: dict[tuple[type, EnvConfig], str | None] = {}


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
    #: Whether the env sends messages of its own through ``self.channel`` (then the channel's
    #: counters are in ``infos`` from the first reset on, as they are whenever ``comm_dim > 0``).
    uses_channel: ClassVar[bool] = False
    #: Observation fields the base adds when ``comm_dim > 0``; a task may not use these names.
    INBOX_FIELDS: ClassVar[tuple[str, ...]] = ("inbox", "inbox_sender", "inbox_mask")
    pixels_per_metre: ClassVar[float] = 200.0
    #: Keys ``reset(options=...)`` accepts (checked by ``_check_reset_options``); others are refused.
    reset_option_keys: ClassVar[tuple[str, ...]] = ()
    #: The control-step phases over a group of copies (:mod:`teamgym.envs.step_loop`); a task
    #: whose per-step state is in arrays over copies gives its own, one numpy pass per group.
    phases_class: ClassVar[type[CopyPhases]] = CopyPhases

    def __init__(self, render_mode: str | None = None, **config: Any) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode={render_mode!r} is not supported; choose one of {self.metadata['render_modes']} or None"
            )
        self.render_mode = render_mode
        self.config = self.config_class.from_kwargs(**config)
        self._roster: FixedRoster | None = None
        self.possible_agents: list[str] = self._agent_names()
        self.live_agents: list[str] = []
        self._row = {a: i for i, a in enumerate(self.possible_agents)}
        self._live_names: list[str] | None = None
        self._live_array = np.zeros(0, dtype=int)
        self._setup()
        self._ensure_feasible()
        c = self.config
        action_type = self._make_action_type()
        if c.normalize_actions:
            try:
                action_type = UnitScaled(action_type)
            except TypeError as error:
                raise ConfigError(f"{type(self.config).__name__}: normalize_actions=True is invalid; {error}") from None
        self.action_type: ActionType = WithMessage(action_type, c.comm_dim) if c.comm_dim else action_type
        self.layout: ObservationLayout = self._make_layout()
        owners = {**dict.fromkeys(self.INBOX_FIELDS, "the message inbox"), PRESENT.name: "fixed_agents"}
        reserved = {f.name: owners[f.name] for f in self.layout.fields if f.name in owners}
        if reserved:
            uses = " and ".join(sorted(set(reserved.values())))
            raise ValueError(f"{type(self).__name__}: observation field name(s) {list(reserved)} are reserved for {uses}")
        if c.comm_dim:
            self.layout = self.layout.extended(self._inbox_fields())
        if c.fixed_agents:
            self.layout = self.layout.extended([PRESENT])
        self.channel = Channel(self.possible_agents, self._channel_config())
        self._action_spaces = {a: self.action_type.space() for a in self.possible_agents}
        self._mask_size = self._action_mask_size()
        self._observation_spaces = {a: self._observation_space() for a in self.possible_agents}
        self._info_schema = self._full_info_schema()
        self._info_template = {key: spec.missing for key, spec in self._info_schema.items()}
        self._checkers = {a: ActionChecker(space) for a, space in self._action_spaces.items()}
        if c.fixed_agents:
            self._roster = FixedRoster(self)
        self._masks: dict[str, np.ndarray] = {}
        self._reward_total = np.zeros(len(self.possible_agents))
        self._joining: list[str] = []
        self.world: World | None = None
        self.robots: dict[str, DiffDriveRobot] = {}
        self.np_random = np.random.default_rng()
        self.cycles = 0
        self._renderer: Renderer | None = None
        self._trails: dict[str, list[tuple[float, float]]] = {}
        self._object_trails: dict[str, list[tuple[float, float]]] = {}
        self._log: list[tuple] = []
        #: Whether steps append to ``trajectories()`` (a batch's copies may skip it).
        self.records_trails = True

    # -- hooks for subclasses --------------------------------------------------------
    def _setup(self) -> None:
        """Build once what depends only on ``self.config`` (robot specs, sensors, maps)."""

    def _check_reset_options(self, options: dict) -> dict:
        """Validate the ``reset`` options (keys already in ``reset_option_keys``) before anything changes.

        Returns them as ``_build`` reads them from ``self.reset_options``; raise naming the key.
        """
        return options

    def _check_feasible(self) -> None:
        """Raise :class:`ConfigError` if episodes of this config cannot be built (e.g. sample scenes)."""

    def _ensure_feasible(self) -> None:
        """:meth:`_check_feasible` once per config and process (``make()`` fails fast on unbuildable configs)."""
        key = (type(self), self.config)
        try:
            hash(key)
        except TypeError:  # a config holding a list: check without the cache
            self._check_feasible()
            return
        if key not in _FEASIBILITY:
            if len(_FEASIBILITY) > 256:
                _FEASIBILITY.clear()
            try:
                self._check_feasible()
                _FEASIBILITY[key] = None
            except ConfigError as error:
                _FEASIBILITY[key] = str(error)
        if _FEASIBILITY[key] is not None:
            raise ConfigError(_FEASIBILITY[key])

    def _agent_names(self) -> list[str]:
        raise NotImplementedError

    def _make_action_type(self) -> ActionType:
        raise NotImplementedError

    def _make_layout(self) -> ObservationLayout:
        raise NotImplementedError

    def _build(self, rng: np.random.Generator) -> None:
        """Create ``self.world`` and ``self.robots`` (agent name -> robot) for a new episode."""
        raise NotImplementedError

    def _observe(self, out: np.ndarray) -> None:
        """Fill row ``i`` of ``out`` with the flat observation of ``self.live_agents[i]``."""
        raise NotImplementedError

    def episode_success(self) -> bool:
        """Whether the episode has reached the task's goal (the episode contract).

        Every env defines it; ``infos[agent]["success"]`` holds its value after ``reset`` and
        every ``step``, so the evaluation CLI, the SB3 adapter and the experiments read only that.
        """
        raise NotImplementedError(f"{type(self).__name__} must define episode_success()")

    def _metrics(self, agent: str) -> dict[str, Any]:
        """Numbers and arrays only (no strings) for ``infos[agent]``; keys from :meth:`_info_keys` only."""
        return {}

    def _info_keys(self) -> dict[str, InfoKey]:
        """The task's keys of ``infos[agent]`` (from the config alone), each with its kind and its value until known."""
        return {}

    def _metrics_of(self, agents: list[str]) -> dict[str, dict[str, Any]]:
        """:meth:`_metrics` of each of ``agents``; a task overrides it to compute team-wide values once per step."""
        return {a: self._metrics(a) for a in agents}

    # Step phases (see the module docstring); the defaults do nothing.
    def _before_physics(self) -> None:
        """Control phase, after the commands are set and before the world steps (e.g. actuation delays)."""

    def _update_state(self) -> None:
        """State phase: read the world into the task's state after a control step."""

    def _apply_events(self) -> None:
        """Events phase: scheduled run-time changes; robots added here join via :meth:`_admit`."""

    def _check_goals(self) -> None:
        """Goals phase: arrivals, deliveries, completion."""

    def _accumulate_rewards(self, total: np.ndarray) -> None:
        """Rewards phase: add this control step's reward of each agent to ``total[row]`` (rows: ``possible_agents``)."""

    def _sense(self) -> None:
        """Sensing phase: read the sensors of the robots that go on."""

    def _terminations(self) -> dict[str, bool]:
        """Agents phase: which live agents end now (every agent in ``self.live_agents``)."""
        return dict.fromkeys(self.live_agents, False)

    def _overlay(self) -> Overlay:
        return Overlay()

    def make_batch(self, n_copies: int, **options: Any) -> TeamBatch:
        """``n_copies`` copies of this env's config stepped together with arrays (:class:`~teamgym.envs.batch.TeamBatch`).

        ``options`` are the batch's own (``auto_reset``, ``render_mode``, ``trails``).
        """
        from teamgym.envs.batch import TeamBatch

        return TeamBatch(type(self), n_copies, config=self.config.as_dict(), **options)

    def _admit(self, agent: str) -> None:
        """Let ``agent`` (a new robot) join ``agents`` at the end of the current step."""
        self._joining.append(agent)

    # -- spaces ----------------------------------------------------------------------
    def _action_mask_size(self) -> int | None:
        """Length of an action mask (the masked part of the action space), or None without masks."""
        if not self.action_type.has_masks:
            return None
        return int(self.action_type.masked_space(self._action_spaces[self.possible_agents[0]]).n)

    def _observation_space(self) -> spaces.Space:
        """The space of one agent's observation in ``obs_format`` (masks added where the action type has them)."""
        fmt, layout, n = self.config.obs_format, self.layout, self._mask_size
        if fmt == "flat":
            return layout.flat_space()
        mask = None if n is None else spaces.Box(0, 1, shape=(n,), dtype=np.int8)
        if fmt == "dict":
            space = layout.dict_space()
            return space if mask is None else spaces.Dict({**space.spaces, self._mask_field: mask})
        action_space = self._action_spaces[self.possible_agents[0]]
        if not isinstance(action_space, spaces.Discrete):
            raise ConfigError(
                f"{type(self.config).__name__}: obs_format='masked' needs a discrete action space; action_type="
                f"{self.action_type.name!r} (comm_dim={self.config.comm_dim}) gives {action_space} (use 'flat' or 'dict')"
            )
        if mask is None:  # a discrete action type without masks: every action is always admissible
            mask = spaces.Box(0, 1, shape=(int(action_space.n),), dtype=np.int8)
        return spaces.Dict({"observation": layout.flat_space(), "action_mask": mask})

    @property
    def _mask_field(self) -> str:
        """Name of the mask in a dict observation: ``action_mask`` (PettingZoo's, for a discrete action space)
        or ``motion_mask`` (the mask of ``action["motion"]`` when a learned message makes the action a Dict)."""
        return "action_mask" if isinstance(self._action_spaces[self.possible_agents[0]], spaces.Discrete) else "motion_mask"

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
    @property
    def agents(self) -> list[str]:
        """PettingZoo's agents: ``live_agents``, or with ``fixed_agents=True`` every possible agent until the team ends."""
        return self.live_agents if self._roster is None else self._roster.agents

    def reset(self, seed: int | None = None, options: dict | None = None):
        seed = check_seed(seed)
        checked = self._check_reset_options(check_option_keys(type(self).__name__, options, self.reset_option_keys))
        self._log = [("reset", self.np_random.bit_generator.state, seed, copy.deepcopy(options))]
        if seed is not None:
            self.np_random = np.random.default_rng(seed)
        self.live_agents = list(self.possible_agents)
        self.cycles = 0
        self._joining = []
        self.reset_options: dict = checked
        self.channel.reset()
        self._build(self.np_random)
        self._deliver_messages()
        self._trails = {a: [self.robots[a].position] for a in self.live_agents}
        self._object_trails = {}
        self._record_object_trails()
        if self._roster is not None:
            self._roster.reset()
        self._refresh_masks()
        observations = self._collect_observations()
        infos = self._collect_infos()
        if self.render_mode == "human":
            self.render()
        return observations, infos

    def step(self, actions: dict):
        if self.world is None:
            raise EpisodeOverError(f"{type(self).__name__}.step() called before reset()")
        if not self.live_agents:
            raise EpisodeOverError(
                f"{type(self).__name__}.step() called after the episode ended (all agents are done); call reset()"
            )
        checked = self._check_actions(actions)
        step_group(self._own_phases(), [0], [checked])
        rewards, terminations, truncations = self._end_step()
        observations = self._collect_observations()
        infos = self._collect_infos()
        self._close_step([a for a in self.live_agents if terminations[a] or truncations[a]])
        if self._roster is not None:
            rewards, terminations, truncations = self._roster.step(self, rewards, terminations, truncations)
        self._rebase_if_due()
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    def _own_phases(self) -> CopyPhases:
        """The step phases over this env alone (:mod:`teamgym.envs.step_loop`), made once."""
        phases = self.__dict__.get("_phases")
        if phases is None:
            phases = self._phases = self.phases_class([self])
        return phases

    def _stage_goes_on(self) -> bool:
        """After a control step: whether this ``step`` runs another (a macro action type's stage goes on)."""
        return self.action_type.is_macro and not self.action_type.stage_over(self) and self.cycles < self.config.cycle_limit

    def _end_step(self) -> StepOutcome:
        """End of a step: messages, joining robots, terminations, truncations, masks (agents leave in :meth:`_close_step`)."""
        total, row = self._reward_total, self._row
        rewards = {a: float(total[row[a]]) for a in self.live_agents}
        joined, terminations, truncated = self._end_phase()
        for agent in joined:
            rewards[agent] = 0.0
        truncations = {a: truncated and not terminations[a] for a in self.live_agents}
        return rewards, terminations, truncations

    def _end_phase(self) -> tuple[list[str], dict[str, bool], bool]:
        """The end phase's work (a lone env's :meth:`_end_step` and a batch's ``CopyPhases.end`` around it): deliver
        messages, admit joining robots (their reward this step is 0), decide terminations, refresh masks.

        Returns the robots that joined, the terminations of every live robot and whether the cycle limit is reached.
        """
        self._deliver_messages()
        joined = self._joining
        for agent in joined:
            self.live_agents.append(agent)
            if self.records_trails:
                self._trails[agent] = [self.robots[agent].position]
        self._joining = []
        terminations = self._terminations()
        truncated = self.cycles >= self.config.cycle_limit
        self._refresh_masks()
        return joined, terminations, truncated

    def _close_step(self, finished: list[str]) -> None:
        """The ``finished`` agents leave ``live_agents`` and their robots stop (after observations and infos were read)."""
        if not finished:
            return
        self.live_agents = [a for a in self.live_agents if a not in finished]
        for agent in finished:
            self.robots[agent].set_command(0.0, 0.0)

    def _record_trails(self) -> None:
        points = self.world.robot_states[:, :2].tolist()
        rows, trails = self.world.robot_rows if points else {}, self._trails
        for agent in self.live_agents:
            row = rows.get(agent)
            point = tuple(points[row]) if row is not None else self.robots[agent].position
            trails.setdefault(agent, []).append(point)  # a robot that joined a batch's copy (no trails) starts one
        self._record_object_trails()

    def _record_object_trails(self) -> None:
        """Append the position of every tracked entity that is not an agent's robot (added ones start a new trail)."""
        trails, agents = self._object_trails, self._row
        for entity in self.world.tracked():
            if entity.name not in agents:
                trails.setdefault(entity.name, []).append(entity.position)

    def _live_rows(self) -> np.ndarray:
        """Rows (``possible_agents`` order) of the agents in ``agents``, rebuilt only when ``agents`` changes.

        The array is shared between calls and read-only: index with it, do not write to it.
        """
        if self._live_names != self.live_agents:
            self._live_names = list(self.live_agents)
            self._live_array = np.array([self._row[a] for a in self.live_agents], dtype=int)
            self._live_array.flags.writeable = False
        return self._live_array

    def _check_actions(self, actions: dict) -> dict:
        """Validate every action before anything changes; raise naming the culprit."""
        if not isinstance(actions, dict):
            raise TypeError(f"actions must be a dict from agent name to action, got {type(actions).__name__}")
        if self._roster is not None:
            actions = self._roster.live_actions(self, actions)
        checkers, live = self._checkers, self.live_agents
        if len(actions) == len(live) and all(a in actions for a in live):  # the usual case: exactly the live agents
            checked = {a: checkers[a].check(a, actions[a]) for a in live}
        else:
            checked = self._check_agent_names(actions)
        if self._masks:
            for agent, action in checked.items():
                self._check_admissible(agent, action)
        return checked

    def _check_agent_names(self, actions: dict) -> dict:
        """The slow path of :meth:`_check_actions`: raise naming unknown, finished or missing agents."""
        unknown = [a for a in actions if a not in self._row]
        if unknown:
            raise KeyError(f"actions for unknown agent(s) {unknown}; live agents are {self.live_agents}")
        finished = [a for a in actions if a not in self.live_agents]
        if finished:
            raise ValueError(f"actions for agent(s) {finished} whose episode is over; live agents are {self.live_agents}")
        missing = [a for a in self.live_agents if a not in actions]
        if missing:
            raise ValueError(f"no action for live agent(s) {missing}; every live agent must act each step")
        checkers = self._checkers
        return {a: checkers[a].check(a, actions[a]) for a in self.live_agents}

    def _check_admissible(self, agent: str, action: Any) -> None:
        mask = self._masks.get(agent)
        index = self.action_type.mask_index(action)
        if mask is not None and not mask[index]:
            describe = self.action_type.describe
            allowed = np.flatnonzero(mask)
            admissible = ", ".join(describe(int(k)) for k in allowed[:8])
            if len(allowed) > 8:
                admissible += f" and {len(allowed) - 8} more"
            raise ValueError(
                f"action {describe(index)} for {agent!r} is masked (not admissible in this state); admissible now: [{admissible}]"
            )

    # -- masks and communication -------------------------------------------------------
    def _refresh_masks(self) -> None:
        """Ask the action type for every live agent's mask (kept for checks, infos and ``action_masks``)."""
        masks: dict[str, np.ndarray] = {}
        if not self.action_type.has_masks:
            self._masks = masks
            return
        for agent in self.live_agents:
            mask = self.action_type.mask(self, agent)
            if mask is not None:
                masks[agent] = mask
                live = getattr(self.action_type.masked_space(self._action_spaces[agent]), "live_mask", None)
                if live is not None:
                    live[:] = mask
        self._masks = masks

    def action_mask(self, agent: str) -> np.ndarray:
        """``agent``'s current action mask (int8, 1 = admissible); raises if its action type has none.

        With ``fixed_agents=True`` an agent in ``agents`` that is not live gets an all-admissible mask.
        """
        if agent not in self._row:
            raise KeyError(f"unknown agent {agent!r}; possible agents are {self.possible_agents}")
        if self.world is None:
            raise EpisodeOverError("action_mask() called before reset()")
        if self._mask_size is not None and agent not in self.live_agents and agent in self.agents:
            return self._all_admissible()
        if agent not in self._masks:
            raise ValueError(f"no action mask for {agent!r}: action type {self.action_type.name!r} has none or the agent is done")
        return self._masks[agent].copy()

    def action_masks(self) -> dict[str, np.ndarray]:
        """Masks of the live agents (none without masks); with ``fixed_agents=True`` of every agent in ``agents``."""
        masks = {a: m.copy() for a, m in self._masks.items() if a in self.live_agents}
        if self._roster is None or self._mask_size is None:
            return masks
        return {a: masks[a] if a in masks else self._all_admissible() for a in self.agents}

    def _all_admissible(self) -> np.ndarray:
        """A mask admitting every action (int8): what an absent agent observes with ``fixed_agents=True``."""
        return np.ones(self._mask_size, dtype=np.int8)

    def _channel_config(self) -> ChannelConfig:
        c = self.config
        return ChannelConfig(
            comm_range=np.inf if c.comm_range is None else c.comm_range,
            throughput=c.comm_throughput,
            latency=c.comm_latency,
            byte_budget=np.inf if c.comm_byte_budget is None else c.comm_byte_budget,
            inbox_size=max(64, 4 * len(self.possible_agents)),
        )

    def _inbox_fields(self) -> list[Field]:
        """Observation fields of the learned-message inbox: one row per possible sender."""
        capacity, n = max(1, len(self.possible_agents) - 1), len(self.possible_agents)
        return [
            Field("inbox", (capacity, self.config.comm_dim), -1.0, 1.0),
            Field("inbox_sender", (capacity,), -1, n - 1, np.int32),
            Field("inbox_mask", (capacity,), 0, 1, np.int8),
        ]

    def _deliver_messages(self) -> None:
        """Communication phase: deliver what was sent this step to the robots in range."""
        if not self.channel.busy:
            return
        positions = {a: robot.position for a, robot in self.robots.items() if robot.space is not None}
        self.channel.deliver(positions, self.np_random, self.cycles)

    def _observe_inbox(self, out: np.ndarray) -> None:
        if not self.config.comm_dim:
            return
        layout, capacity = self.layout, self.layout.shapes["inbox_mask"][0]
        for row, agent in enumerate(self.live_agents):
            packed = self.channel.inbox_array(agent, self.config.comm_dim, capacity, kind="learned")
            layout.view(out[row], "inbox")[:] = packed.payload
            layout.view(out[row], "inbox_sender")[:] = packed.sender
            layout.view(out[row], "inbox_mask")[:] = packed.mask

    def _observation_rows(self) -> np.ndarray:
        """``(len(live_agents), D)`` flat observations of the live agents, inbox included, saturated at the bounds."""
        out = np.zeros((len(self.live_agents), self.layout.size), dtype=np.float32)
        self._observe(out)
        self._observe_inbox(out)
        self.layout.clip(out)
        return out

    def _collect_observations(self) -> dict[str, np.ndarray | dict[str, np.ndarray]]:
        out = self._observation_rows()
        rows = dict(zip(self.live_agents, out))
        if self._roster is not None:
            out[:, self.layout.slices[PRESENT.name]] = 1.0
            rows = self._roster.observations(rows)
        fmt = self.config.obs_format
        if fmt == "flat":
            return rows
        if fmt == "masked":
            return {a: {"observation": row, "action_mask": self._observed_mask(a)} for a, row in rows.items()}
        to_dict = self.layout.to_dict
        observations = {a: to_dict(row) for a, row in rows.items()}
        if self._mask_size is not None:
            field = self._mask_field
            for agent, observation in observations.items():
                observation[field] = self._observed_mask(agent)
        return observations

    def _observed_mask(self, agent: str) -> np.ndarray:
        """``agent``'s action mask as an observation field (int8; all admissible if it has none or is absent)."""
        mask = self._masks.get(agent)
        if mask is None:
            field = "action_mask" if self.config.obs_format == "masked" else self._mask_field
            return np.ones(self._observation_spaces[agent][field].shape, dtype=np.int8)
        return np.asarray(mask, dtype=np.int8).copy()

    # -- infos -----------------------------------------------------------------------
    def _full_info_schema(self) -> dict[str, InfoKey]:
        schema = {"success": COUNT, **self._info_keys()}
        if self._mask_size is not None:
            schema["action_mask"] = InfoKey("mask", None, sentinel=False)
        if self.config.comm_dim or self.uses_channel:
            schema.update(metrics(*Channel.stat_keys()))
        if self.config.fixed_agents:
            schema[PRESENT.name] = PRESENT_INFO
        return schema

    def info_schema(self) -> dict[str, InfoKey]:
        """Every key of ``infos[agent]`` (present from reset on, in every agent's dict), its kind and its value until known.

        Times not known yet and categorical indices hold -1 (:mod:`teamgym.envs.infos`);
        summaries average metrics only, over the values that are known.
        """
        return dict(self._info_schema)

    def _schema_info(self, task_metrics: dict[str, Any]) -> dict[str, Any]:
        """One agent's infos: every schema key at its value until known, updated with the task's ``task_metrics``."""
        info = self._info_template.copy()
        info.update(task_metrics)
        return info

    def _collect_infos(self) -> dict[str, dict[str, Any]]:
        success = bool(self.episode_success())
        infos = self._infos_of(self.live_agents, success)
        return infos if self._roster is None else self._roster.infos(self, infos, success)

    def _infos_of(self, agents: list[str], success: bool) -> dict[str, dict[str, Any]]:
        """The infos of ``agents`` (robots in the world) now: schema keys, metrics, ``success``, masks, channel counters."""
        template = self._info_template
        comm = bool(self.config.comm_dim) or self.uses_channel
        infos = {}
        for agent, task_metrics in self._metrics_of(agents).items():
            info = self._schema_info(task_metrics)
            info["success"] = success
            if agent in self._masks:
                info["action_mask"] = self.action_type.info_mask(self._masks[agent].copy())
            if comm:
                info.update(self.channel.stats(agent))
            if len(info) != len(template):
                extra = sorted(set(info) - set(template))
                raise RuntimeError(f"{type(self).__name__}: infos key(s) {extra} are not in the env's info schema (_info_keys)")
            infos[agent] = info
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

    def decode(self, observation: np.ndarray | dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Named fields of an observation, flat or dict (see :class:`ObservationLayout`)."""
        return self.layout.decode(observation)

    # -- copying and pickling ---------------------------------------------------------
    # Chipmunk keeps state no pickle restores exactly (the history of its broad phase: the
    # order in which it reports colliding pairs), so an env is pickled as its config plus a
    # log and rebuilt by replaying the log: the simulation is deterministic, so the copy
    # continues exactly as the original would. The log starts at a *base*: the reset (its RNG
    # state, seed and options) or a snapshot. At the first step boundary after
    # ``rebase_cycles`` control cycles since the last base, the env pickles its episode state
    # (world, robots, sensors, RNG, counters; :mod:`teamgym.sim.snapshot`) and replaces its
    # own live state by the unpickled snapshot, so that from then on it is itself a restored
    # copy, and the log starts again at that snapshot. A copy unpickles the snapshot and
    # replays the steps since (fewer than ``rebase_cycles`` cycles plus one step), so copies
    # cost about the same at any episode length, and the worlds of original and copy are
    # built from the same bytes by the same procedure. After its base the log holds every
    # checked joint action and every recorded event: subclasses route run-time events (adding
    # robots, opening doors...) through :meth:`_record` so that they are replayed too. Trails
    # (positions per cycle) are history, not state: snapshots leave them out, copies get them
    # as they are (packed for pickling by :class:`~teamgym.envs.trails.TrailArchive`).
    #: Control cycles between re-bases (see above): a task sets it so that replaying that many
    #: cycles stays well under 0.5 s. Copies re-base where the original does.
    rebase_cycles: int = 300
    #: What a re-base leaves alone: the config and the objects ``__init__`` derives from it that
    #: callers hold (spaces, checkers), the renderer, the log and the trails.
    _KEPT_ON_REBASE: ClassVar[frozenset[str]] = frozenset(
        {"render_mode", "config", "possible_agents", "layout", "_checkers", "_observation_spaces", "_action_spaces"}
        | {"_renderer", "_log", "_trails", "_object_trails", "_trail_archives", "_phases"}
    )

    def _record(self, method: str, *args: Any) -> None:
        """Log a call of ``self.<method>(*args)`` made during the episode, for replay."""
        self._log.append(("call", method, copy.deepcopy(args)))

    def _episode_state(self) -> dict[str, Any]:
        """The attributes a snapshot holds (all but :attr:`_KEPT_ON_REBASE`); a task may swap some for what rebuilds them."""
        return {k: v for k, v in self.__dict__.items() if k not in self._KEPT_ON_REBASE}

    def _adopt_episode_state(self, state: dict[str, Any]) -> None:
        """Take the attributes of an unpickled snapshot as this env's own (the inverse of :meth:`_episode_state`).

        The attributes are set again one by one on an emptied ``__dict__``: CPython 3.11 reads
        the attributes of an object whose ``__dict__`` was read or written about 2.5 times slower.
        """
        attributes = {**self.__dict__, **state}
        del self.__dict__
        for name, value in attributes.items():
            object.__setattr__(self, name, value)
        if self._renderer is not None:
            self._renderer.world = self.world

    def _cycles_since_base(self) -> int:
        first = self._log[0] if self._log else None
        return self.cycles - (first[2] if first is not None and first[0] == "base" else 0)

    def _rebase_if_due(self) -> None:
        """At a step boundary: re-base once ``rebase_cycles`` control cycles have passed since the last base.

        Not once the episode is over (no agent left): no step follows, and the snapshot would
        cost its 1–4 ms for nothing (Navigation-v0's episodes end exactly at its ``rebase_cycles``).
        """
        if self.live_agents and self._cycles_since_base() >= self.rebase_cycles:
            self._rebase()

    def _rebase(self) -> None:
        """Snapshot the episode state, replace the live state by the unpickled snapshot and start the log there.

        The world's fixed entities (walls, furniture) are referred to, not pickled: the live ones
        move into the restored world, and a copy gets fresh ones (:class:`~teamgym.sim.world.FixedRecord`).
        """
        world = self.world
        fixed = world.fixed_record()
        data = snapshot.dumps(self._episode_state(), external=[self, *fixed.objects])
        world.release_fixed()
        self._adopt_episode_state(snapshot.loads(data, external=[self, *fixed.objects]))
        self.world.adopt_fixed(fixed)
        self._log = [("base", data, self.cycles, fixed)]

    def _restore_base(self, data: bytes, fixed: FixedRecord) -> None:
        """Take the state of a snapshot :meth:`_rebase` logged (where a copy starts)."""
        fresh = fixed.fresh()
        self._adopt_episode_state(snapshot.loads(data, external=[self, *fresh.objects]))
        self.world.adopt_fixed(fresh)

    def _pack_trails(self) -> tuple[dict, dict]:
        archives = getattr(self, "_trail_archives", None)
        if archives is None:
            archives = self._trail_archives = (TrailArchive(), TrailArchive())
        return archives[0].pack(self._trails), archives[1].pack(self._object_trails)

    def _copy_state(self) -> dict:
        return {
            "render_mode": self.render_mode,
            "config": self.config.as_dict(),
            "log": self._log,
            "np_random": self.np_random.bit_generator.state,
            "spaces": (self._observation_spaces, self._action_spaces),
            "rebase_cycles": self.rebase_cycles,
        }

    def _rebuild(self, state: dict, trails: tuple[dict, dict] | None, archives: tuple[TrailArchive, TrailArchive] | None) -> None:
        """Make this (new) env the copy ``state`` describes: config, base, replayed log; then its trails.

        ``trails`` None (a pickle of a release without re-bases, whose log starts at the reset):
        the replay records them.
        """
        self.__init__(render_mode=None, **state["config"])
        if state.get("rebase_cycles", self.rebase_cycles) != self.rebase_cycles:
            self.rebase_cycles = state["rebase_cycles"]
        for entry in state["log"]:
            if entry[0] == "reset":
                _, rng_state, seed, options = entry
                self.np_random.bit_generator.state = rng_state
                self.reset(seed=seed, options=options)
            elif entry[0] == "base":
                self._restore_base(entry[1], entry[3])
                self._log = [entry]
                self._trails = {name: [] for name in trails[0]}  # replaced below by the original's
            elif entry[0] == "step":
                self.step(entry[1])
            else:
                getattr(self, entry[1])(*entry[2])
        if trails is not None:
            self._trails, self._object_trails = trails
            self._trail_archives = archives
        self.np_random.bit_generator.state = state["np_random"]
        self._observation_spaces, self._action_spaces = state["spaces"]
        self.render_mode = state["render_mode"]

    def __getstate__(self) -> dict:
        return {**self._copy_state(), "trails": self._pack_trails()}

    def __setstate__(self, state: dict) -> None:
        if "trails" not in state:  # pickled by a release without re-bases
            self._rebuild(state, None, None)
            return
        (trails, robot_archive), (object_trails, object_archive) = (TrailArchive.unpack(t) for t in state["trails"])
        self._rebuild(state, (trails, object_trails), (robot_archive, object_archive))

    def __deepcopy__(self, memo: dict) -> TeamEnv:
        clone = type(self).__new__(type(self))
        archives = getattr(self, "_trail_archives", None) or (TrailArchive(), TrailArchive())
        (trails, robot_archive), (object_trails, object_archive) = (
            archive.copied(t) for archive, t in zip(archives, (self._trails, self._object_trails))
        )
        clone._rebuild(copy.deepcopy(self._copy_state(), memo), (trails, object_trails), (robot_archive, object_archive))
        memo[id(self)] = clone
        return clone

    def copy(self) -> TeamEnv:
        """An independent copy of the env mid-episode (same as ``copy.deepcopy``)."""
        return copy.deepcopy(self)
