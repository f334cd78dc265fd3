"""Env-steps/s of Navigation-v0 beside a bare pymunk loop and MPE2's simple_spread.

All three run in one process, interleaved in short chunks (``--chunk`` steps each) over
``--rounds`` rounds; the fastest chunk of each is reported (the least disturbed by other load
on a shared machine), with the median chunk beside it. Random actions are drawn before
timing; no rendering.

* ``teamgym``: ``Navigation-v0`` with N robots and 2 moving obstacles, random actions from
  the action space, episodes reset when they end (resets are included in the time).
* ``bare pymunk``: the same bodies (N motor-driven discs with kinematic control bodies,
  pivot and gear joints; 2 moving polygons driven the same way; 4 boundary walls), the same
  20 substeps per control step and 8 ray casts per robot every step, written with pymunk's
  public API and nothing else; it builds a plain observation per robot (pose, velocities,
  ray hits) but computes no rewards and checks nothing.
* ``bare + contract``: the bare loop behind the smallest PettingZoo parallel step: a dict of
  actions in, checked in one numpy pass (agents, shape, bounds, NaN: invalid actions must be
  refused before any work), and five dicts out keyed by agent (observation rows, a reward, termination,
  truncation, ``infos`` with ``success``). No rewards worth the name, no metrics: the floor
  of any env with this API on these bodies, beside which issue 15's 1.2x is judged.
* ``MPE2 simple_spread``: N agents, continuous actions, ``max_cycles`` large.
* ``batch/K`` (``--batch K``, default 16): K copies stepped as one
  :class:`~teamgym.envs.navigation.batch.NavigationBatch` (arrays in and out, one numpy pass
  for all copies), counted as K env steps per call: the cost of an env step when copies share it.

Targets: issue 2, N = 5: teamgym time per step at most 2x the bare loop, and teamgym
env-steps/s at least 2x MPE2's; issue 15: at most 1.2x the bare loop.

    python benchmarks/bench_navigation.py [--chunk 200] [--rounds 15] [--json out.json]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import platform
import time
from collections.abc import Callable

import numpy as np
import pymunk

import teamgym
from teamgym.sim.sensors import KHEPERA_RING


class TeamgymLoop:
    """``Navigation-v0`` stepped with random actions; a finished episode is reset."""

    def __init__(self, n_robots: int, seed: int = 0) -> None:
        self.env = teamgym.make("Navigation-v0", n_robots=n_robots, n_obstacles=2)
        self.env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        space = self.env.action_space(self.env.possible_agents[0])
        agents = self.env.possible_agents
        self.pool = [{a: rng.uniform(space.low, space.high).astype(np.float32) for a in agents} for _ in range(256)]

    def step(self, i: int) -> None:
        env = self.env
        if not env.agents:
            env.reset()
        actions = self.pool[i % 256]
        env.step({a: actions[a] for a in env.agents})


def drive_on_arc(body: pymunk.Body, control: pymunk.Body, pivot: pymunk.PivotJoint, v: float, omega: float) -> None:
    """Put a robot's kinematic control body on the arc of ``(v, ω)`` from the robot's pose (public pymunk API)."""
    x, y = body.position
    theta = body.angle
    control.angle = theta
    if abs(omega) < 1e-9:
        control.position = (x, y)
        control.velocity = (v * math.cos(theta), v * math.sin(theta))
        control.angular_velocity = 0.0
        pivot.anchor_a = (0.0, 0.0)
    else:
        radius = v / omega
        control.position = (x - radius * math.sin(theta), y + radius * math.cos(theta))
        control.velocity = (0.0, 0.0)
        control.angular_velocity = omega
        pivot.anchor_a = (0.0, -radius)


def time_teamgym(n_robots: int, steps: int, seed: int = 0) -> float:
    """Steps/s of ``Navigation-v0`` with ``n_robots`` robots over ``steps`` steps of random actions."""
    return chunk_rate(TeamgymLoop(n_robots, seed), 0, steps)


class BatchLoop:
    """``batch`` copies of ``Navigation-v0`` stepped together (:class:`NavigationBatch`); one call is ``batch`` env steps."""

    def __init__(self, n_robots: int, batch: int, seed: int = 0) -> None:
        from teamgym.envs.navigation.batch import NavigationBatch

        self.steps_per_call = batch
        self.batch = NavigationBatch(batch, n_robots=n_robots, n_obstacles=2)
        self.batch.reset(seed=seed)
        space = self.batch.action_space
        rng = np.random.default_rng(seed)
        self.pool = rng.uniform(space.low, space.high, size=(256, batch, n_robots, 2)).astype(np.float32)

    def step(self, i: int) -> None:
        batch = self.batch
        for k in np.flatnonzero(batch.episode_over()).tolist():
            batch.reset_copy(k)
        batch.step(self.pool[i % 256])


class BareLoop:
    """The physics and sensing of Navigation-v0 with plain pymunk calls."""

    def __init__(self, n_robots: int, seed: int = 0, substeps: int = 20, dt: float = 0.1) -> None:
        rng = np.random.default_rng(seed)
        self.space = space = pymunk.Space()
        space.collision_slop = 2e-4
        self.dt, self.substeps = dt, substeps
        size, t = 2.0, 0.01
        corners = [(-t, -t), (size + t, -t), (size + t, size + t), (-t, size + t)]
        for i in range(4):
            wall = pymunk.Body(body_type=pymunk.Body.STATIC)
            space.add(wall, pymunk.Segment(wall, corners[i], corners[(i + 1) % 4], t))
        self.robots = []
        for k in range(n_robots):
            body = pymunk.Body(0.08, pymunk.moment_for_circle(0.08, 0, 0.0275))
            body.position = (0.2 + 0.35 * k % 1.6, 0.3 + 0.3 * (k // 5))
            shape = pymunk.Circle(body, 0.0275)
            shape.filter = pymunk.ShapeFilter(group=k + 1)
            control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            pivot = pymunk.PivotJoint(control, body, (0, 0), (0, 0))
            pivot.max_bias, pivot.max_force = 0.0, 0.6
            gear = pymunk.GearJoint(control, body, 0.0, 1.0)
            gear.max_bias, gear.max_force = 0.0, 0.6 * 0.053 / 2
            space.add(body, shape, control, pivot, gear)
            self.robots.append((body, control, pivot, shape.filter))
        self.movers = []
        for k in range(2):
            verts = [(0.08 * math.cos(a), 0.08 * math.sin(a)) for a in np.linspace(0, 2 * np.pi, 6)[:-1]]
            body = pymunk.Body(1.0, pymunk.moment_for_poly(1.0, verts))
            body.position = (0.5 + 1.0 * k, 1.4)
            control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            control.velocity = (0.2 * math.cos(k + 0.3), 0.2 * math.sin(k + 0.3))
            pivot = pymunk.PivotJoint(control, body, (0, 0), (0, 0))
            pivot.max_bias, pivot.max_force = 0.0, 5.0
            gear = pymunk.GearJoint(control, body, 0.0, 1.0)
            gear.max_bias, gear.max_force = 0.0, 0.5
            space.add(body, pymunk.Poly(body, verts), control, pivot, gear)
            self.movers.append((body, control))
        self.commands = rng.uniform([-0.4, -15.0], [0.4, 15.0], size=(256, n_robots, 2))
        self.ray_cos = np.cos(KHEPERA_RING).tolist()
        self.ray_sin = np.sin(KHEPERA_RING).tolist()

    def step(self, i: int) -> None:
        for (body, control, pivot, _), (v, omega) in zip(self.robots, self.commands[i % 256].tolist()):
            drive_on_arc(body, control, pivot, v, omega)
        for body, control in self.movers:
            x, y = body.position
            vx, vy = control.velocity
            if (x < 0.1 and vx < 0) or (x > 1.9 and vx > 0):
                vx = -vx
            if (y < 0.1 and vy < 0) or (y > 1.9 and vy > 0):
                vy = -vy
            control.velocity = (vx, vy)
        h = self.dt / self.substeps
        for _ in range(self.substeps):
            self.space.step(h)
        rows = []
        for body, _, _, shape_filter in self.robots:
            x, y = body.position
            vx, vy = body.velocity
            row = [x, y, body.angle, vx, vy, body.angular_velocity]
            c, s = math.cos(body.angle), math.sin(body.angle)
            for ca, sa in zip(self.ray_cos, self.ray_sin):
                dx, dy = c * ca - s * sa, s * ca + c * sa
                start = (x + 0.0275 * dx, y + 0.0275 * dy)
                hit = self.space.segment_query_first(start, (start[0] + 0.1 * dx, start[1] + 0.1 * dy), 0.0, shape_filter)
                row.append(0.1 if hit is None else 0.1 * hit.alpha)
            rows.append(row)
        self.observation = np.array(rows, dtype=np.float32)


class ContractLoop(BareLoop):
    """:class:`BareLoop` behind the smallest PettingZoo parallel ``step``: dicts in, checked, dicts out."""

    def __init__(self, n_robots: int, seed: int = 0) -> None:
        super().__init__(n_robots, seed)
        self.agents = [f"robot_{k}" for k in range(n_robots)]
        self.agent_set = frozenset(self.agents)
        rng = np.random.default_rng(seed)
        self.pool = [{a: rng.uniform(-1, 1, 2).astype(np.float32) for a in self.agents} for _ in range(256)]
        self.scale = np.array([0.4, 15.0])

    def step(self, i: int) -> None:
        self.parallel_step(self.pool[i % 256])

    def parallel_step(self, actions: dict[str, np.ndarray]) -> tuple[dict, ...]:
        """One check of the whole joint action (agents, shape, bounds, NaN), then the bare step and five dicts."""
        if actions.keys() != self.agent_set:
            raise ValueError(f"actions for {sorted(actions)}, expected {self.agents}")
        joint = np.stack([actions[a] for a in self.agents])
        if joint.shape != (len(self.agents), 2) or not np.all((joint >= -1.0) & (joint <= 1.0)):
            raise ValueError("an action is outside [-1, 1]^2 or NaN")
        self.commands[0] = joint * self.scale
        BareLoop.step(self, 0)
        rows = self.observation
        observations = {a: rows[k] for k, a in enumerate(self.agents)}
        rewards = {a: -float(rows[k, 0]) for k, a in enumerate(self.agents)}
        done = {a: False for a in self.agents}
        infos = {a: {"success": False} for a in self.agents}
        return observations, rewards, done, dict(done), infos


class MPE2Loop:
    """MPE2's ``simple_spread`` with N agents and continuous random actions."""

    def __init__(self, n_agents: int, seed: int = 0) -> None:
        from mpe2 import simple_spread_v3

        self.env = simple_spread_v3.parallel_env(N=n_agents, max_cycles=10**9, continuous_actions=True)
        self.env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        space = self.env.action_space(self.env.agents[0])
        self.pool = [{a: rng.uniform(space.low, space.high).astype(np.float32) for a in self.env.agents} for _ in range(256)]

    def step(self, i: int) -> None:
        self.env.step(self.pool[i % 256])


def make_loops(n: int, batch: int = 0) -> dict[str, object]:
    loops: dict[str, object] = {"teamgym": TeamgymLoop(n), "bare pymunk": BareLoop(n), "bare + contract": ContractLoop(n)}
    if batch:
        loops[f"batch/{batch}"] = BatchLoop(n, batch)
    with contextlib.suppress(ImportError):
        loops["MPE2 simple_spread"] = MPE2Loop(n)
    return loops


CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def physics_share(n_robots: int, steps: int, clock=time.perf_counter) -> float:
    """Share of ``Navigation-v0``'s step time spent in the physics substeps (``World._integrate``)."""
    return physics_share_of(lambda: TeamgymLoop(n_robots), steps, clock)


def physics_share_of(make_loop: Callable[[], object], steps: int, clock=time.perf_counter) -> float:
    """Share of a loop's step time spent in ``World._integrate``.

    Measured in a separate run with a timer around ``World._integrate``, so the timed chunks
    carry no timer overhead.
    """
    from teamgym.sim.world import World

    spent = [0.0]
    original = World._integrate

    def timed(world: World, h: float, n: int) -> None:
        begin = clock()
        original(world, h, n)
        spent[0] += clock() - begin

    World._integrate = timed
    try:
        loop = make_loop()
        chunk_rate(loop, 0, steps, clock)  # warm-up
        spent[0] = 0.0
        begin = clock()
        for i in range(steps, 2 * steps):
            loop.step(i)
        return spent[0] / (clock() - begin)
    finally:
        World._integrate = original


def chunk_rate(loop, start: int, steps: int, clock=time.perf_counter) -> float:
    """Steps per second over ``steps`` steps of ``loop`` starting at step ``start``, timed by ``clock``."""
    begin = clock()
    for i in range(start, start + steps):
        loop.step(i)
    return steps * getattr(loop, "steps_per_call", 1) / (clock() - begin)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--chunk", type=int, default=200, help="steps per timed chunk")
    parser.add_argument("--rounds", type=int, default=15, help="chunks per contender, interleaved")
    parser.add_argument("--robots", type=int, nargs="+", default=[3, 5])
    parser.add_argument("--json", type=str, default=None)
    parser.add_argument(
        "--batch", type=int, default=16, help="also time this many copies stepped as one NavigationBatch (0: not)"
    )
    parser.add_argument(
        "--clock",
        choices=sorted(CLOCKS),
        default="wall",
        help="wall time, or this process's CPU time (for a machine busy with other jobs)",
    )
    args = parser.parse_args()
    clock = CLOCKS[args.clock]
    rates: dict[tuple[str, int], list[float]] = {}
    for n in args.robots:
        loops = make_loops(n, args.batch)
        for loop in loops.values():
            chunk_rate(loop, 0, max(1, args.chunk // getattr(loop, "steps_per_call", 1)), clock)  # warm-up
        for k in range(args.rounds):
            for name, loop in loops.items():
                calls = max(1, args.chunk // getattr(loop, "steps_per_call", 1))  # about the same time per contender
                rates.setdefault((name, n), []).append(chunk_rate(loop, (k + 1) * calls, calls, clock))
    machine = platform.processor() or platform.machine()
    print(
        f"Navigation-v0 steps/s ({args.clock} clock): fastest (median) of {args.rounds} interleaved chunks "
        f"x {args.chunk} steps ({machine})"
    )
    print(f"{'N':>3}  {'teamgym':>14}  {'bare pymunk':>14}  {'MPE2':>14}  {'env/bare time':>13}  {'teamgym/MPE2':>12}")
    rows = []
    for n in args.robots:
        best = {name: max(r) for (name, m), r in rates.items() if m == n}
        median = {name: float(np.median(r)) for (name, m), r in rates.items() if m == n}
        env_rate, bare_rate, mpe_rate = best["teamgym"], best["bare pymunk"], best.get("MPE2 simple_spread")

        def cell(name: str, best: dict = best, median: dict = median) -> str:
            return f"{best[name]:6.0f} ({median[name]:5.0f})" if name in best else f"{'n/a':>14}"

        ratio_mpe = env_rate / mpe_rate if mpe_rate else float("nan")
        print(
            f"{n:>3}  {cell('teamgym'):>14}  {cell('bare pymunk'):>14}  {cell('MPE2 simple_spread'):>14}  "
            f"{bare_rate / env_rate:12.2f}x  {ratio_mpe:11.2f}x"
        )
        row = {"n_robots": n, "teamgym": env_rate, "bare_pymunk": bare_rate, "mpe2": mpe_rate, "median": median}
        if args.batch:
            row["batch"] = best[f"batch/{args.batch}"]
            print(
                f"{'':>3}  {args.batch} copies as one NavigationBatch: {cell(f'batch/{args.batch}')} env-steps/s, "
                f"env/bare time per copy {bare_rate / row['batch']:.2f}x"
            )
        row["contract"] = best["bare + contract"]
        print(
            f"{'':>3}  bare + PettingZoo contract: {cell('bare + contract')} steps/s, "
            f"its time / bare time {bare_rate / row['contract']:.2f}x"
        )
        rows.append(row)
    print("targets (N=5): env/bare time <= 2.00x (issue 2), <= 1.20x (issue 15); teamgym/MPE2 >= 2.00x")
    for row in rows:
        row["physics_share"] = physics_share(row["n_robots"], args.chunk * 5, clock)
        print(f"N={row['n_robots']}: physics substeps are {100 * row['physics_share']:.0f} % of a teamgym step")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(rows, handle, indent=2)


if __name__ == "__main__":
    main()
