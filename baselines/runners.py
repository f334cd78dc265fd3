"""Where episodes and other jobs run: in this process, in a process pool, or on Ray actors.

* :class:`EpisodeRunner`: an env and a policy built once and reused for many seeded episodes;
* :func:`run_episodes`: the episodes of ``(seed, keep trajectories)`` items, serially, in
  ``workers`` processes (:func:`pool_map`, each with its own :class:`EpisodeRunner`) or with
  ``workers="ray"`` on Ray actors, one per cluster CPU (:func:`ray_episodes`); results come back
  in item order and are the same every way, because an episode depends on its seed only;
* :func:`pool_map`: ``task(job)`` for every job, in order, in worker processes (forked where the
  platform allows and torch is not loaded, else spawned), handed out in chunks of consecutive
  jobs (:func:`chunks`); the experiments of ``experiments/`` run their jobs through it;
* :class:`Episodes`: the items of a run (seed ``S + i``, trajectories of the first), made on demand;
* :func:`require_ray` and :func:`check_ray_address` for ``--workers ray``.
"""

from __future__ import annotations

import math
import os
import re
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

from baselines.episode import EpisodeResult, run_episode

__all__ = [
    "EpisodeRunner",
    "Episodes",
    "check_ray_address",
    "chunks",
    "pool_context",
    "pool_map",
    "ray_episodes",
    "require_ray",
    "run_episodes",
]


class EpisodeRunner:
    """An env and a policy built once and reused for many episodes (config, env-id and policy errors raise here)."""

    def __init__(
        self,
        env_id: str,
        policy_name: str,
        config: Mapping[str, Any] | None,
        render_mode: str | None = None,
        policy_kwargs: Mapping[str, Any] | None = None,
    ) -> None:
        import teamgym
        from baselines.registry import make_policy, policy_class, required_config

        if env_id in teamgym.envs():  # a policy for another env fails here, before its required config
            policy_class(policy_name).check_env_id(env_id, policy_name)
        config = {**required_config(policy_name), **dict(config or {})}
        self.env = teamgym.make(env_id, render_mode=render_mode, **config)
        try:
            self.policy = make_policy(policy_name, self.env, **dict(policy_kwargs or {}))
        except BaseException:
            self.env.close()
            raise

    def run(self, seed: int, record_frames: bool = False, record_trajectories: bool = False) -> EpisodeResult:
        """One episode with ``seed`` (:func:`baselines.episode.run_episode`)."""
        return run_episode(self.env, self.policy, seed, record_frames=record_frames, record_trajectories=record_trajectories)

    def run_items(self, items: Sequence[tuple[int, bool]]) -> list[EpisodeResult]:
        """The episodes of ``(seed, keep trajectories)`` items, in order."""
        return [self.run(seed, record_trajectories=keep) for seed, keep in items]

    def close(self) -> None:
        self.env.close()


class Episodes(Sequence[tuple[int, bool]]):
    """The ``(seed, keep trajectories)`` pairs of a run's episodes ``indices``, made on demand (a slice is another)."""

    def __init__(self, seed: int, keep_all: bool, indices: range) -> None:
        self.seed, self.keep_all, self.indices = seed, keep_all, indices

    def __len__(self) -> int:
        return len(self.indices)

    def __iter__(self) -> Iterator[tuple[int, bool]]:
        return ((self.seed + i, self.keep_all or i == 0) for i in self.indices)

    def __getitem__(self, item: Any) -> Any:
        if isinstance(item, slice):
            return Episodes(self.seed, self.keep_all, self.indices[item])
        index = self.indices[item]
        return self.seed + index, self.keep_all or index == 0


def chunks(items: Sequence[Any], workers: int) -> list[Sequence[Any]]:
    """``items`` in consecutive slices, about four per worker, so that the load still balances."""
    size = max(1, math.ceil(len(items) / (4 * workers)))
    return [items[i : i + size] for i in range(0, len(items), size)]


def pool_context(start_method: str | None = None) -> Any:
    """A multiprocessing context: ``start_method``, else ``fork`` where the platform has it and torch is not
    loaded (forking after torch's threads start can hang), else ``spawn``. Forked workers start in
    milliseconds instead of re-importing."""
    import multiprocessing

    if start_method is None:
        methods = multiprocessing.get_all_start_methods()
        start_method = "fork" if "fork" in methods and "torch" not in sys.modules else "spawn"
    return multiprocessing.get_context(start_method)


def _run_chunk(task: Callable[..., Any], chunk: Sequence[Any], star: bool) -> list[Any]:
    return [task(*job) if star else task(job) for job in chunk]


def pool_map(
    task: Callable[..., Any],
    jobs: Sequence[Any],
    workers: int,
    *,
    star: bool = False,
    initializer: Callable[..., None] | None = None,
    initargs: tuple[Any, ...] = (),
    on_done: Callable[[int], None] | None = None,
    start_method: str | None = None,
) -> list[Any]:
    """``task(job)`` (``task(*job)`` with ``star``) for every job, results in job order.

    ``workers <= 1`` or fewer than two jobs: in this process (``initializer`` is not called).
    Else in ``min(workers, len(jobs))`` processes of :func:`pool_context` (``start_method``), each
    started with ``initializer(*initargs)``, the jobs in consecutive chunks (:func:`chunks`).
    ``task`` and the jobs must pickle (a module-level function). ``on_done(n)`` is called as each
    chunk of ``n`` jobs finishes. An exception in a job is raised here.
    """
    if not isinstance(workers, int) or isinstance(workers, bool):
        raise TypeError(f"workers must be an integer, got {workers!r}")
    if workers <= 1 or len(jobs) <= 1:
        results = []
        for job in jobs:
            results.append(task(*job) if star else task(job))
            if on_done is not None:
                on_done(1)
        return results
    from concurrent.futures import ProcessPoolExecutor, as_completed

    parts = chunks(jobs, workers)
    slots: list[list[Any] | None] = [None] * len(parts)
    with ProcessPoolExecutor(
        max_workers=min(workers, len(jobs)), mp_context=pool_context(start_method), initializer=initializer, initargs=initargs
    ) as pool:
        futures = {pool.submit(_run_chunk, task, part, star): i for i, part in enumerate(parts)}
        for future in as_completed(futures):
            slots[futures[future]] = future.result()
            if on_done is not None:
                on_done(len(parts[futures[future]]))
    return [result for part in slots if part is not None for result in part]


# -- worker processes of run_episodes -------------------------------------------------------

_WORKER: EpisodeRunner | None = None


def _init_worker(
    env_id: str, policy_name: str, config: Mapping[str, Any] | None, policy_kwargs: Mapping[str, Any] | None = None
) -> None:
    """Process-pool initializer: one env and policy per worker process, single-threaded torch."""
    global _WORKER
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    _WORKER = EpisodeRunner(env_id, policy_name, config, policy_kwargs=policy_kwargs)
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(1)


def _worker_run(seed: int, record_trajectories: bool) -> EpisodeResult:
    assert _WORKER is not None, "worker not initialised"
    return _WORKER.run(seed, record_trajectories=record_trajectories)


def run_episodes(
    env_id: str,
    policy_name: str,
    config: Mapping[str, Any],
    items: Sequence[tuple[int, bool]],
    workers: int | str = 1,
    *,
    policy_kwargs: Mapping[str, Any] | None = None,
    runner: EpisodeRunner | None = None,
    on_done: Callable[[int], None] | None = None,
    ray_address: str | None = None,
    ray_nodes: dict[str, int] | None = None,
) -> list[EpisodeResult]:
    """The episodes of ``items`` (``(seed, keep trajectories)``) of ``policy_name`` on ``env_id``, in item order.

    ``workers=1`` (or one item): serially, on ``runner`` if given (else one built here and closed
    after); an integer above 1: in that many processes (:func:`pool_map`), each with its own env and
    policy; ``"ray"``: on Ray actors (:func:`ray_episodes`, ``ray_address`` and ``ray_nodes``).
    ``on_done(n)`` is called as ``n`` more episodes finish. Arguments are not checked here:
    :func:`baselines.evaluate.evaluate` checks them.
    """
    policy_kwargs = dict(policy_kwargs or {})
    if workers == "ray":
        return ray_episodes(env_id, policy_name, config, policy_kwargs, items, on_done or _ignore, ray_address, ray_nodes)
    if workers == 1 or len(items) <= 1:
        own = runner is None
        runner = runner or EpisodeRunner(env_id, policy_name, config, policy_kwargs=policy_kwargs)
        try:
            results = []
            for seed, keep in items:
                results.append(runner.run(seed, record_trajectories=keep))
                if on_done is not None:
                    on_done(1)
            return results
        finally:
            if own:
                runner.close()
    assert isinstance(workers, int)
    return pool_map(
        _worker_run,
        items,
        workers,
        star=True,
        initializer=_init_worker,
        initargs=(env_id, policy_name, dict(config), policy_kwargs),
        on_done=on_done,
    )


def _ignore(count: int) -> None:
    return None


# -- Ray ------------------------------------------------------------------------------------


def require_ray() -> Any:
    """The ``ray`` module, or ``ImportError`` with the install command (``--workers ray``)."""
    try:
        import ray
    except ImportError as error:
        raise ImportError(
            "--workers ray needs the ray package: pip install 'ray>=2.60' (or teamgym's rllib extra, docs/scale_out.md)"
        ) from error
    import ray.util  # ActorPool

    return ray


#: What ``ray.init(address=...)`` takes for an existing cluster: ``auto``, ``HOST:PORT`` or ``ray://HOST:PORT``.
_RAY_ADDRESS = re.compile(r"(ray://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(\d{1,5})")


def check_ray_address(address: str) -> str:
    """``address`` if it names an existing Ray cluster (``HOST:PORT``, ``ray://HOST:PORT`` or ``auto``), else ``ValueError``."""
    match = _RAY_ADDRESS.fullmatch(address)
    if address != "auto" and not (match and 1 <= int(match.group(3)) <= 65535):
        raise ValueError(f"a Ray address is HOST:PORT, ray://HOST:PORT or auto, got {address!r}")
    return address


class _RayRunner:
    """A Ray actor's state: one env and policy (as a process-pool worker has), reused for its chunks."""

    def __init__(self, env_id: str, policy_name: str, config: Mapping[str, Any], policy_kwargs: Mapping[str, Any] | None) -> None:
        import ray

        _init_worker(env_id, policy_name, config, policy_kwargs)
        self.node = ray.get_runtime_context().get_node_id()

    def run_chunk(self, index: int, chunk: Sequence[tuple[int, bool]]) -> tuple[int, str, list[EpisodeResult]]:
        """The chunk's results, with its index and the id of the Ray node that ran it."""
        assert _WORKER is not None, "worker not initialised"
        return index, self.node, _WORKER.run_items(chunk)


def ray_episodes(
    env_id: str,
    policy_name: str,
    config: Mapping[str, Any],
    policy_kwargs: Mapping[str, Any] | None,
    items: Sequence[tuple[int, bool]],
    on_done: Callable[[int], None],
    address: str | None = None,
    nodes: dict[str, int] | None = None,
) -> list[EpisodeResult]:
    """Episodes ``items`` (seed, keep trajectories) on Ray actors, one per cluster CPU, each with its own env and policy.

    Uses the running Ray session, else ``ray.init(address)`` (``None``: ``RAY_ADDRESS`` or a new local
    cluster), shut down after. ``nodes`` gets the number of episodes each node ran (node id -> count).
    """
    ray = require_ray()
    started = not ray.is_initialized()
    if started:
        import logging

        ray.init(address=address, logging_level=logging.WARNING)
    try:
        cpus = max(1, int(ray.cluster_resources().get("CPU", 1)))
        parts = chunks(items, cpus)
        actor_class = ray.remote(num_cpus=1)(_RayRunner)
        actors = [
            actor_class.remote(env_id, policy_name, dict(config), dict(policy_kwargs or {})) for _ in range(min(cpus, len(parts)))
        ]
        pool = ray.util.ActorPool(actors)
        for i, part in enumerate(parts):
            pool.submit(lambda actor, job: actor.run_chunk.remote(*job), (i, part))
        slots: list[list[EpisodeResult] | None] = [None] * len(parts)
        while pool.has_next():
            i, node, results = pool.get_next_unordered()
            slots[i] = results
            if nodes is not None:
                nodes[node] = nodes.get(node, 0) + len(results)
            on_done(len(results))
        for actor in actors:
            ray.kill(actor)
        return [r for part in slots if part is not None for r in part]
    finally:
        if started:
            ray.shutdown()
