"""One seeded episode of a policy on an env: :func:`run_episode` and its :class:`EpisodeResult`.

Every episode loop of the package (the evaluation CLI, the experiments of ``experiments/``)
is this one. The env is reset with ``seed``, then the policy with ``policy.reset(seed)``;
while agents are live, the policy gets the live agents' observations and the last infos and
the env steps. Success is the episode contract's: ``infos[agent]["success"]`` of the last
step (every agent of one step holds the same value; see :func:`success_of`). With
``fixed_agents=True`` robots that are not present (``infos[agent]["present"]`` is 0) neither
act nor add to the returns and final metrics, so results equal those without it.

Hooks let callers collect what they need without writing their own loop. Both receive one
:class:`Step`::

    def on_step(step: Step) -> None:  # after every env.step
        distances.append(step.env.goal_distances)

    run_episode(env, policy, seed=0, on_step=on_step)

``on_reset`` is called once after the resets (``step.index == 0``, no actions or rewards),
``on_step`` after every step (``step.index`` = steps taken). A hook may read the env and
the policy and change the episode through the env's public event methods (``env.add_box``,
``env.remove_robot``, ...): the next actions are asked for the agents live after the hook.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from teamgym.envs.infos import known_values

__all__ = ["EpisodeResult", "Step", "StepHook", "metric_names", "run_episode", "static_geometry", "success_of"]


@dataclass(frozen=True)
class Step:
    """What an episode hook sees: the env and policy, and one step's joint action and outcome.

    ``index`` counts the steps taken (0 after reset). ``agents`` are the agents that acted
    in this step, in ``env.agents`` order (after reset: the live agents; a teamgym env's
    ``live_agents``, so with ``fixed_agents=True`` absent robots are left out); ``actions`` is the
    policy's joint action (empty after reset). ``observations`` ... ``infos`` are what
    ``env.step`` (or ``env.reset``) returned; ``rewards``, ``terminations`` and
    ``truncations`` are empty after reset.
    """

    env: Any
    policy: Any
    index: int
    agents: tuple[str, ...]
    actions: Mapping[str, Any]
    observations: Mapping[str, Any]
    rewards: Mapping[str, float]
    terminations: Mapping[str, bool]
    truncations: Mapping[str, bool]
    infos: Mapping[str, Mapping[str, Any]]

    @property
    def success(self) -> bool:
        """The episode's success so far (:func:`success_of` this step's infos)."""
        return success_of(self.infos)

    @property
    def done(self) -> bool:
        """No agent is live any more: this was the episode's last step."""
        return not self.env.agents


#: The signature of ``on_step`` and ``on_reset`` hooks.
StepHook = Callable[[Step], None]


def success_of(infos: Mapping[str, Mapping[str, Any]]) -> bool:
    """The episode's success as one step's ``infos`` report it (the episode contract).

    ``False`` when no agent reports ``"success"`` (an env outside the contract); raises
    ``ValueError`` naming the agents when they disagree, which the contract rules out.
    """
    values = {agent: bool(info["success"]) for agent, info in infos.items() if "success" in info}
    if len(set(values.values())) > 1:
        raise ValueError(f"agents disagree on infos['success'] in one step: {values}")
    return any(values.values())


@dataclass
class EpisodeResult:
    """The outcome of one episode.

    ``success`` is ``infos[...]["success"]`` of the last step. ``metrics`` maps each agent
    to the numeric metrics of the last ``infos`` it received (booleans kept as ``bool``;
    ``success`` is not repeated there); ``returns`` is each agent's summed reward. Equality
    compares only seed, length, success, returns and metrics (not the recordings).
    """

    seed: int
    length: int
    success: bool
    returns: dict[str, float]
    metrics: dict[str, dict[str, float | int | bool]]
    trajectories: dict[str, list[tuple[float, float]]] | None = field(default=None, compare=False, repr=False)
    #: Paths of the moving obstacles and boxes (``env.object_trajectories()``), if the env has them.
    object_paths: dict[str, list[tuple[float, float]]] | None = field(default=None, compare=False, repr=False)
    goals: dict[str, tuple[float, float]] | None = field(default=None, compare=False, repr=False)
    arena: tuple[float, float] | None = field(default=None, compare=False, repr=False)
    #: Static geometry at the end of the episode: wall and closed-door segments, furniture polygons.
    walls: list[tuple[tuple[float, float], tuple[float, float]]] | None = field(default=None, compare=False, repr=False)
    furniture: list[list[tuple[float, float]]] | None = field(default=None, compare=False, repr=False)
    frames: list[np.ndarray] | None = field(default=None, compare=False, repr=False)
    #: Keys of ``metrics`` that are categorical (indices of a sector, place, task: ``env.info_schema()``), never averaged.
    categorical: frozenset[str] = field(default=frozenset(), compare=False, repr=False)

    @property
    def mean_return(self) -> float:
        """Summed reward averaged over the agents."""
        return float(np.mean(list(self.returns.values()))) if self.returns else math.nan

    def metric_values(self, name: str) -> list[float]:
        """Values of metric ``name`` over the agents that report it."""
        return [float(m[name]) for m in self.metrics.values() if name in m]

    def metric_means(self) -> dict[str, float]:
        """Per-episode mean of every (non-categorical) metric over the agents that report it."""
        return {name: float(np.mean(self.metric_values(name))) for name in metric_names([self])}


def metric_names(results: Iterable[EpisodeResult]) -> list[str]:
    """Every metric name in ``results`` that is a quantity (categorical keys left out), in first-seen order."""
    names: dict[str, None] = {}
    for result in results:
        for metrics in result.metrics.values():
            names.update(dict.fromkeys(k for k in metrics if k not in result.categorical))
    return list(names)


def run_episode(
    env: Any,
    policy: Any,
    seed: int,
    on_step: StepHook | None = None,
    *,
    on_reset: StepHook | None = None,
    record_frames: bool = False,
    record_trajectories: bool = True,
) -> EpisodeResult:
    """Play one episode of ``policy`` on ``env`` with ``seed`` and collect its results.

    ``on_step`` / ``on_reset`` are the hooks of the module docstring. With
    ``record_frames`` the env must have ``render_mode="rgb_array"``; every frame (after
    reset and after each step) is kept in ``result.frames``. With ``record_trajectories``
    the robots' and objects' paths, goals, arena size and static geometry are kept.
    """
    if record_frames and getattr(env, "render_mode", None) != "rgb_array":
        raise ValueError("record_frames needs an env made with render_mode='rgb_array'")
    observations, infos = env.reset(seed=seed)
    policy.reset(seed)
    final: dict[str, dict[str, Any]] = {a: dict(infos[a]) for a in env.possible_agents if _present(infos, a)}
    returns = {a: 0.0 for a in _live(env)}
    frames = [env.render()] if record_frames else None
    limit = getattr(getattr(env, "config", None), "cycle_limit", None)
    length = 0
    success = success_of(infos)
    if on_reset is not None:
        on_reset(Step(env, policy, 0, _live(env), {}, observations, {}, {}, {}, infos))
    while env.agents:
        agents = _live(env)
        actions = policy.act({a: observations[a] for a in agents}, infos)
        observations, rewards, terminations, truncations, infos = env.step(actions)
        length += 1
        for agent, reward in rewards.items():
            if _present(infos, agent):
                returns[agent] = returns.get(agent, 0.0) + float(reward)
        for agent, info in infos.items():
            if _present(infos, agent):
                final[agent] = dict(info)
        success = success_of(infos)
        if frames is not None:
            frames.append(env.render())
        if on_step is not None:
            on_step(Step(env, policy, length, agents, actions, observations, rewards, terminations, truncations, infos))
        if limit is not None and length > limit:
            raise RuntimeError(f"episode with seed {seed} ran past its cycle limit ({limit} steps); the env does not truncate")
    schema = env.info_schema() if hasattr(env, "info_schema") else {}
    metrics = {agent: _numeric_metrics(known_values(info, schema)) for agent, info in final.items()}
    categorical = frozenset(k for k, spec in schema.items() if spec.kind == "categorical")
    result = EpisodeResult(
        seed=int(seed), length=length, success=success, returns=returns, metrics=metrics, frames=frames, categorical=categorical
    )
    if record_trajectories:
        _record_scene(env, result)
    return result


def _live(env: Any) -> tuple[str, ...]:
    """The agents that act now: a teamgym env's ``live_agents`` (with ``fixed_agents=True``, ``env.agents``
    also lists absent robots, whose actions are ignored), else ``env.agents``."""
    return tuple(getattr(env, "live_agents", env.agents))


def _present(infos: Mapping[str, Mapping[str, Any]], agent: str) -> bool:
    """Whether ``agent`` reported this step as a robot in the episode (``fixed_agents=True`` reports absent ones too)."""
    return agent in infos and infos[agent].get("present", 1) != 0


def _numeric_metrics(info: Mapping[str, Any]) -> dict[str, float | int | bool]:
    """The numeric scalars of one agent's infos, ``success`` left out (it is the episode's).

    ``run_episode`` passes the known values only (``teamgym.envs.infos.known_values``: a time to goal
    of a robot that never arrived is left out), so means run over the robots and episodes that report it.
    """
    values = {k: _numeric(v) for k, v in info.items() if k != "success"}
    return {k: v for k, v in values.items() if v is not None}


def _numeric(value: Any) -> float | int | bool | None:
    """``value`` as a plain Python number if it is a numeric scalar, else ``None``."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, np.ndarray) and value.shape == () and np.issubdtype(value.dtype, np.number):
        return value.item()
    return None


def _record_scene(env: Any, result: EpisodeResult) -> None:
    """Fill the paths, goals, arena and static geometry of ``result`` from the env at the episode's end."""
    result.trajectories = env.trajectories() if hasattr(env, "trajectories") else None
    result.object_paths = env.object_trajectories() if hasattr(env, "object_trajectories") else None
    world = getattr(env, "world", None)
    if world is not None:
        result.arena = tuple(float(s) for s in world.size) if hasattr(world, "size") else None
        result.walls, result.furniture = static_geometry(world)
    raw_goals = getattr(env, "goals", None)
    if raw_goals is not None:
        try:
            points = np.asarray(raw_goals, dtype=float).reshape(-1, 2)
        except (TypeError, ValueError):
            return
        if len(points) == len(env.possible_agents):
            result.goals = {a: (float(p[0]), float(p[1])) for a, p in zip(env.possible_agents, points)}


def static_geometry(world: Any) -> tuple[list, list]:
    """Wall and closed-door segments (the walls of a ``JoinedWalls`` one by one) and furniture polygons, for plots."""
    from teamgym.maps.walls import JoinedWalls
    from teamgym.sim.objects import Door, StaticPolygon, Wall

    walls, furniture = [], []
    for entity in world.entities.values():
        if isinstance(entity, Door) and entity.is_open:
            continue
        if isinstance(entity, JoinedWalls):
            walls += [(tuple(w.a), tuple(w.b)) for w in entity.walls]
        elif isinstance(entity, Wall):
            walls.append((tuple(entity.a), tuple(entity.b)))
        elif isinstance(entity, StaticPolygon):
            furniture.append([tuple(v) for v in entity.vertices])
    return walls, furniture
