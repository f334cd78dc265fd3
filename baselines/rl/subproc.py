"""``SubprocTeamVecEnv``: :class:`~baselines.rl.sb3_env.TeamVecEnv` copies stepped in worker processes.

The ``n_envs`` env copies are split over ``n_workers`` processes (as evenly as possible);
each worker runs a :class:`~baselines.rl.sb3_env.TeamVecEnv` over its share and the slots
are concatenated in worker order, so slot ``k`` of this VecEnv is a slot of exactly one
worker for the whole run. Workers are started by ``fork`` where the platform has it (no
re-import, no pickling of ``env_fn``) and by ``spawn`` elsewhere (``env_fn`` is then sent
with cloudpickle). Each worker limits the BLAS/OpenMP/torch thread pools to one thread, so
``n_workers`` processes use ``n_workers`` cores.

Seeding follows :class:`TeamVecEnv`: after ``seed(S)`` the copy behind slots ``e·A …`` is
reset with ``S + e·A`` whatever the worker count. Refilled slots draw from their own
worker's pool of copies, so runs with different worker counts differ after the first
robot finishes, while each worker count is bit-identical from run to run.
"""

from __future__ import annotations

import multiprocessing as mp
import os
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import CloudpickleWrapper, VecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

from baselines.rl.sb3_env import TeamVecEnv
from teamgym.envs.base import TeamEnv

__all__ = ["SubprocTeamVecEnv", "default_start_method", "split_copies"]

_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def default_start_method() -> str:
    """``fork`` where the platform offers it, else ``spawn``."""
    return "fork" if "fork" in mp.get_all_start_methods() else "spawn"


def split_copies(n_envs: int, n_workers: int) -> list[int]:
    """How many copies each worker runs: ``n_envs`` split as evenly as possible, larger shares first."""
    if n_workers < 1 or n_envs < n_workers:
        raise ValueError(f"need 1 <= n_workers <= n_envs, got n_workers={n_workers}, n_envs={n_envs}")
    base, extra = divmod(n_envs, n_workers)
    return [base + (w < extra) for w in range(n_workers)]


def _one_thread() -> None:
    for name in _THREAD_VARIABLES:
        os.environ[name] = "1"
    try:
        import torch
    except ImportError:
        return
    torch.set_num_threads(1)


def _serve(
    remote: Any,
    parent_remote: Any,
    env_fn: CloudpickleWrapper,
    layout: tuple[int, int, int, int, int],
    batched: bool | None = None,
) -> None:
    """Worker loop: run a :class:`TeamVecEnv` over this worker's copies and answer the parent's commands.

    ``layout`` is (copies here, index of the first, total copies, worker index, workers);
    ``batched`` is :class:`TeamVecEnv`'s.
    """
    parent_remote.close()
    _one_thread()
    n_envs, first_copy, total, worker, workers = layout
    venv = TeamVecEnv(env_fn.var, n_envs=n_envs, batched=batched)
    venv.slot_offset = first_copy * venv.agents_per_env
    venv.extra_copy_numbers = (total + worker, workers)
    try:
        while True:
            command, data = remote.recv()
            if command == "step":
                venv.step_async(data)
                remote.send(venv.step_wait())
            elif command == "reset":
                seeds, options = data
                if seeds and seeds[0] is not None:  # the parent's seeds are consecutive: S + k for its slot k
                    venv.seed(seeds[0])
                venv.set_options(list(options))
                remote.send((venv.reset(), list(venv.reset_infos)))
            elif command == "spaces":
                remote.send((venv.num_envs, venv.agents_per_env, venv.observation_space, venv.action_space))
            elif command == "padding":
                remote.send((venv.slot_steps, venv.padding_steps))
            elif command == "call":
                name, args, kwargs = data
                remote.send(getattr(venv, name)(*args, **kwargs))
            elif command == "close":
                venv.close()
                remote.send(None)
                break
            else:
                raise ValueError(f"unknown worker command {command!r}")
    except (EOFError, KeyboardInterrupt):
        venv.close()


class SubprocTeamVecEnv(VecEnv):
    """``n_envs × A`` slots like :class:`TeamVecEnv`, with the copies stepped in ``n_workers`` processes.

    Each worker steps its copies as one batch where the env has a batch form (``batched``, as :class:`TeamVecEnv`).
    """

    def __init__(
        self,
        env_fn: Callable[[], TeamEnv],
        n_envs: int,
        n_workers: int | None = None,
        start_method: str | None = None,
        batched: bool | None = None,
    ) -> None:
        n_workers = min(n_envs, n_workers or os.cpu_count() or 1)
        self.shares = split_copies(n_envs, n_workers)
        context = mp.get_context(start_method or default_start_method())
        self.remotes, self.processes = [], []
        firsts = np.cumsum([0, *self.shares])
        for w, share in enumerate(self.shares):
            parent, child = context.Pipe()
            layout = (share, int(firsts[w]), n_envs, w, n_workers)
            args = (child, parent, CloudpickleWrapper(env_fn), layout, batched)
            process = context.Process(target=_serve, args=args, daemon=True)
            process.start()
            child.close()
            self.remotes.append(parent)
            self.processes.append(process)
        self.closed = False
        self.waiting = False
        sizes = []
        for remote in self.remotes:
            remote.send(("spaces", None))
            size, agents, observation_space, action_space = remote.recv()
            sizes.append(size)
        self.agents_per_env = agents
        self._offsets = np.cumsum([0, *sizes])
        super().__init__(int(self._offsets[-1]), observation_space, action_space)

    # -- routing -----------------------------------------------------------------------
    def _slices(self) -> list[slice]:
        return [slice(int(a), int(b)) for a, b in zip(self._offsets[:-1], self._offsets[1:])]

    def _by_worker(self, indices: VecEnvIndices) -> dict[int, list[int]]:
        """Local slot indices per worker for global slot ``indices``, in order."""
        groups: dict[int, list[int]] = {}
        for k in self._get_indices(indices):
            w = int(np.searchsorted(self._offsets, k, side="right") - 1)
            groups.setdefault(w, []).append(k - int(self._offsets[w]))
        return groups

    def _call(self, name: str, *args: Any, indices: VecEnvIndices = None, **kwargs: Any) -> list[Any]:
        out: list[Any] = []
        groups = self._by_worker(indices)
        for w, local in groups.items():
            self.remotes[w].send(("call", (name, args, {**kwargs, "indices": local})))
        for w in groups:
            out += self.remotes[w].recv()
        return out

    # -- VecEnv API --------------------------------------------------------------------
    def reset(self) -> VecEnvObs:
        for remote, part in zip(self.remotes, self._slices()):
            remote.send(("reset", (self._seeds[part], self._options[part])))
        observations = []
        for remote, part in zip(self.remotes, self._slices()):
            obs, reset_infos = remote.recv()
            observations.append(obs)
            self.reset_infos[part] = reset_infos
        self._reset_seeds()
        self._reset_options()
        return np.concatenate(observations)

    def step_async(self, actions: np.ndarray) -> None:
        actions = np.asarray(actions)
        if len(actions) != self.num_envs:
            raise ValueError(f"expected {self.num_envs} actions (one per slot), got {len(actions)}")
        for remote, part in zip(self.remotes, self._slices()):
            remote.send(("step", actions[part]))
        self.waiting = True

    def step_wait(self) -> VecEnvStepReturn:
        results = [remote.recv() for remote in self.remotes]
        self.waiting = False
        obs, rewards, dones, infos = zip(*results)
        return np.concatenate(obs), np.concatenate(rewards), np.concatenate(dones), [i for part in infos for i in part]

    @property
    def padding_share(self) -> float:
        """Share of slot-steps that were padding, over every worker (see :attr:`TeamVecEnv.padding_share`)."""
        for remote in self.remotes:
            remote.send(("padding", None))
        counts = np.array([remote.recv() for remote in self.remotes]).sum(axis=0)
        return float(counts[1] / counts[0]) if counts[0] else 0.0

    def action_masks(self) -> np.ndarray:
        """One mask row per slot for sb3-contrib's ``MaskablePPO``."""
        for remote in self.remotes:
            remote.send(("call", ("action_masks", (), {})))
        return np.concatenate([remote.recv() for remote in self.remotes])

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        return self._call("get_attr", attr_name, indices=indices)

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        self._call("set_attr", attr_name, value, indices=indices)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any) -> list[Any]:
        return self._call("env_method", method_name, *method_args, indices=indices, **method_kwargs)

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return self._call("env_is_wrapped", wrapper_class, indices=indices)

    def get_images(self) -> Sequence[np.ndarray | None]:
        for remote in self.remotes:
            remote.send(("call", ("get_images", (), {})))
        return [image for remote in self.remotes for image in remote.recv()]

    def close(self) -> None:
        if self.closed:
            return
        if self.waiting:
            for remote in self.remotes:
                remote.recv()
        for remote in self.remotes:
            remote.send(("close", None))
        for remote in self.remotes:
            remote.recv()
        for process in self.processes:
            process.join()
        self.closed = True
