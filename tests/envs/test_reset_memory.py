"""Resets do not leak memory outside the Python heap (issue 23).

pymunk 7's ``batch.Buffer`` never frees its C arrays, and every world used to read its
bodies through a new one: each reset leaked a row (56 bytes and the array's slack) per body
of the space, static wall bodies included, about 27 kB per Rendezvous-v0 reset. The C heap
is measured with glibc's ``mallinfo2`` (bytes in use), which sees Chipmunk's and cffi's
allocations that ``tracemalloc`` does not; Python's small objects live in arenas it does not
count. ``benchmarks/bench_reset_memory.py`` measures the process's RSS over 2,000 resets.
"""

import ctypes
import ctypes.util
import gc

import pymunk
import pytest

import teamgym
from teamgym.sim.chipmunk import BodyReader

#: Bytes of one body's row in a batch read: x, y, angle, vx, vy, ω and the body id.
ROW_BYTES = 7 * 8


class _MallInfo2(ctypes.Structure):
    _fields_ = [
        (name, ctypes.c_size_t)
        for name in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost")
    ]


def _libc_mallinfo2():
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        function = libc.mallinfo2
    except (OSError, AttributeError):
        return None
    function.restype = _MallInfo2
    return function


MALLINFO2 = _libc_mallinfo2()
pytestmark = pytest.mark.skipif(MALLINFO2 is None, reason="needs glibc >= 2.33 (mallinfo2) to count C heap bytes")


def c_heap_bytes() -> int:
    """Bytes malloc has handed out and not got back (after a full garbage collection)."""
    gc.collect()
    info = MALLINFO2()
    return info.uordblks + info.hblkhd


def live_pymunk_objects() -> dict[str, int]:
    """Live pymunk spaces, bodies, shapes and constraints by type (after a full garbage collection)."""
    gc.collect()
    counts: dict[str, int] = {}
    for obj in gc.get_objects():
        if issubclass(type(obj), (pymunk.Space, pymunk.Body, pymunk.Shape, pymunk.Constraint)):  # type(): no __class__ lookups
            counts[type(obj).__name__] = counts.get(type(obj).__name__, 0) + 1
    return counts


def test_body_readers_free_their_arrays():
    space = pymunk.Space()
    for k in range(400):
        body = pymunk.Body(body_type=pymunk.Body.STATIC)
        space.add(body, pymunk.Segment(body, (k, 0.0), (k, 1.0), 0.1))
    robot = pymunk.Body(1.0, 1.0)
    space.add(robot, pymunk.Circle(robot, 0.1))
    BodyReader([robot]).read(space)
    before = c_heap_bytes()
    for _ in range(200):
        BodyReader([robot]).read(space)
    grown = c_heap_bytes() - before
    # A leaking reader keeps at least 401 rows (22 kB) each: 4.5 MB for 200 readers.
    assert grown < 200 * 401 * ROW_BYTES / 20, f"200 body readers left {grown} bytes on the C heap"


@pytest.mark.parametrize("env_id", teamgym.envs())
def test_resets_leave_no_memory_behind(env_id):
    env = teamgym.make(env_id)
    for seed in range(50):
        env.reset(seed=seed)
    objects = live_pymunk_objects()
    bodies = len(env.world.space.bodies)
    before = c_heap_bytes()
    resets = 300
    for seed in range(50, 50 + resets):
        env.reset(seed=seed)
    grown = c_heap_bytes() - before
    assert live_pymunk_objects() == objects, "resets leave pymunk objects (or whole spaces) alive"
    # One leaked batch read of this space per reset would be resets * bodies * ROW_BYTES or more
    # (with its arrays' slack, about 400 bytes a reset even for the 5 bodies of Rendezvous-v0,
    # whose walls are joined). Blocks of up to ~50 kB come and go between two readings without
    # growing (seen over 800 resets), hence the floor.
    limit = max(resets * bodies * ROW_BYTES / 2, 64_000)
    assert grown < limit, f"{env_id}: {resets} resets left {grown} bytes on the C heap (limit {limit:.0f})"
