"""Env-steps/s of Navigation-v0 beside a bare pymunk loop and MPE2's simple_spread.

All three run in one process, interleaved over several rounds; the best round of each is
reported (the least disturbed by other load on the machine). Random actions are drawn
before timing; no rendering.

* ``teamgym``: ``Navigation-v0`` with N robots and 2 moving obstacles, random actions from
  the action space, episodes reset when they end (resets are included in the time).
* ``bare pymunk``: the same bodies (N motor-driven discs with kinematic control bodies,
  pivot and gear joints; 2 moving polygons driven the same way; 4 boundary walls), the same
  20 substeps per control step and 8 ray casts per robot every step, written with pymunk's
  public API and nothing else (no observations, rewards or checks).
* ``MPE2 simple_spread``: N agents, continuous actions, ``max_cycles`` large.

Targets (issue 2, N = 5): teamgym time per step at most 2x the bare loop, and teamgym
env-steps/s at least 2x MPE2's.

    python benchmarks/bench_navigation.py [--steps 3000] [--rounds 3] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time

import numpy as np
import pymunk

import teamgym
from teamgym.sim.sensors import KHEPERA_RING


def time_teamgym(n_robots: int, steps: int, seed: int = 0) -> float:
    env = teamgym.make("Navigation-v0", n_robots=n_robots, n_obstacles=2)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    space = env.action_space(env.possible_agents[0])
    pool = [{a: rng.uniform(space.low, space.high).astype(np.float32) for a in env.possible_agents} for _ in range(256)]
    start = time.perf_counter()
    for i in range(steps):
        if not env.agents:
            env.reset()
        actions = pool[i % 256]
        env.step({a: actions[a] for a in env.agents})
    return steps / (time.perf_counter() - start)


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
        for body, _, _, shape_filter in self.robots:
            x, y = body.position
            c, s = math.cos(body.angle), math.sin(body.angle)
            for ca, sa in zip(self.ray_cos, self.ray_sin):
                dx, dy = c * ca - s * sa, s * ca + c * sa
                start = (x + 0.0275 * dx, y + 0.0275 * dy)
                self.space.segment_query_first(start, (start[0] + 0.1 * dx, start[1] + 0.1 * dy), 0.0, shape_filter)


def time_bare(n_robots: int, steps: int) -> float:
    loop = BareLoop(n_robots)
    start = time.perf_counter()
    for i in range(steps):
        loop.step(i)
    return steps / (time.perf_counter() - start)


def time_mpe2(n_agents: int, steps: int, seed: int = 0) -> float | None:
    try:
        from mpe2 import simple_spread_v3
    except ImportError:
        return None
    env = simple_spread_v3.parallel_env(N=n_agents, max_cycles=10**9, continuous_actions=True)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    space = env.action_space(env.agents[0])
    pool = [{a: rng.uniform(space.low, space.high).astype(np.float32) for a in env.agents} for _ in range(256)]
    start = time.perf_counter()
    for i in range(steps):
        env.step(pool[i % 256])
    return steps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--robots", type=int, nargs="+", default=[3, 5])
    parser.add_argument("--json", type=str, default=None)
    args = parser.parse_args()
    best: dict[tuple[str, int], float] = {}
    for _ in range(args.rounds):
        for n in args.robots:
            for name, fn in (("teamgym", time_teamgym), ("bare pymunk", time_bare), ("MPE2 simple_spread", time_mpe2)):
                rate = fn(n, args.steps)
                if rate is not None:
                    best[(name, n)] = max(best.get((name, n), 0.0), rate)
    machine = platform.processor() or platform.machine()
    print(f"Navigation-v0 speed, best of {args.rounds} rounds x {args.steps} steps ({machine})")
    print(f"{'N':>3}  {'teamgym':>10}  {'bare pymunk':>12}  {'MPE2':>10}  {'env/bare time':>13}  {'teamgym/MPE2':>12}")
    rows = []
    for n in args.robots:
        env_rate, bare_rate = best[("teamgym", n)], best[("bare pymunk", n)]
        mpe_rate = best.get(("MPE2 simple_spread", n))
        ratio_bare = bare_rate / env_rate
        ratio_mpe = env_rate / mpe_rate if mpe_rate else float("nan")
        mpe_text = f"{mpe_rate:10.0f}" if mpe_rate else f"{'n/a':>10}"
        print(f"{n:>3}  {env_rate:10.0f}  {bare_rate:12.0f}  {mpe_text}  {ratio_bare:12.2f}x  {ratio_mpe:11.2f}x")
        rows.append({"n_robots": n, "teamgym": env_rate, "bare_pymunk": bare_rate, "mpe2": mpe_rate})
    print("targets (N=5): env/bare time <= 2.00x, teamgym/MPE2 >= 2.00x")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(rows, handle, indent=2)


if __name__ == "__main__":
    main()
