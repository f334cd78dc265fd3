"""Evaluate a policy on a teamgym env over seeded episodes; write a summary, a CSV and plots.

Command line::

    python -m baselines.evaluate [--env Navigation-v0] [--policy goto] [--episodes 10] [--seed 0]
        [--set key=value ...] [--max-cycles M] [--out DIR] [--gif] [--workers W|ray] [--ray-address ADDR]
        [--quiet] [--stochastic]

Episode ``i`` resets the env with seed ``S + i`` and the policy with ``policy.reset(S + i)``,
so results do not depend on ``--workers``. ``--workers ray`` runs the episodes on a Ray
cluster (one actor per CPU; ``--ray-address HOST:PORT`` or ``RAY_ADDRESS`` names an existing
cluster, else a local one starts; needs ``pip install ray``) with the same results.
``--policy sb3:PATH`` evaluates a saved Stable-Baselines3 model (see
:mod:`baselines.rl.sb3_policy`), deterministically unless ``--stochastic``.

A model saved by ``python -m baselines.train`` has a sidecar ``<model>.json`` with the env
id and config overrides it was trained with. When it exists they are the defaults: the
env is the sidecar's unless ``--env`` is given, and the config is the sidecar's overrides
updated with the ``--set``/``--max-cycles`` given (an explicit setting wins, key by key).
An ``--env`` other than the sidecar's drops the sidecar's overrides and is accepted only if
the model's spaces fit that env (a note goes to stderr); otherwise it is a one-line error
naming both envs. Files written to ``DIR`` (default ``results/<env>_<policy>/``):

* ``summary.json``: env, policy, resolved config, episodes, seed, ``success_rate``,
  ``mean_episode_length``, ``mean_return`` and ``mean_<metric>`` for every numeric
  metric, plus ``metrics`` (mean/std/min/max/count of each), ``deterministic`` (false
  with ``--stochastic``), ``overrides`` (the ``--set`` and sidecar settings, as strings), for
  a model with a sidecar ``sidecar`` (its path) and, with ``--workers ray``, ``ray_nodes``
  (the episodes each Ray node ran, by node id);
* ``episodes.csv``: one row per episode (seed, length, success, mean return over robots
  and the per-episode mean of every metric over the robots that report it);
* ``trajectories.png``: the robots' (and moving obstacles' or boxes') paths in the first episode;
* ``episode.gif`` (with ``--gif``): an animation of the first episode.

Success is the episode contract's: ``infos[agent]["success"]`` of an episode's last step
(one episode: :func:`baselines.episode.run_episode`, re-exported here); it is the
``success`` column, never a metric column.

Errors: a bad command line (an empty ``--env``, ``--policy`` or ``--out`` included, ``--episodes``
above :data:`MAX_EPISODES` = 10**6), env id, config, ``--out`` (an existing file, under one, or
not writable) or a policy that does not fit the env (``Policy.check_env``) exits with code 2
and one ``error: ...`` line before any episode runs; a failure while running exits with code 1
and one line (``TEAMGYM_TRACEBACK=1`` shows the traceback instead). Seeds are made episode by
episode, never listed up front.

Metric means pool all (robot, episode) values: a metric a robot does not report (such as
``time_to_goal`` before arrival) is left out rather than counted as zero; booleans count
as 0/1 (so ``mean_arrived`` is the arrival rate). Non-finite means are written as ``null``.

From Python::

    from baselines.evaluate import evaluate, summarise
    results = evaluate("Navigation-v0", "goto", episodes=20, seed=0, config={"n_robots": 5}, workers=2)
    summary = summarise(results)
"""

from __future__ import annotations

import os

if __name__ == "__main__":  # the CLI: one numeric thread per process, set before numpy loads
    for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_variable, "1")

import argparse
import csv
import json
import math
import re
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from baselines.episode import EpisodeResult, metric_names, run_episode

__all__ = [
    "EpisodeResult",
    "evaluate",
    "main",
    "metric_names",
    "run_episode",
    "summarise",
    "summary_table",
    "write_episodes_csv",
    "write_summary_json",
]


#: The env evaluated when neither ``--env`` nor an SB3 model's sidecar names one.
DEFAULT_ENV = "Navigation-v0"
#: The most episodes one evaluation runs: their results are kept for the summary and the CSV
#: (about 2 kB each for ``goto`` on Navigation-v0, 0.1 CPU-s to play), so more would not fit in memory.
MAX_EPISODES = 10**6


class _Runner:
    """An env and a policy built once and reused for many episodes."""

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
        return run_episode(self.env, self.policy, seed, record_frames=record_frames, record_trajectories=record_trajectories)

    def close(self) -> None:
        self.env.close()


_WORKER: _Runner | None = None


def _init_worker(
    env_id: str, policy_name: str, config: Mapping[str, Any] | None, policy_kwargs: Mapping[str, Any] | None = None
) -> None:
    """Process-pool initializer: one env and policy per worker process, single-threaded torch."""
    global _WORKER
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    _WORKER = _Runner(env_id, policy_name, config, policy_kwargs=policy_kwargs)
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(1)


def _worker_run(seed: int, record_trajectories: bool) -> EpisodeResult:
    assert _WORKER is not None, "worker not initialised"
    return _WORKER.run(seed, record_trajectories=record_trajectories)


def _worker_run_chunk(chunk: Sequence[tuple[int, bool]]) -> list[EpisodeResult]:
    """Several episodes in one task (fewer round trips between processes)."""
    return [_worker_run(s, k) for s, k in chunk]


def _ray_results(
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
        chunks = _chunks(items, cpus)
        actor_class = ray.remote(num_cpus=1)(_RayRunner)
        actors = [
            actor_class.remote(env_id, policy_name, dict(config), dict(policy_kwargs or {}))
            for _ in range(min(cpus, len(chunks)))
        ]
        pool = ray.util.ActorPool(actors)
        for i, chunk in enumerate(chunks):
            pool.submit(lambda actor, job: actor.run_chunk.remote(*job), (i, chunk))
        slots: list[list[EpisodeResult] | None] = [None] * len(chunks)
        while pool.has_next():
            i, node, results = pool.get_next_unordered()
            slots[i] = results
            if nodes is not None:
                nodes[node] = nodes.get(node, 0) + len(results)
            on_done(len(results))
        for actor in actors:
            ray.kill(actor)
        return [r for chunk in slots if chunk is not None for r in chunk]
    finally:
        if started:
            ray.shutdown()


class _RayRunner:
    """A Ray actor's state: one env and policy (as a process-pool worker has), reused for its chunks."""

    def __init__(self, env_id: str, policy_name: str, config: Mapping[str, Any], policy_kwargs: Mapping[str, Any] | None) -> None:
        import ray

        _init_worker(env_id, policy_name, config, policy_kwargs)
        self.node = ray.get_runtime_context().get_node_id()

    def run_chunk(self, index: int, chunk: Sequence[tuple[int, bool]]) -> tuple[int, str, list[EpisodeResult]]:
        """The chunk's results, with its index and the id of the Ray node that ran it."""
        return index, self.node, _worker_run_chunk(chunk)


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


def _pool_context():
    """``fork`` where the platform has it and torch is not loaded (forking after torch's threads start
    can hang); ``spawn`` otherwise. Forked workers start in milliseconds instead of re-importing."""
    import multiprocessing

    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods and "torch" not in sys.modules else "spawn")


class _Episodes(Sequence[tuple[int, bool]]):
    """The ``(seed, keep trajectories)`` pairs of a run's episodes ``indices``, made on demand (a slice is another)."""

    def __init__(self, seed: int, keep_all: bool, indices: range) -> None:
        self.seed, self.keep_all, self.indices = seed, keep_all, indices

    def __len__(self) -> int:
        return len(self.indices)

    def __iter__(self) -> Iterator[tuple[int, bool]]:
        return ((self.seed + i, self.keep_all or i == 0) for i in self.indices)

    def __getitem__(self, item: Any) -> Any:
        if isinstance(item, slice):
            return _Episodes(self.seed, self.keep_all, self.indices[item])
        index = self.indices[item]
        return self.seed + index, self.keep_all or index == 0


def _chunks(items: Sequence[Any], workers: int) -> list[Sequence[Any]]:
    """``items`` in consecutive slices, about four per worker, so that the load still balances."""
    size = max(1, math.ceil(len(items) / (4 * workers)))
    return [items[i : i + size] for i in range(0, len(items), size)]


def evaluate(
    env_id: str = "Navigation-v0",
    policy_name: str = "goto",
    episodes: int = 10,
    seed: int = 0,
    config: Mapping[str, Any] | None = None,
    workers: int | str = 1,
    *,
    progress: bool = False,
    keep_trajectories: bool = False,
    policy_kwargs: Mapping[str, Any] | None = None,
    ray_address: str | None = None,
    ray_nodes: dict[str, int] | None = None,
) -> list[EpisodeResult]:
    """Run ``episodes`` episodes (seeds ``seed .. seed+episodes-1``) and return their results in seed order.

    ``episodes`` is at most :data:`MAX_EPISODES`; the seeds are made one by one, never listed.

    ``config`` is passed to ``teamgym.make`` (strings are parsed as on the command line).
    With ``workers > 1`` episodes run in that many worker processes (forked where possible),
    each with its own env and policy, handed out in chunks of consecutive seeds; results are
    identical to a sequential run. ``workers="ray"`` runs the chunks on Ray actors, one per CPU of
    the running Ray session or of ``ray.init(address=ray_address)`` (by default ``RAY_ADDRESS``,
    else a new local cluster; shut down after); results are again identical, and ``ray_nodes``
    (a dict, if given) gets the number of episodes each Ray node ran. Trajectories are kept for
    the first episode only unless ``keep_trajectories``. ``policy_kwargs`` go to
    :func:`baselines.registry.make_policy` (e.g. ``{"deterministic": False}`` for an
    ``sb3:PATH`` policy). Config, env-id and policy errors
    (including a policy that does not fit the env) raise (``ConfigError``/``ValueError``/
    ``KeyError``/``FileNotFoundError``) before any episode runs.
    """
    if not 1 <= episodes <= MAX_EPISODES:
        raise ValueError(f"episodes must be in [1, {MAX_EPISODES}], got {episodes}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    if workers == "ray":
        ray = require_ray()
        if ray_address is not None:
            check_ray_address(ray_address)
            if ray.is_initialized():
                raise ValueError("ray_address was given, but this process already runs a Ray session (it would be used)")
    elif isinstance(workers, str) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1 or 'ray', got {workers!r}")
    elif ray_address is not None:
        raise ValueError(f"ray_address applies to workers='ray' only, not workers={workers!r}")
    from tqdm import tqdm

    config = dict(config or {})
    runner = _Runner(env_id, policy_name, config, policy_kwargs=policy_kwargs)  # validates env id, config and policy here
    items = _Episodes(seed, keep_trajectories, range(episodes))  # episode i: seed + i, trajectories of the first
    bar = tqdm(total=episodes, desc=f"{env_id} {policy_name}", unit="ep", disable=not progress, leave=False)
    try:
        if workers == 1 or (episodes == 1 and workers != "ray"):
            results = []
            for s, k in items:
                results.append(runner.run(s, record_trajectories=k))
                bar.update(1)
            return results
        runner.close()
        if workers == "ray":
            return _ray_results(env_id, policy_name, config, policy_kwargs, items, bar.update, ray_address, ray_nodes)
        assert isinstance(workers, int)
        from concurrent.futures import ProcessPoolExecutor, as_completed

        chunks = _chunks(items, workers)
        slots: list[list[EpisodeResult] | None] = [None] * len(chunks)
        with ProcessPoolExecutor(
            max_workers=min(workers, episodes),
            mp_context=_pool_context(),
            initializer=_init_worker,
            initargs=(env_id, policy_name, config, policy_kwargs),
        ) as pool:
            futures = {pool.submit(_worker_run_chunk, chunk): i for i, chunk in enumerate(chunks)}
            for future in as_completed(futures):
                slots[futures[future]] = future.result()
                bar.update(len(chunks[futures[future]]))
        return [r for chunk in slots if chunk is not None for r in chunk]
    finally:
        bar.close()
        runner.close()


def _stats(values: Sequence[float]) -> dict[str, float | int]:
    array = np.asarray(values, dtype=float)
    if array.size == 0:
        return {"mean": math.nan, "std": math.nan, "min": math.nan, "max": math.nan, "count": 0}
    with np.errstate(invalid="ignore"):
        return {
            "mean": float(np.mean(array)),
            "std": float(np.std(array)),
            "min": float(np.min(array)),
            "max": float(np.max(array)),
            "count": int(array.size),
        }


def summarise(results: Sequence[EpisodeResult]) -> dict[str, Any]:
    """Aggregate episode results.

    Returns ``episodes``, ``success_rate``, ``mean_episode_length``, ``mean_return`` (mean
    over robots and episodes), ``mean_<metric>`` for every numeric metric (pooled over
    every robot of every episode that reports it) and ``metrics``: per metric (plus
    ``episode_length``, ``return`` and ``success``) its ``mean``, ``std``, ``min``, ``max``
    and ``count``. ``success`` is the episode's (the contract's), so ``mean_success`` equals
    ``success_rate``; it is kept because BoxPushing-v0 summaries had it as a metric.
    """
    if not results:
        raise ValueError("summarise() needs at least one episode result")
    names = metric_names(results)
    stats: dict[str, dict[str, float | int]] = {
        "episode_length": _stats([r.length for r in results]),
        "return": _stats([v for r in results for v in r.returns.values()]),
        "success": _stats([float(r.success) for r in results]),
    }
    for name in names:
        stats[name] = _stats([v for r in results for v in r.metric_values(name)])
    summary: dict[str, Any] = {
        "episodes": len(results),
        "success_rate": float(np.mean([r.success for r in results])),
        "mean_episode_length": stats["episode_length"]["mean"],
        "mean_return": stats["return"]["mean"],
    }
    summary["mean_success"] = stats["success"]["mean"]
    for name in names:
        summary[f"mean_{name}"] = stats[name]["mean"]
    summary["metrics"] = stats
    return summary


def markdown_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """A Markdown table of dict rows (keys of the first row as columns; floats to 3 significant digits)."""
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for row in rows:
        cells = [f"{row[k]:.3g}" if isinstance(row[k], float) else str(row[k]) for k in keys]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def summary_table(summary: Mapping[str, Any], title: str | None = None) -> str:
    """A plain-text, column-aligned table of a :func:`summarise` result."""

    def fmt(value: Any) -> str:
        if isinstance(value, int):
            return str(value)
        if value is None or (isinstance(value, float) and math.isnan(value)):
            return "-"
        return f"{value:.4g}"

    rows = [
        ("metric", "mean", "std", "min", "max", "n"),
        ("success_rate", fmt(summary["success_rate"]), "", "", "", fmt(summary["episodes"])),
    ]
    for name, s in summary["metrics"].items():
        rows.append((name, fmt(s["mean"]), fmt(s["std"]), fmt(s["min"]), fmt(s["max"]), fmt(s["count"])))
    widths = [max(len(row[c]) for row in rows) for c in range(len(rows[0]))]
    lines = [title] if title else []
    for i, row in enumerate(rows):
        cells = [row[0].ljust(widths[0])] + [cell.rjust(w) for cell, w in zip(row[1:], widths[1:])]
        lines.append("  ".join(cells).rstrip())
        if i == 0:
            lines.append("  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _json_safe(value: Any) -> Any:
    """Replace non-finite floats with ``None`` (strict JSON) and numpy scalars/tuples with Python ones."""
    if isinstance(value, Mapping):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return _json_safe(value.tolist())
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    return value


def write_summary_json(path: str | Path, summary: Mapping[str, Any]) -> Path:
    """Write ``summary`` as strict JSON (non-finite numbers become ``null``)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(_json_safe(summary), indent=2, allow_nan=False) + "\n")
    return path


def write_episodes_csv(path: str | Path, results: Sequence[EpisodeResult]) -> Path:
    """One row per episode: ``episode, seed, length, success, return`` and the mean of every metric."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    names = metric_names(results)
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["episode", "seed", "length", "success", "return", *names])
        for i, result in enumerate(results):
            means = result.metric_means()
            cells = [repr(means[n]) if n in means else "" for n in names]
            writer.writerow([i, result.seed, result.length, int(result.success), repr(result.mean_return), *cells])
    return path


# -- command line -----------------------------------------------------------------------


class _UsageError(ValueError):
    """A command-line or configuration mistake: reported in one line, exit code 2."""


class _Parser(argparse.ArgumentParser):
    """An argument parser that reports a bad command line in one line (``error: ...``), exit code 2.

    With ``named`` the line starts with the program's name (``prog: error: ...``, as argparse's does).
    """

    def __init__(self, *args: Any, named: bool = False, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.named = named

    def error(self, message: str) -> NoReturn:
        lead = f"{self.prog}: error" if self.named else "error"
        self.exit(2, f"{lead}: {_one_line(message)} (see --help)\n")


def _at_least(minimum: int, maximum: int | None = None) -> Callable[[str], int]:
    """An argparse ``type``: an integer ``>= minimum`` (and ``<= maximum``)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be >= {minimum}, got {value}")
        if maximum is not None and value > maximum:
            raise argparse.ArgumentTypeError(f"must be <= {maximum}, got {value}")
        return value

    return parse


def _nonblank(what: str) -> Callable[[str], str]:
    """An argparse ``type``: a ``what`` that is not empty or blank (an empty value would fall back to a default)."""

    def parse(text: str) -> str:
        if not text.strip():
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        if text.startswith("sb3:") and not text[4:].strip():
            raise argparse.ArgumentTypeError(f"expected a model path or shipped agent after sb3:, got {text!r}")
        return text

    return parse


def _ray_address(text: str) -> str:
    """An argparse ``type``: a Ray cluster address (:func:`check_ray_address`)."""
    try:
        return check_ray_address(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _workers(text: str) -> int | str:
    """An argparse ``type``: a number of worker processes ``>= 1``, or ``ray``."""
    if text.strip().lower() == "ray":
        return "ray"
    try:
        return _at_least(1)(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1 or 'ray', got {text!r}") from None


def _parse_sets(items: Sequence[str] | None) -> dict[str, str]:
    config: dict[str, str] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise _UsageError(f"--set expects key=value, got {item!r}")
        config[key.strip()] = value.strip()
    return config


def _check_out(out: Path, flag: str = "--out", *, file: bool = False) -> None:
    """Raise :class:`_UsageError` (a ``ValueError``) if ``out`` cannot be made an output directory.

    It cannot when it is an existing file, lies under a file, or when it (if it exists) or its
    nearest existing ancestor is a directory this process may not write into. With ``file``,
    ``out`` names a file to write: it must not be a directory, and its directory is checked.
    """
    shown = repr(str(out))
    try:
        if file and out.is_dir():
            raise _UsageError(f"{flag} {shown} is a directory, not a file")
        for path in out.parents if file else (out, *out.parents):
            if not path.exists():
                continue
            if not path.is_dir():
                where = "is an existing file" if path == out else f"is under {str(path)!r}, which is a file"
                raise _UsageError(f"{flag} {shown} {where}, not a directory")
            if not os.access(path, os.W_OK | os.X_OK):
                where = "" if path == out else f" under {str(path)!r}"
                raise _UsageError(f"{flag} {shown}: cannot write{where} (permission denied)")
            return
    except _UsageError:
        raise
    except (OSError, ValueError) as error:  # e.g. a NUL byte or a name too long
        raise _UsageError(f"{flag} {shown} is not a usable path: {error}") from None


def _model_defaults(
    policy: str, env_id: str | None, config: Mapping[str, str]
) -> tuple[str, dict[str, str], Path | None, str | None]:
    """Env id and config for ``policy``, completed from an ``sb3:PATH`` model's sidecar.

    Returns ``(env_id, config, sidecar path or None, env the model was trained on or None)``.
    The sidecar's overrides apply (explicit settings win) only when the env is the sidecar's.
    """
    config = dict(config)
    default = DEFAULT_ENV if env_id is None else env_id  # an empty --env is refused, never the default
    if not policy.startswith("sb3:"):
        return default, config, None, None
    from baselines.rl.sb3_policy import read_sidecar, resolve_model

    try:
        sidecar = read_sidecar(policy[4:])
    except ValueError as error:
        raise _UsageError(str(error)) from error
    trained_on = sidecar.get("env") if sidecar else None
    if not isinstance(trained_on, str):
        return default, config, None, None
    path = resolve_model(policy[4:]).with_suffix(".json")
    if env_id is not None and env_id != trained_on:
        return env_id, config, path, trained_on
    overrides = sidecar.get("overrides") if isinstance(sidecar.get("overrides"), dict) else {}
    return trained_on, {**{str(k): str(v) for k, v in overrides.items()}, **config}, path, trained_on


def _slug(text: str) -> str:
    if text.startswith("sb3:"):
        text = "sb3-" + Path(text[4:]).stem
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text).strip("-") or "policy"


def _one_line(text: str) -> str:
    return " ".join(text.split())


def _message(error: BaseException) -> str:
    if isinstance(error, KeyError) and error.args:
        return _one_line(str(error.args[0]))
    return _one_line(str(error)) or type(error).__name__


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m baselines.evaluate`` argument parser (a bad command line exits 2 with a one-line error)."""
    parser = _Parser(
        prog="python -m baselines.evaluate",
        description="Evaluate a policy on a teamgym env over seeded episodes.",
    )
    seed = _at_least(0)  # numpy rejects negative seeds
    parser.add_argument(
        "--env",
        type=_nonblank("an env id"),
        default=None,
        help=f"env id (default: an sb3:PATH model's, from its sidecar <model>.json; else {DEFAULT_ENV})",
    )
    parser.add_argument(
        "--policy", type=_nonblank("a policy name or sb3:PATH"), default="goto", help="policy name or sb3:PATH (default: goto)"
    )
    parser.add_argument(
        "--episodes",
        type=_at_least(1, MAX_EPISODES),
        default=10,
        help=f"number of episodes, 1 to {MAX_EPISODES} (default: 10)",
    )
    parser.add_argument("--seed", type=seed, default=0, help="first seed, >= 0; episode i uses seed+i (default: 0)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="env config override (repeatable)")
    parser.add_argument("--max-cycles", type=int, default=None, help="shorthand for --set max_cycles=M")
    parser.add_argument(
        "--out", type=_nonblank("a directory"), default=None, help="output directory (default: results/<env>_<policy>/)"
    )
    parser.add_argument("--gif", action="store_true", help="also write an animated GIF of the first episode")
    parser.add_argument("--no-plot", action="store_true", help="do not draw trajectories.png (matplotlib is then not loaded)")
    parser.add_argument(
        "--workers",
        type=_workers,
        default=1,
        help="parallel worker processes, >= 1, or 'ray': Ray actors, one per cluster CPU (RAY_ADDRESS; default: 1)",
    )
    parser.add_argument(
        "--ray-address",
        type=_ray_address,
        default=None,
        metavar="ADDR",
        help="with --workers ray: the Ray cluster to run on, HOST:PORT of its head (default: RAY_ADDRESS, else a new local one)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar or table")
    parser.add_argument(
        "--stochastic", action="store_true", help="sample an sb3:PATH model's actions instead of taking the most likely"
    )
    parser.add_argument("--list", action="store_true", help="list env ids and policy names and exit")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the evaluation CLI; returns the exit code.

    Exit code 2, with one ``error: ...`` line on stderr and before any episode runs, for a
    bad command line, env id, config, policy, policy/env mismatch or ``--out``; 1, with
    one line, for a failure while running (``TEAMGYM_TRACEBACK=1`` re-raises it instead).
    """
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as done:  # --help, or a usage error already reported in one line
        return 0 if done.code is None else done.code if isinstance(done.code, int) else 2

    def body() -> int:
        try:
            return _run(args)
        except _UsageError as error:
            print(f"error: {_one_line(str(error))}", file=sys.stderr)
            return 2

    return guarded(body)


def guarded(body: Callable[[], int]) -> int:
    """Run a command's work: Ctrl-C exits 130, any failure prints one line and exits 1 (``TEAMGYM_TRACEBACK=1`` re-raises)."""
    try:
        return body()
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130
    except Exception as error:  # noqa: BLE001 - no traceback reaches a command-line user
        if os.environ.get("TEAMGYM_TRACEBACK"):
            raise
        print(f"error: {type(error).__name__}: {_message(error)} (TEAMGYM_TRACEBACK=1 shows where)", file=sys.stderr)
        return 1


def _run(args: argparse.Namespace) -> int:
    """The CLI after parsing: validate everything, then run the episodes and write the outputs."""
    import teamgym
    from baselines.registry import policies

    if args.list:
        print("envs:     " + " ".join(teamgym.envs()))
        print("policies: " + " ".join(policies()) + " sb3:PATH")
        return 0
    config = _parse_sets(args.set)
    if args.max_cycles is not None:
        config["max_cycles"] = str(args.max_cycles)
    if args.stochastic and not args.policy.startswith("sb3:"):
        raise _UsageError(f"--stochastic applies to sb3:PATH policies only, not {args.policy!r}")
    if args.ray_address is not None and args.workers != "ray":
        raise _UsageError(f"--ray-address applies to --workers ray only, not --workers {args.workers}")
    if args.workers == "ray":
        try:
            require_ray()
        except ImportError as error:
            raise _UsageError(str(error)) from error
    env_id, config, sidecar, trained_on = _model_defaults(args.policy, args.env, config)
    policy_kwargs = {"deterministic": False} if args.stochastic else {}
    name = _slug(args.policy) + ("-stochastic" if args.stochastic else "")
    out = Path(args.out) if args.out is not None else Path("results") / f"{_slug(env_id)}_{name}"
    _check_out(out)
    try:
        probe = _Runner(env_id, args.policy, config, policy_kwargs=policy_kwargs)
    except (ValueError, TypeError, KeyError, FileNotFoundError, ImportError) as error:
        if trained_on is not None and trained_on != env_id:
            raise _UsageError(
                f"the model was trained on {trained_on} (per {str(sidecar)!r}), not {env_id}: {_message(error)}"
            ) from error
        raise _UsageError(_message(error)) from error
    if trained_on is not None and trained_on != env_id:
        print(
            f"note: the model was trained on {trained_on} (per {str(sidecar)!r}); its spaces fit {env_id}, "
            "so it is evaluated there without the sidecar's config",
            file=sys.stderr,
        )
    resolved = probe.env.config.as_dict() if hasattr(probe.env.config, "as_dict") else dict(config)
    if "torch" in sys.modules:  # an SB3 policy: tiny batches run fastest single-threaded
        sys.modules["torch"].set_num_threads(1)
    probe.close()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise _UsageError(f"cannot create --out {str(out)!r}: {error.strerror or error}") from error

    nodes: dict[str, int] = {}
    results = evaluate(
        env_id,
        args.policy,
        args.episodes,
        args.seed,
        config,
        args.workers,
        progress=not args.quiet,
        policy_kwargs=policy_kwargs,
        ray_address=args.ray_address,
        ray_nodes=nodes,
    )
    summary = {"env": env_id, "policy": args.policy, "config": resolved, "seed": args.seed, "workers": args.workers}
    summary.update(summarise(results))
    if args.workers == "ray":
        summary["ray_nodes"] = dict(sorted(nodes.items()))
    summary["deterministic"] = not args.stochastic
    summary["overrides"] = {k: str(v) for k, v in config.items()}
    if sidecar is not None:
        summary["sidecar"] = str(sidecar)
    written = [write_summary_json(out / "summary.json", summary), write_episodes_csv(out / "episodes.csv", results)]

    first = results[0]
    if first.trajectories and not args.no_plot:
        from baselines.plots import plot_trajectories

        title = f"{env_id} · {args.policy} · seed {first.seed} · {'success' if first.success else 'no success'}"
        written.append(
            plot_trajectories(
                first.trajectories,
                out / "trajectories.png",
                arena=first.arena,
                goals=first.goals,
                title=title,
                walls=first.walls,
                furniture=first.furniture,
                objects=first.object_paths,
            )
        )
    if args.gif:
        from teamgym.sim.render import save_gif

        recorder = _Runner(env_id, args.policy, config, render_mode="rgb_array", policy_kwargs=policy_kwargs)
        try:
            replay = recorder.run(first.seed, record_frames=True)
            fps = float(recorder.env.metadata.get("render_fps") or 10)
        finally:
            recorder.close()
        if replay != first:
            print(f"warning: the rendered replay of seed {first.seed} differs from the evaluated episode", file=sys.stderr)
        written.append(save_gif(replay.frames or [], out / "episode.gif", fps=fps))

    if not args.quiet:
        seeds = f"seed {args.seed}" if args.episodes == 1 else f"seeds {args.seed}-{args.seed + args.episodes - 1}"
        mode = " (stochastic)" if args.stochastic else ""
        print(summary_table(summary, title=f"{env_id} | {args.policy}{mode} | {args.episodes} episodes ({seeds})"))
        for path in written:
            print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    # Re-enter through the importable module so spawned workers can unpickle its functions.
    from baselines.evaluate import main as _main

    sys.exit(_main())
