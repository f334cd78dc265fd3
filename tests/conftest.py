"""Shared test setup: headless rendering and small helpers exposed as fixtures."""

import os

# Any pygame import (the "human" render mode) must work without a display.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from teamgym.sim import Category  # noqa: E402


class PenetrationProbe:
    """Records the deepest overlap of every contact involving a robot, in every physics substep.

    Uses a ``post_solve`` collision callback, which Chipmunk calls in each substep for every
    touching pair (however the world drives its substeps), so it sees the worst overlap
    rather than only the state at the end of a control step.
    """

    def __init__(self, space, kind=Category.ROBOT):
        self.worst = {}
        self.calls = 0
        space.on_collision(int(kind), post_solve=self._post_solve)

    def _post_solve(self, arbiter, space, data):
        self.calls += 1
        key = frozenset(getattr(getattr(s, "entity", None), "kind", None) for s in arbiter.shapes)
        depth = max((-p.distance for p in arbiter.contact_point_set.points), default=0.0)
        self.worst[key] = max(self.worst.get(key, -np.inf), depth)

    def deepest(self, kind_a, kind_b):
        return self.worst.get(frozenset((kind_a, kind_b)), 0.0)


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
