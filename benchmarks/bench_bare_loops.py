"""Env-steps/s of BoxPushing-v0 (S3) and Exploration-v0 beside bare pymunk loops with the same bodies (issue 15).

Each env and its bare loop run in one process, interleaved in short chunks (``--chunk`` steps
each) over ``--rounds`` rounds, as in ``benchmarks/bench_navigation.py``; the fastest chunk is
reported with the median chunk beside it. Random actions are drawn before timing (the env and
its bare loop get the same numbers); no rendering. The env loops reset finished episodes
(resets are included in the time; with the default chunk sizes no episode ends).

* ``BoxPushing-v0``, situation S3, ``action_type="wheels"`` (one env step = one control step):
  4 robots, 1 heavy box, 4 boundary walls, lamp beside the table. Also timed with
  ``action_type="primitives"`` (the paper's discrete actions, one control step per env step) against the same bare loop.
* ``Exploration-v0``, default config (``office12``, 3 robots, ``action_type="velocity"``, one
  control step per env step; the macro ``operator`` type is not timed).

What a bare loop contains (pymunk's public API and plain Python only; the scene is read once,
before timing, from an env reset with the same seed, so both start from the same state):

* the same bodies, shapes and joints as ``env.world.space`` (checked at start-up: counts of
  bodies, shapes and constraints by type, masses, friction coefficients and joint force limits):
  robots are motor-driven discs held to kinematic control bodies by a pivot and a gear joint
  with ``max_bias = 0`` and the motors' force and torque limits (``DiffDriveRobot``); a box is a
  square polygon held to a resting kinematic body by a pivot and a gear joint with the ground
  friction limits ``μ m g`` and ``μ m g · ⅔ r_eq`` (``Box``); walls, doors and furniture are
  static segments and polygons, one static body each (an open door is a static body without
  a shape, as in the env);
* the same physics settings (``dt``, ``substeps`` = 20, ``collision_slop``, ``iterations``),
  every substep through ``Space.step``;
* per control step: the wheel speeds (BoxPushing) or ``(v, ω)`` saturated at the wheel limit
  (Exploration) turned into the control bodies' arc motion, as the env does;
* the sensors: 8 proximity rays per robot (Khepera ring, range ``sensor_range``) cast with
  ``Space.segment_query_first`` every step; BoxPushing also the 8 light readings
  ``max(0, cos(φ − α_i)) / max(d, 0.05)²`` in plain Python (the env's default lamp casts no
  shadows, ``light_shadows=False``, so neither loop makes an occlusion query) and the 4
  encoder values (commanded and actual wheel rotation from the poses before and after);
* a plain float32 observation per robot: BoxPushing the env's 21 values (proximity, light,
  encoders, busy = 0); Exploration pose, forward speed, ω and the 8 rays (13 values; the env's
  observation also holds one-hot sectors and places of every robot, the explored set, door
  beliefs, clutter and task status).

At start-up the env (wheels / velocity) and its bare loop are stepped 100 steps side by side
from fresh copies with the same actions, and the largest difference of the robots' poses is
printed (when written: 0 for BoxPushing, under 1e-13 m for Exploration; the proximity and light
readings and encoders matched too).

What a bare loop leaves out: no contact callback and no contact counting (the env's world has
a Python ``begin`` handler on every pair), no rewards, no goal or delivery checks, no
sector/place bookkeeping, no trails, no infos or metrics, no action checks, no primitive
executors, no episode ends. By default the bare loop casts all 8 rays of every robot every
step (the issue's definition); the env first asks whether anything is within range of a robot
(one point query) and skips its 8 casts if not. ``--bare-skip`` gives the bare loop the same
test (``Space.point_query_nearest``), so both cast the same rays.

The physics share of an env step is timed in a separate run, with a timer around
``World._integrate`` (the chunks above carry no timer).

    python benchmarks/bench_bare_loops.py [--envs boxpushing exploration] [--chunk 200] [--rounds 15]
        [--clock {wall,cpu}] [--bare-skip] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pymunk

import teamgym
from teamgym.sim.categories import Category
from teamgym.sim.objects import GRAVITY, SURFACE_FRICTION
from teamgym.sim.sensors import KHEPERA_RING

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_navigation import CLOCKS, chunk_rate, drive_on_arc, physics_share_of  # noqa: E402

#: Short name -> (env id, config) of each env timed; ``boxpushing`` also times its ``primitives`` action type.
ENVS: dict[str, tuple[str, dict]] = {
    "boxpushing": ("BoxPushing-v0", {"situation": "S3", "action_type": "wheels"}),
    "exploration": ("Exploration-v0", {}),
}
POOL = 256
WALL_FRICTION, FURNITURE_FRICTION = 0.3, 0.5  # teamgym.sim.objects.Wall and StaticPolygon


def action_pool(env, seed: int) -> list[dict]:
    """``POOL`` joint random actions from the env's action space (the same numbers for every ``seed``)."""
    rng = np.random.default_rng(seed)
    space = env.action_space(env.possible_agents[0])
    agents = env.possible_agents
    if hasattr(space, "n"):
        return [{a: int(rng.integers(space.n)) for a in agents} for _ in range(POOL)]
    return [{a: rng.uniform(space.low, space.high).astype(np.float32) for a in agents} for _ in range(POOL)]


class EnvLoop:
    """An env stepped with random actions; a finished episode is reset."""

    def __init__(self, env_id: str, config: dict, seed: int = 0) -> None:
        self.env = teamgym.make(env_id, **config)
        self.env.reset(seed=seed)
        self.pool = action_pool(self.env, seed)

    def step(self, i: int) -> None:
        env = self.env
        if not env.agents:
            env.reset()
        actions = self.pool[i % POOL]
        env.step({a: actions[a] for a in env.agents})


class BareRobots:
    """Differential-drive discs in a plain pymunk space: bodies, drive joints, commands and the proximity ring."""

    def __init__(self, env, seed: int, skip_free: bool) -> None:
        space = env.world.space
        self.space = pymunk.Space()
        self.space.gravity = (0.0, 0.0)
        self.space.collision_slop = space.collision_slop
        self.space.iterations = space.iterations
        self.dt, self.substeps = env.config.dt, env.config.substeps
        self.skip_free = skip_free
        spec = env.spec_robot
        self.radius, self.wheel_base, self.wheel_radius, self.max_wheel = (
            spec.radius,
            spec.wheel_base,
            spec.wheel_radius,
            spec.max_wheel_speed,
        )
        self.ray_range = env.config.sensor_range
        self.ray_cos = np.cos(KHEPERA_RING).tolist()
        self.ray_sin = np.sin(KHEPERA_RING).tolist()
        self.robots: list[tuple[pymunk.Body, pymunk.Body, pymunk.PivotJoint, pymunk.ShapeFilter]] = []
        for k, agent in enumerate(env.possible_agents):
            start = env.robots[agent].body
            body = pymunk.Body(spec.mass, pymunk.moment_for_circle(spec.mass, 0.0, spec.radius))
            body.position, body.angle = start.position, start.angle
            shape = pymunk.Circle(body, spec.radius)
            shape.friction, shape.elasticity = spec.friction, spec.elasticity
            shape.filter = pymunk.ShapeFilter(group=k + 1)  # the robot's rays pass through itself
            control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            control.position, control.angle = start.position, start.angle
            pivot = pymunk.PivotJoint(control, body, (0.0, 0.0), (0.0, 0.0))
            pivot.max_bias, pivot.max_force = 0.0, spec.max_motor_force
            gear = pymunk.GearJoint(control, body, 0.0, 1.0)
            gear.max_bias, gear.max_force = 0.0, spec.max_motor_force * spec.wheel_base / 2
            self.space.add(body, shape, control, pivot, gear)
            self.robots.append((body, control, pivot, shape.filter))
        pool = action_pool(env, seed)
        self.actions = [[pool[i][a].tolist() for a in env.possible_agents] for i in range(POOL)]

    def add_static_segment(self, a: tuple[float, float], b: tuple[float, float], thickness: float, solid: bool = True) -> None:
        """A wall (or a door; ``solid=False``: an open door, a static body without a shape)."""
        body = pymunk.Body(body_type=pymunk.Body.STATIC)
        if solid:
            shape = pymunk.Segment(body, a, b, thickness / 2)
            shape.friction = WALL_FRICTION
            self.space.add(body, shape)
        else:
            self.space.add(body)

    def drive(self, commands: list[tuple[float, float]]) -> list[tuple[float, float, float]]:
        """Put each control body on the arc of its robot's ``(v, ω)``; returns the poses before the step."""
        poses = []
        for (body, control, pivot, _), (v, omega) in zip(self.robots, commands):
            x, y = body.position
            poses.append((x, y, body.angle))
            drive_on_arc(body, control, pivot, v, omega)
        return poses

    def integrate(self) -> None:
        h = self.dt / self.substeps
        for _ in range(self.substeps):
            self.space.step(h)

    def rays(self, x: float, y: float, theta: float, shape_filter: pymunk.ShapeFilter) -> list[float]:
        """Distances from the rim to the first solid along the 8 rays (``ray_range`` if none)."""
        r, span, space = self.radius, self.ray_range, self.space
        if self.skip_free and space.point_query_nearest((x, y), r + span, shape_filter) is None:
            return [span] * len(self.ray_cos)
        c, s = math.cos(theta), math.sin(theta)
        out = []
        for ca, sa in zip(self.ray_cos, self.ray_sin):
            dx, dy = c * ca - s * sa, s * ca + c * sa
            start = (x + r * dx, y + r * dy)
            hit = space.segment_query_first(start, (start[0] + span * dx, start[1] + span * dy), 0.0, shape_filter)
            out.append(span if hit is None else span * hit.alpha)
        return out


class BoxPushingBare(BareRobots):
    """BoxPushing-v0's physics and sensing (proximity, light, encoders) with plain pymunk calls."""

    def __init__(self, env, seed: int = 0, skip_free: bool = False) -> None:
        super().__init__(env, seed, skip_free)
        c = env.config
        w, h, t = c.table_width, c.table_height, 0.01  # World.add_boundary: 2 cm walls just outside the table
        corners = [(-t, -t), (w + t, -t), (w + t, h + t), (-t, h + t)]
        for i in range(4):
            self.add_static_segment(corners[i], corners[(i + 1) % 4], 2 * t)
        for box in env.world.boxes:
            heavy = env.is_heavy(box.name)
            size, mass = (c.heavy_box_size, c.heavy_box_mass) if heavy else (c.light_box_size, c.light_box_mass)
            verts = [(-size / 2, -size / 2), (size / 2, -size / 2), (size / 2, size / 2), (-size / 2, size / 2)]
            body = pymunk.Body(mass, pymunk.moment_for_poly(mass, verts))
            body.position, body.angle = box.body.position, box.body.angle
            shape = pymunk.Poly(body, verts)
            shape.friction = SURFACE_FRICTION
            ground = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            ground.position, ground.angle = body.position, body.angle
            force = c.box_friction * mass * GRAVITY
            pivot = pymunk.PivotJoint(ground, body, (0.0, 0.0), (0.0, 0.0))
            pivot.max_bias, pivot.max_force = 0.0, force
            gear = pymunk.GearJoint(ground, body, 0.0, 1.0)
            gear.max_bias, gear.max_force = 0.0, force * 2.0 / 3.0 * math.sqrt(size * size / math.pi)
            self.space.add(body, shape, ground, pivot, gear)
        self.lamp = c.lamp
        self.angles = KHEPERA_RING.tolist()

    def step(self, i: int) -> None:
        base, dt, wheel = self.wheel_base, self.dt, self.wheel_radius
        commands = [(0.5 * (left + right), (right - left) / base) for left, right in self.actions[i % POOL]]
        # Wheel speeds from the action space are within the wheel limit: saturation changes nothing.
        before = self.drive(commands)
        self.integrate()
        lx, ly = self.lamp
        half = 0.5 * base
        rows = []
        for (body, _, _, shape_filter), (x0, y0, a0), (v, omega) in zip(self.robots, before, commands):
            x, y = body.position
            theta = body.angle
            row = self.rays(x, y, theta, shape_filter)
            d = math.hypot(lx - x, ly - y)
            bearing = math.atan2(ly - y, lx - x) - theta
            gain = 1.0 / max(d, 0.05) ** 2
            row += [max(0.0, math.cos(bearing - a) * gain) for a in self.angles]
            mid = 0.5 * (a0 + theta)
            ds = (x - x0) * math.cos(mid) + (y - y0) * math.sin(mid)
            da = theta - a0
            row += [
                (v - half * omega) * dt / wheel,
                (v + half * omega) * dt / wheel,
                (ds - half * da) / wheel,
                (ds + half * da) / wheel,
                0.0,
            ]
            rows.append(row)
        self.observation = np.array(rows, dtype=np.float32)


class ExplorationBare(BareRobots):
    """Exploration-v0's physics and proximity sensing with plain pymunk calls; the map read from the env's world."""

    def __init__(self, env, seed: int = 0, skip_free: bool = False) -> None:
        super().__init__(env, seed, skip_free)
        for entity in env.world.entities.values():
            if entity.kind in (Category.WALL, Category.DOOR):
                self.add_static_segment(entity.a, entity.b, entity.thickness, solid=bool(entity.shapes))
            elif entity.kind == Category.FURNITURE:
                body = pymunk.Body(body_type=pymunk.Body.STATIC)
                shape = pymunk.Poly(body, entity.vertices)
                shape.friction = FURNITURE_FRICTION
                self.space.add(body, shape)

    def step(self, i: int) -> None:
        half, limit = 0.5 * self.wheel_base, self.max_wheel
        commands = []
        for v, omega in self.actions[i % POOL]:
            peak = max(abs(v - half * omega), abs(v + half * omega))
            if peak > limit:  # saturate at the wheel limit, keeping the curvature (as DiffDriveRobot.set_command)
                v, omega = v * limit / peak, omega * limit / peak
            commands.append((v, omega))
        self.drive(commands)
        self.integrate()
        rows = []
        for body, _, _, shape_filter in self.robots:
            x, y = body.position
            theta = body.angle
            vx, vy = body.velocity
            row = [x, y, theta, vx * math.cos(theta) + vy * math.sin(theta), body.angular_velocity]
            row += self.rays(x, y, theta, shape_filter)
            rows.append(row)
        self.observation = np.array(rows, dtype=np.float32)


BARE = {"boxpushing": BoxPushingBare, "exploration": ExplorationBare}


def space_signature(space: pymunk.Space) -> dict[str, object]:
    """What must match between a bare loop and the env: object counts by type, masses, frictions, joint limits."""
    bodies = Counter(
        {pymunk.Body.DYNAMIC: "dynamic", pymunk.Body.KINEMATIC: "kinematic"}.get(b.body_type, "static") for b in space.bodies
    )
    return {
        "bodies": len(space.bodies),
        "shapes": len(space.shapes),
        "constraints": len(space.constraints),
        "body types": dict(sorted(bodies.items())),
        "shape types": dict(sorted(Counter(type(s).__name__ for s in space.shapes).items())),
        "constraint types": dict(sorted(Counter(type(c).__name__ for c in space.constraints).items())),
        "masses": sorted(round(b.mass, 9) for b in space.bodies if b.body_type == pymunk.Body.DYNAMIC),
        "frictions": sorted(round(s.friction, 9) for s in space.shapes),
        "joint limits": sorted((type(c).__name__, round(c.max_force, 9), c.max_bias) for c in space.constraints),
        "settings": (space.collision_slop, space.iterations, tuple(space.gravity)),
    }


def check_same(bare: BareRobots, env) -> dict[str, object]:
    """Raise unless the bare loop's space matches the env's; return the env's counts."""
    mine, theirs = space_signature(bare.space), space_signature(env.world.space)
    wrong = [key for key in theirs if mine[key] != theirs[key]]
    if wrong:
        raise AssertionError(
            f"bare loop differs from the env in {wrong}: " + "; ".join(f"{k}: {mine[k]} vs {theirs[k]}" for k in wrong)
        )
    return {key: theirs[key] for key in ("bodies", "shapes", "constraints", "body types")}


def contenders(name: str, skip_free: bool) -> dict[str, tuple[Callable[[], object], bool]]:
    """Label -> (factory, is an env loop) for one env: the env, its bare loop, and for boxpushing the primitives env."""
    env_id, config = ENVS[name]
    out: dict[str, tuple[Callable[[], object], bool]] = {
        f"{env_id} {config.get('action_type', '')}".strip(): (lambda: EnvLoop(env_id, config), True)
    }
    if name == "boxpushing":
        primitives = {**config, "action_type": "primitives"}
        out[f"{env_id} primitives"] = (lambda: EnvLoop(env_id, primitives), True)

    def bare() -> BareRobots:
        template = teamgym.make(env_id, **config)
        template.reset(seed=0)
        loop = BARE[name](template, 0, skip_free)
        loop.counts = check_same(loop, template)
        return loop

    out["bare"] = (bare, False)
    return out


def pose_gap(name: str, steps: int = 100) -> float:
    """Largest difference (m or rad) of the robots' poses in the env (first action type) and its bare loop over ``steps`` steps.

    Both start from the same scene and get the same actions; 0 (or rounding) means the bare loop simulates the same motion.
    """
    factories = contenders(name, False)
    env_loop, bare = next(iter(factories.values()))[0](), factories["bare"][0]()
    worst = 0.0
    for i in range(steps):
        env_loop.step(i)
        bare.step(i)
        mine = np.array([[*body.position, body.angle] for body, *_ in bare.robots])
        worst = max(worst, float(np.abs(env_loop.env.world.robot_states[:, :3] - mine).max()))
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", nargs="+", choices=sorted(ENVS), default=sorted(ENVS))
    parser.add_argument("--chunk", type=int, default=200, help="steps per timed chunk")
    parser.add_argument("--rounds", type=int, default=15, help="chunks per contender, interleaved")
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="wall", help="wall time, or this process's CPU time")
    parser.add_argument(
        "--bare-skip", action="store_true", help="bare loops skip a robot's casts when nothing is in range, as the env"
    )
    parser.add_argument("--json", type=str, default=None)
    args = parser.parse_args()
    clock = CLOCKS[args.clock]
    machine = platform.processor() or platform.machine()
    print(
        f"env-steps/s ({args.clock} clock): fastest (median) of {args.rounds} interleaved chunks x {args.chunk} steps "
        f"({machine}); bare loops {'skip free robots' if args.bare_skip else 'cast all 8 rays'}"
    )
    rows = []
    for name in args.envs:
        factories = contenders(name, args.bare_skip)
        loops = {label: factory() for label, (factory, _) in factories.items()}
        print(f"{name}: env space {loops['bare'].counts} (bare loop: the same)")
        print(f"{name}: robot poses of env and bare loop differ by at most {pose_gap(name):.1e} over 100 steps")
        rates: dict[str, list[float]] = {label: [] for label in loops}
        for loop in loops.values():
            chunk_rate(loop, 0, args.chunk, clock)  # warm-up
        for k in range(args.rounds):
            for label, loop in loops.items():
                rates[label].append(chunk_rate(loop, (k + 1) * args.chunk, args.chunk, clock))
        bare_best, bare_median = max(rates["bare"]), float(np.median(rates["bare"]))
        for label, (factory, is_env) in factories.items():
            if not is_env:
                continue
            best, median = max(rates[label]), float(np.median(rates[label]))
            share = physics_share_of(factory, args.chunk * 5, clock)
            rows.append(
                {
                    "env": label,
                    "env_best": best,
                    "env_median": median,
                    "bare_best": bare_best,
                    "bare_median": bare_median,
                    "ratio_best": bare_best / best,
                    "ratio_median": bare_median / median,
                    "physics_share": share,
                    "space": loops["bare"].counts,
                }
            )
    print(f"{'env':<30} {'env steps/s':>15} {'bare steps/s':>15} {'env/bare time':>15} {'physics share':>14}")
    for row in rows:
        print(
            f"{row['env']:<30} {row['env_best']:7.0f} ({row['env_median']:5.0f}) "
            f"{row['bare_best']:7.0f} ({row['bare_median']:5.0f}) "
            f"{row['ratio_best']:6.2f}x ({row['ratio_median']:.2f}x) {100 * row['physics_share']:12.0f} %"
        )
    print("target (issue 15): env/bare time as close as Navigation-v0's (<= 1.20x); ratio: fastest chunks (medians)")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(rows, handle, indent=2)


if __name__ == "__main__":
    main()
