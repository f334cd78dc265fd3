"""Shared test setup: headless rendering and small helpers exposed as fixtures."""

import os
import subprocess
import sys


def _numpy_without_avx512_kernels() -> str:
    """Turn off numpy's AVX-512 kernels for this test run (before numpy loads); returns what was turned off.

    On CPUs with AVX-512, numpy dispatches float64 ``sin``, ``cos``, ``exp``, ... to kernels
    whose last bits differ from the AVX2/libm ones, and a rollout then drifts from the
    recorded fixtures (tests/envs/test_obs_hashes.py, tests/envs/test_regression.py). The fixtures
    hold for the AVX2 kernels, so the suite runs on those on every x86 CPU. A probe process
    names the dispatched AVX-512 targets this numpy has and this CPU supports (the names
    differ between numpy versions). Set ``NPY_DISABLE_CPU_FEATURES`` yourself to override.
    """
    if "NPY_DISABLE_CPU_FEATURES" in os.environ or "numpy" in sys.modules:
        return os.environ.get("NPY_DISABLE_CPU_FEATURES", "")
    probe = (
        "from numpy._core._multiarray_umath import __cpu_dispatch__ as d, __cpu_features__ as f;"
        "print(' '.join(x for x in d if f.get(x) and ('AVX512' in x or x == 'X86_V4')))"
    )
    found = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=False).stdout.strip()
    if found:
        os.environ["NPY_DISABLE_CPU_FEATURES"] = found
    return found


AVX512_KERNELS_OFF = _numpy_without_avx512_kernels()

# Any pygame import (the "human" render mode) must work without a display.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import pytest  # noqa: E402

from teamgym.sim.contacts import PenetrationProbe  # noqa: E402


def pytest_report_header(config):
    return f"numpy kernels turned off for the recorded rollouts: {AVX512_KERNELS_OFF or 'none'}"


@pytest.fixture
def penetration_probe():
    """``penetration_probe(space)`` installs a :class:`PenetrationProbe` on a pymunk space."""
    return PenetrationProbe


def sample_space(space, rng):
    """A value of ``space`` drawn with ``rng`` (Discrete, Box and nested Dict spaces)."""
    if hasattr(space, "n"):
        return int(rng.integers(space.start, space.start + space.n))
    if hasattr(space, "spaces") and isinstance(space.spaces, dict):
        return {key: sample_space(sub, rng) for key, sub in space.spaces.items()}
    return rng.uniform(space.low, space.high).astype(space.dtype)


def random_actions(env, rng):
    """One action per live agent, drawn from the agent's action space with ``rng``."""
    return {agent: sample_space(env.action_space(agent), rng) for agent in env.agents}


@pytest.fixture
def random_policy():
    """``random_policy(env, rng)`` returns a dict of random in-space actions for the live agents."""
    return random_actions


@pytest.fixture
def single_thread_torch():
    """torch on one thread for the test (tiny MLPs run far faster so, and tests share the CPU); restored after."""
    torch = pytest.importorskip("torch")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)
