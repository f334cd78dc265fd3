"""Shared test setup: headless rendering and small helpers exposed as fixtures."""

import os

# Any pygame import (the "human" render mode) must work without a display.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import pytest  # noqa: E402

from teamgym.sim.contacts import PenetrationProbe  # noqa: E402


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
