"""``NavigationArrays``: Navigation's per-step arrays for K env copies, computed in one numpy pass.

Every array has a leading copy axis ``k`` (then robot ``i``, then object ``j``); a single
:class:`~teamgym.envs.navigation.env.Navigation` env is the case K = 1, and a
:class:`~teamgym.envs.batch.TeamBatch` of Navigation copies
(:class:`~teamgym.envs.navigation.phases.NavigationPhases`) steps K copies with one call of
each method below instead of K. Methods take ``ks``, a ``slice`` of copies (views, so
writes land in the shared arrays), and ``live``, a ``(k, N)`` mask of the robots still in
their episode. Rows of arrived robots are computed too and masked where it matters, so a
row's numbers do not depend on the other rows (the observation hashes of the single env
are unchanged by the batch form).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from teamgym.control.forces import MIN_DISTANCE, ForceGains, attraction, repulsion
from teamgym.sim.chipmunk import shape_distance
from teamgym.sim.sensors import KHEPERA_RING

if TYPE_CHECKING:
    import pymunk

    from teamgym.envs.navigation.config import NavigationConfig
    from teamgym.envs.spaces import ObservationLayout

__all__ = ["FORCE_ROWS", "NavigationArrays", "force_log_bound"]

#: Rows of the ``forces`` observation field (``virtual_forces``): the sources, then their sum.
FORCE_ROWS = ("goal", "mates", "obstacles", "rays", "total")


def force_log_bound(config: NavigationConfig, rays: int) -> float:
    """Upper bound of log(1 + |F|) in field ``forces``: every source at the clamped distance ``MIN_DISTANCE``."""
    g = ForceGains()
    sources = g.k_a + (config.n_robots - 1) * g.k_r + (config.n_obstacles + rays) * g.k_rb
    return float(np.log1p(sources / MIN_DISTANCE**2))


#: Margin (m) beyond the sensor range under which a ring is not known to be free (rounding).
FREE_MARGIN = 1e-6

#: Gap (m) under which a robot's distance to an obstacle is measured on the polygon, not its bounding circle.
EXACT_GAP_BELOW = 0.1


class NavigationArrays:
    """Robot and obstacle states, distances, metrics and rewards of ``n_copies`` Navigation copies."""

    def __init__(self, config: NavigationConfig, n_copies: int, ring_width: int) -> None:
        self.config = config
        self.n_copies = 0
        self.ring_width = ring_width
        n = config.n_robots
        self.others = np.array([[j for j in range(n) if j != i] for i in range(n)], dtype=int).reshape(n, n - 1)
        self._rows = np.arange(n)
        #: Per copy: the obstacles' pymunk shapes (for exact distances when a robot is near).
        self.obstacle_shapes: list[list[pymunk.Shape]] = []
        self.grow(n_copies)

    # -- storage ---------------------------------------------------------------------
    def _allocate(self, k: int) -> dict[str, np.ndarray]:
        c = self.config
        n, m = c.n_robots, c.n_obstacles
        return {
            "pos": np.zeros((k, n, 2)),
            "theta": np.zeros((k, n)),
            "vel": np.zeros((k, n, 2)),
            "obs_pos": np.zeros((k, m, 2)),
            "obs_vel": np.zeros((k, m, 2)),
            "goals": np.zeros((k, n, 2)),
            "obstacle_radii": np.zeros((k, m)),
            "contact_radius": np.zeros((k, n + m)),
            "object_offsets": np.zeros((k, n, n + m, 2)),
            "object_gaps": np.zeros((k, n, n + m)),
            "goal_distance": np.zeros((k, n)),
            "progress": np.zeros((k, n)),
            "arrived": np.zeros((k, n), dtype=bool),
            "arriving": np.zeros((k, n), dtype=bool),
            "arrival_time": np.full((k, n), np.nan),
            "collisions": np.zeros((k, n), dtype=int),
            "new_collisions": np.zeros((k, n), dtype=int),
            "smooth_sum": np.zeros((k, n)),
            "smooth_steps": np.zeros((k, n), dtype=int),
            "last_command": np.zeros((k, n, 2)),
            "prev_command": np.zeros((k, n, 2)),
            "min_clearance": np.full((k, n), np.inf),
            "min_center": np.full((k, n), np.inf),
            "proximity": np.zeros((k, n, self.ring_width), dtype=np.float32),
        }

    def grow(self, n_copies: int) -> None:
        """Make room for ``n_copies`` copies (existing copies keep their rows)."""
        extra = n_copies - self.n_copies
        if extra <= 0:
            return
        fresh = self._allocate(extra)
        for name, block in fresh.items():
            old = getattr(self, name, None)
            setattr(self, name, block if old is None else np.concatenate([old, block]))
        self.obstacle_shapes.extend([] for _ in range(extra))
        self.n_copies = n_copies

    def shrink(self, n_copies: int) -> None:
        """Keep only the first ``n_copies`` copies."""
        if n_copies >= self.n_copies:
            return
        for name in self._allocate(0):
            setattr(self, name, getattr(self, name)[:n_copies].copy())
        del self.obstacle_shapes[n_copies:]
        self.n_copies = n_copies

    def row(self, k: int) -> dict[str, Any]:
        """Copy ``k``'s values of every array (copies) and its obstacle shapes, as :meth:`set_row` takes them."""
        values: dict[str, Any] = {name: getattr(self, name)[k].copy() for name in self._allocate(0)}
        values["obstacle_shapes"] = list(self.obstacle_shapes[k])
        return values

    def set_row(self, k: int, values: dict[str, Any]) -> None:
        """Write :meth:`row`'s values into copy ``k``."""
        for name, value in values.items():
            if name == "obstacle_shapes":
                self.obstacle_shapes[k] = list(value)
            else:
                getattr(self, name)[k] = value

    def start(self, k: int, goals: np.ndarray, obstacle_radii: np.ndarray, obstacle_shapes: list) -> None:
        """A new episode in copy ``k``: its goals and obstacles, counters and minima cleared."""
        c = self.config
        self.goals[k] = goals
        self.obstacle_radii[k] = obstacle_radii
        # Centre distance at which a robot touches each object (robots first, then obstacles'
        # bounding circles): gap = centre distance − contact radius.
        self.contact_radius[k, : c.n_robots] = 2 * c.robot_radius
        self.contact_radius[k, c.n_robots :] = c.robot_radius + obstacle_radii
        self.obstacle_shapes[k] = list(obstacle_shapes)
        for name in ("arrived", "arriving", "collisions", "new_collisions", "smooth_sum", "smooth_steps"):
            getattr(self, name)[k] = 0
        for name in ("last_command", "prev_command", "progress"):
            getattr(self, name)[k] = 0.0
        self.arrival_time[k] = np.nan
        self.min_clearance[k] = np.inf
        self.min_center[k] = np.inf
        self.proximity[k] = c.sensor_range

    # -- phases ----------------------------------------------------------------------
    def read(self, ks: slice, robots: np.ndarray, movers: np.ndarray) -> None:
        """Poses and velocities from body rows ``(x, y, angle, vx, vy, ω)``: ``robots`` (k, N, 6), ``movers`` (k, M, 6)."""
        self.pos[ks] = robots[..., 0:2]
        angle = robots[..., 2]
        self.theta[ks] = np.pi - np.mod(np.pi - angle, 2 * np.pi)
        vel = self.vel[ks]
        np.multiply(robots[..., 3], np.cos(angle), out=vel[..., 0])
        vel[..., 0] += robots[..., 4] * np.sin(angle)
        vel[..., 1] = robots[..., 5]
        self.obs_pos[ks] = movers[..., 0:2]
        self.obs_vel[ks] = movers[..., 3:5]

    def update_distances(self, ks: slice) -> None:
        """Offsets and gaps from each robot to each object (robots, then obstacles), and the minima.

        Gaps are centre distance minus radii (bounding radius for obstacles), the inputs of the
        speed rule of eq. (12); ``min_clearance`` measures obstacles on their polygon when near.
        """
        n = self.config.n_robots
        pos = self.pos[ks]
        has_obstacles = self.obs_pos.shape[1] > 0
        points = np.concatenate([pos, self.obs_pos[ks]], axis=1) if has_obstacles else pos
        offsets = self.object_offsets[ks]
        np.subtract(points[:, None, :, :], pos[:, :, None, :], out=offsets)
        d = np.sqrt(np.einsum("kijl,kijl->kij", offsets, offsets))
        d[:, self._rows, self._rows] = np.inf
        gaps = self.object_gaps[ks]
        np.subtract(d, self.contact_radius[ks][:, None, :], out=gaps)
        exact = gaps.min(axis=2)
        if has_obstacles:
            near = gaps[:, :, n:] < EXACT_GAP_BELOW
            if near.any():
                exact_obstacles = gaps[:, :, n:].copy()
                r, first = self.config.robot_radius, ks.start or 0
                for k, i, j in zip(*np.nonzero(near)):
                    point = pos[k, i].tolist()
                    exact_obstacles[k, i, j] = shape_distance(self.obstacle_shapes[first + k][j], point) - r
                exact = np.minimum(gaps[:, :, :n].min(axis=2), exact_obstacles.min(axis=2))
        np.minimum(self.min_clearance[ks], exact, out=self.min_clearance[ks])
        np.minimum(self.min_center[ks], d.min(axis=2), out=self.min_center[ks])

    def sensing_free(self, ks: slice) -> np.ndarray:
        """``(k, N)``: robots with nothing within ``sensor_range`` of their rim, whose rays can hit nothing.

        From the gaps of :meth:`update_distances` (bounding circles: a lower bound for obstacles)
        and the walls' inner faces at the arena's edges; ``False`` only means "cast the rays".
        """
        c = self.config
        reach = c.sensor_range + FREE_MARGIN
        free = self.object_gaps[ks].min(axis=2) > reach if self.object_gaps.shape[2] else np.ones(self.pos[ks].shape[:2], bool)
        if c.walls:
            pos = self.pos[ks]
            wall_gap = np.minimum(pos.min(axis=2), c.arena_size - pos.max(axis=2)) - c.robot_radius
            free &= wall_gap > reach
        return free

    def command(self, ks: slice, live: np.ndarray, commands: np.ndarray) -> None:
        """The commands ``(v, ω)`` (k, N, 2) that the live robots execute this control step."""
        np.copyto(self.prev_command[ks], self.last_command[ks], where=live[..., None])
        np.copyto(self.last_command[ks], commands, where=live[..., None])

    def after_physics(self, ks: slice, live: np.ndarray, hits: np.ndarray) -> None:
        """Contacts (``hits``, k × N), progress towards the goals and smoothness J_i (section 6.2) of the live robots."""
        if hits.any():
            hits = np.where(live, hits, 0)
            self.collisions[ks] += hits
            self.new_collisions[ks] += hits
        offset = self.goals[ks] - self.pos[ks]
        distance = np.sqrt(np.einsum("kij,kij->ki", offset, offset))
        np.subtract(self.goal_distance[ks], distance, out=self.progress[ks])
        self.goal_distance[ks] = distance
        du = self.last_command[ks] - self.prev_command[ks]
        self.smooth_sum[ks] += np.where(live, np.einsum("kij,kij->ki", du, du), 0.0)
        self.smooth_steps[ks] += live

    def check_goals(self, ks: slice, live: np.ndarray, time: np.ndarray | float) -> np.ndarray:
        """Live robots within ``goal_tolerance`` arrive now (at ``time`` s, per copy); returns them (k, N)."""
        arriving = self.arriving[ks]
        np.less(self.goal_distance[ks], self.config.goal_tolerance, out=arriving)
        arriving &= live
        if arriving.any():
            self.arrived[ks] |= arriving
            stamp = np.broadcast_to(np.asarray(time, dtype=float).reshape(-1, 1), arriving.shape)
            np.copyto(self.arrival_time[ks], stamp, where=arriving)
        return arriving

    def rewards(self, ks: slice, live: np.ndarray) -> np.ndarray:
        """This control step's reward of every robot (0 for robots not live); clears the new-contact counts.

        progress_reward × progress − time_penalty − collision_penalty × new contacts + arrival_bonus on arrival.
        """
        c = self.config
        reward = c.progress_reward * self.progress[ks] - c.time_penalty - c.collision_penalty * self.new_collisions[ks]
        reward += c.arrival_bonus * self.arriving[ks]
        self.new_collisions[ks] = 0  # robots not live count none (after_physics masks their contacts)
        return np.where(live, reward, 0.0)

    # -- observations ----------------------------------------------------------------
    def observe(self, ks: slice, layout: ObservationLayout, out: np.ndarray) -> None:
        """Every robot's flat observation (see the env's module docstring) into ``out`` (k, N, D)."""
        c, s = self.config, layout.slices
        pos, theta, vel = self.pos[ks], self.theta[ks], self.vel[ks]
        out[..., 0:2] = pos
        out[..., 2] = theta
        out[..., s["velocity"]] = vel
        out[..., s["last_command"]] = self.last_command[ks]
        out[..., s["radius"]] = c.robot_radius
        out[..., s["goal_offset"]] = self.goals[ks] - pos
        k, n = pos.shape[0], pos.shape[1]
        if n > 1:
            others = self.others
            mates = out[..., s["mates"]].reshape(k, n, -1, 5)  # a view: writes land in ``out``
            mates[..., 0:2] = pos[:, others] - pos[:, :, None, :]
            mates[..., 2] = theta[:, others]
            mates[..., 3:5] = vel[:, others]
        obs_pos = self.obs_pos[ks]
        if obs_pos.shape[1]:
            block = out[..., s["obstacles"]].reshape(k, n, -1, 5)  # a view
            block[..., 0:2] = obs_pos[:, None, :, :] - pos[:, :, None, :]
            block[..., 2:4] = self.obs_vel[ks][:, None, :, :]
            block[..., 4] = self.obstacle_radii[ks][:, None, :]
        out[..., s["proximity"]] = self.proximity[ks]
        if c.local_features:
            self._observe_local(ks, s, out)
        if c.mate_goals and n > 1:
            offset = self.goals[ks][:, self.others] - pos[:, :, None, :]
            if c.local_features:
                offset = np.stack(self._rotation(ks)(offset[..., 0], offset[..., 1]), axis=-1)
            out[..., s["mate_goals"]] = offset.reshape(k, n, -1)
        if c.virtual_forces:
            out[..., s["forces"]] = self._forces(ks).reshape(k, n, -1)

    def _rotation(self, ks: slice):
        """``rotate(dx, dy)``: world-axis vectors (axis 2 over objects) in each robot's frame (x ahead, y left)."""
        theta = self.theta[ks]
        cos, sin = np.cos(theta)[:, :, None], np.sin(theta)[:, :, None]

        def rotate(dx: np.ndarray, dy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return cos * dx + sin * dy, -sin * dx + cos * dy

        return rotate

    def _forces(self, ks: slice) -> np.ndarray:
        """Field ``forces`` (k, N, 5, 3): eqs. (15), (19), (21) at each robot's pose, in its frame (``FORCE_ROWS``).

        Obstacles count at their centres one step ahead, x_b + v_b Δt (eq. 23 with the
        velocity for the difference of positions), ray hits at radius + reading along the ray
        (as ``nash`` places them); each force is encoded as its unit direction in the robot's
        frame (0 for no force) and log(1 + |F|).
        """
        c, g = self.config, ForceGains()
        pos, theta = self.pos[ks], self.theta[ks]
        k, n = pos.shape[0], pos.shape[1]
        forces = np.zeros((k, n, len(FORCE_ROWS), 2))
        goal = self.goals[ks] - pos
        forces[..., 0, 0], forces[..., 0, 1] = attraction(goal[..., 0], goal[..., 1], g.k_a)
        if n > 1:
            away = pos[:, :, None, :] - pos[:, self.others]
            fx, fy = repulsion(away[..., 0], away[..., 1], g.k_r, g.influence)
            forces[..., 1, 0], forces[..., 1, 1] = fx.sum(axis=2), fy.sum(axis=2)
        if self.obs_pos.shape[1]:
            ahead = self.obs_pos[ks] + self.obs_vel[ks] * c.dt
            away = pos[:, :, None, :] - ahead[:, None, :, :]
            fx, fy = repulsion(away[..., 0], away[..., 1], g.k_rb, g.influence)
            forces[..., 2, 0], forces[..., 2, 1] = fx.sum(axis=2), fy.sum(axis=2)
        reading = self.proximity[ks].astype(float)
        hit = reading < c.sensor_range
        angles = theta[:, :, None] + np.asarray(KHEPERA_RING, dtype=float)
        reach = c.robot_radius + reading
        # From the hit point to the robot: minus the ray's vector.
        fx, fy = repulsion(-reach * np.cos(angles), -reach * np.sin(angles), g.k_rb, g.influence)
        forces[..., 3, 0], forces[..., 3, 1] = (fx * hit).sum(axis=2), (fy * hit).sum(axis=2)
        forces[..., 4, :] = forces[..., :4, :].sum(axis=2)
        cos, sin = np.cos(theta)[:, :, None], np.sin(theta)[:, :, None]
        ahead_x = cos * forces[..., 0] + sin * forces[..., 1]
        left_y = -sin * forces[..., 0] + cos * forces[..., 1]
        size = np.hypot(ahead_x, left_y)
        unit = np.where(size > 0, 1.0 / np.maximum(size, 1e-300), 0.0)
        return np.stack([ahead_x * unit, left_y * unit, np.log1p(size)], axis=-1)

    def _observe_local(self, ks: slice, s: dict[str, slice], out: np.ndarray) -> None:
        """Goal offset, mates' and obstacles' offsets and velocities rotated into each robot's frame."""
        pos, goals = self.pos[ks], self.goals[ks]
        k, n = pos.shape[0], pos.shape[1]
        rotate = self._rotation(ks)
        gx, gy = rotate(goals[..., 0:1] - pos[..., 0:1], goals[..., 1:2] - pos[..., 1:2])
        out[..., s["goal_local"]] = np.concatenate([gx, gy], axis=2)
        if n > 1:
            others = self.others
            block = np.empty((k, n, n - 1, 4))
            offset = pos[:, others] - pos[:, :, None, :]
            block[..., 0], block[..., 1] = rotate(offset[..., 0], offset[..., 1])
            speed, heading = self.vel[ks][:, others, 0], self.theta[ks][:, others]
            block[..., 2], block[..., 3] = rotate(speed * np.cos(heading), speed * np.sin(heading))
            out[..., s["mates_local"]] = block.reshape(k, n, -1)
        obs_pos = self.obs_pos[ks]
        if obs_pos.shape[1]:
            block = np.empty((k, n, obs_pos.shape[1], 4))
            offset = obs_pos[:, None, :, :] - pos[:, :, None, :]
            block[..., 0], block[..., 1] = rotate(offset[..., 0], offset[..., 1])
            velocity = np.broadcast_to(self.obs_vel[ks][:, None, :, :], offset.shape)
            block[..., 2], block[..., 3] = rotate(velocity[..., 0], velocity[..., 1])
            out[..., s["obstacles_local"]] = block.reshape(k, n, -1)
