"""The probabilistic grid world model of paper 002 (DMAPS, sections 2.2, 2.3 and 3.2).

Pure numpy: no env, no simulator. Every robot keeps one :class:`GridWorldModel`; the env
uses it for the optional ``world_model`` observation and the DMAPS baseline
(:mod:`baselines.foraging.dmaps`) plans on it.

**Partial models (eq. 3).** For every contributing robot ``r`` (the owner and each teammate
whose packets arrived) the model holds a grid ``P(X_ij | R = r)`` per class layer: layer 0
targets, layer 1 robots (the transmitting robot's own ``SENDER`` tuple goes into the robot
layer). Grids are ``(ny, nx)`` like :class:`~teamgym.envs.foraging.grid.GridSpec`.

**A tuple as a normal blob (section 2.2).** A tuple ``(class, gx, gy, Pc)`` enters as
``N(μ, kPc)`` centred on its cell. The text says a high Pc gives "a sharp spike" and a low Pc
"a flatter hill", so ``kPc`` is read as a *precision*: the variance is ``σ² = k / Pc``
(cells²), ``k`` = :attr:`WorldModelParams.blob_k` = 0.25, i.e. σ = 0.5 cell at Pc = 1 (86 %
of the mass in the tuple's cell's 3×3 neighbourhood, the neighbours at e^-2 = 14 % of the
peak). The blob is the density scaled by ``2πk`` — a constant, "the normalising constant
k" — so its peak is ``2πk / (2πσ²) = Pc``: the value at the tuple's cell *is* its
confidence, a sharper and higher spike for a larger Pc and a flatter, lower hill for a
smaller one, always with the same total mass ``2πk``. Blobs of one update are max-combined.
Kernels are precomputed for Pc quantised to 1/100; tuples with Pc below
:attr:`~WorldModelParams.min_pc` carry nothing usable and are dropped.

**Own model.** Cells of the owner's current viewing sector are overwritten with what it sees
now (its blobs there; seen-empty cells go to 0 in both layers); outside the sector the target
layer keeps its memory (targets are static), max-combined with any blob tails reaching out of
the sector. Robots move, so the robot layer outside the sector decays with the half-life
:attr:`~WorldModelParams.robot_half_life`.

**A teammate's model (on the receiver).** Built from the tuples it broadcasts: each packet's
blobs are max-combined into the decayed memory of that teammate's grid (half-lives
:attr:`~WorldModelParams.teammate_target_half_life` for targets, ``robot_half_life`` for
robots). Negative information is inferred twice: cells the receiver itself sees empty now
are cleared in every teammate's grid, and the target layer within
:attr:`~WorldModelParams.sender_clear_radius` cells of the teammate's reported location is
overwritten by its current packet (cleared, then the packet's blobs max-combined): a robot's
own cell is always in its view and a robot notices a target at its feet, so this is how a
target the teammate consumed leaves the receiver's copy.

**Fusion (eqs. 4 and 5).** ``P(X_ij) = Σ_r P(X_ij | R = r) P(R = r)`` with
``Σ_r P(R = r) = 1``; by default equal weights ``1/n`` over the robots that have contributed.
**Self-bias (end of section 3.2).** Where the fused map disagrees with the owner's current
view (cells of its sector where ``|own − fused| >`` :attr:`~WorldModelParams.self_bias_threshold`,
per layer), the weights become self-biased: ``P(R = owner) = 1`` and 0 for the others there, so
they still sum to 1 in every cell (:meth:`GridWorldModel.weights`).

**Staleness.** ``last_seen`` (s, ``-inf`` = never) per cell: the owner's sector cells get the
current time; a teammate's reported location and its 8 neighbours get the packet's time.

**Helpers.** :class:`ViewSector` computes viewing sectors like
:meth:`GridSpec.sector_mask` (exactly, or pasted from a per-(sub-cell, heading) cache) and
the cells hidden behind robots in view (:meth:`ViewSector.shadow`); :func:`local_maxima`
finds the peaks of a layer. Cost: a few dozen numpy calls per robot and step on
``(2, ny, nx)`` arrays, no Python loop over cells (only over tuples and peaks).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from teamgym.envs.foraging.grid import GridSpec

__all__ = [
    "N_CLASSES",
    "ROBOT",
    "ROBOT_LAYER",
    "SENDER",
    "TARGET",
    "TARGET_LAYER",
    "BlobKernels",
    "GridWorldModel",
    "ViewSector",
    "WorldModelParams",
    "local_maxima",
]

#: Tuple classes (the same values as :mod:`teamgym.envs.foraging.perception`).
TARGET, ROBOT, SENDER = 0, 1, 2
#: Model layers: targets, robots (``SENDER`` tuples go into the robot layer).
N_CLASSES = 2
TARGET_LAYER, ROBOT_LAYER = 0, 1
#: Layer of each tuple class.
LAYER_OF_CLASS = (TARGET_LAYER, ROBOT_LAYER, ROBOT_LAYER)


@dataclass(frozen=True)
class WorldModelParams:
    """Constants of :class:`GridWorldModel` (see the module docstring for each reading)."""

    #: k of N(μ, kPc) (section 2.2): variance σ² = k / Pc cells²; 0.25 gives σ = 0.5 cell at Pc = 1.
    blob_k: float = 0.25
    #: Tuples with Pc below this are dropped (their blob would stay below it everywhere).
    min_pc: float = 0.05
    #: Pc quantisation of the precomputed kernels (levels per unit).
    pc_levels: int = 100
    #: Half-life (s) of robot layers (own outside the sector, teammates' everywhere).
    robot_half_life: float = 1.0
    #: Half-life (s) of a teammate's target layer on the receiver.
    teammate_target_half_life: float = 30.0
    #: A cell of the owner's sector whose current blob value is below this counts as seen empty.
    empty_threshold: float = 0.05
    #: Self-bias where |own − fused| exceeds this in the owner's sector (section 3.2).
    self_bias_threshold: float = 0.25
    #: Chebyshev radius (cells) around a teammate's reported location cleared in its target layer.
    sender_clear_radius: int = 1
    #: Chebyshev radius (cells) around a teammate's reported location whose ``last_seen`` it refreshes.
    sender_seen_radius: int = 1

    def __post_init__(self) -> None:
        if not (self.blob_k > 0 and 0 < self.min_pc <= 1 and self.pc_levels >= 1):
            raise ValueError(f"WorldModelParams: need blob_k > 0, 0 < min_pc <= 1, pc_levels >= 1, got {self}")
        if not (self.robot_half_life > 0 and self.teammate_target_half_life > 0):
            raise ValueError(f"WorldModelParams: half-lives must be > 0 (math.inf: no decay), got {self}")


class BlobKernels:
    """Precomputed blobs ``N(μ, kPc)`` of section 2.2, one ``(2R+1, 2R+1)`` kernel per quantised Pc.

    ``kernels[q]`` is the blob of Pc = q / levels: ``Pc · exp(−(dx² + dy²) Pc / (2k))`` at the
    integer cell offsets (dx, dy), i.e. the normal density of variance σ² = k / Pc scaled by
    its constant mass 2πk, so the peak equals Pc. ``R = ceil(3 σ_max)`` with σ_max the spread
    at ``min_pc``; levels below ``min_pc`` are zero.
    """

    def __init__(self, k: float = 0.25, min_pc: float = 0.05, levels: int = 100) -> None:
        self.k, self.min_pc, self.levels = float(k), float(min_pc), int(levels)
        self.radius = int(math.ceil(3.0 * math.sqrt(self.k / self.min_pc)))
        offsets = np.arange(-self.radius, self.radius + 1, dtype=float)
        d2 = offsets[None, :] ** 2 + offsets[:, None] ** 2
        pc = np.arange(self.levels + 1, dtype=float) / self.levels
        kernels = pc[:, None, None] * np.exp(-d2[None] * pc[:, None, None] / (2.0 * self.k))
        kernels[pc < self.min_pc - 1e-12] = 0.0
        self.kernels = kernels
        #: Per level: the kernel cut to its own radius ``ceil(3σ)`` and that radius (faster to stamp).
        self.trimmed: list[tuple[np.ndarray, int]] = []
        for q in range(self.levels + 1):
            r = min(self.radius, int(math.ceil(3.0 * self.sigma(pc[q])))) if pc[q] >= self.min_pc - 1e-12 else 0
            c = self.radius
            self.trimmed.append((np.ascontiguousarray(kernels[q, c - r : c + r + 1, c - r : c + r + 1]), r))

    @property
    def size(self) -> int:
        return 2 * self.radius + 1

    def level(self, pc: float) -> int:
        """The kernel index of confidence ``pc`` (clipped to [0, 1])."""
        return int(round(min(1.0, max(0.0, float(pc))) * self.levels))

    def sigma(self, pc: float) -> float:
        """σ (cells) of the blob of confidence ``pc`` (σ² = k / Pc)."""
        return math.sqrt(self.k / max(pc, 1e-12))


class ViewSector:
    """Viewing-sector masks on a grid: the same cells as :meth:`GridSpec.sector_mask`.

    :meth:`mask` is exact: cell centres are precomputed and a cell is in the sector iff its
    centre is within ``camera_range`` of the camera and ``u · h ≥ |u| cos(fov / 2)`` (u: camera
    → centre, h: heading), the bearing test ``|bearing| ≤ fov / 2`` without ``arctan2``; the
    camera's own cell counts as seen.

    :meth:`cached` is the fast path for a planner: the pose is quantised (position to the
    centre of its ``1/subdivisions``-cell bin, heading to ``heading_steps`` per turn) and the
    sector of the quantised pose, relative to the camera's cell, is computed once per
    (bin, heading) and pasted into the grid. It equals :meth:`mask` at the quantised pose;
    near a partial edge column or row (a field not a whole number of cells) it computes that
    exactly instead of pasting.
    """

    def __init__(
        self, grid: GridSpec, camera_range: float, camera_fov: float, subdivisions: int = 4, heading_steps: int = 128
    ) -> None:
        self.grid = grid
        centres = grid.centres()
        self.cx = np.ascontiguousarray(centres[..., 0])
        self.cy = np.ascontiguousarray(centres[..., 1])
        self.range2 = float(camera_range) ** 2
        self.cos_half = math.cos(0.5 * float(camera_fov))
        self.nx, self.ny, self.cell = grid.nx, grid.ny, grid.cell_size
        self.subdivisions, self.heading_steps = int(subdivisions), int(heading_steps)
        self.reach = int(math.ceil(float(camera_range) / self.cell)) + 1  # window half-width (cells)
        # Last column/row narrower than a cell: their centres are not on the regular lattice.
        self._partial_x = self.nx * self.cell > grid.width + 1e-9
        self._partial_y = self.ny * self.cell > grid.height + 1e-9
        self._windows: dict[tuple[int, int, int], np.ndarray] = {}

    def mask(self, x: float, y: float, theta: float) -> np.ndarray:
        """Cells ``(ny, nx)`` bool in the sector of a camera at ``(x, y, θ)``."""
        dx = self.cx - x
        dy = self.cy - y
        d2 = dx * dx + dy * dy
        along = dx * math.cos(theta) + dy * math.sin(theta)
        seen = (d2 <= self.range2) & (along >= np.sqrt(d2) * self.cos_half)
        gx = min(self.nx - 1, max(0, math.floor(x / self.cell + 1e-9)))
        gy = min(self.ny - 1, max(0, math.floor(y / self.cell + 1e-9)))
        seen[gy, gx] = True
        return seen

    def shadow(self, x: float, y: float, theta: float, polar: np.ndarray, radius: float) -> np.ndarray:
        """Cells ``(ny, nx)`` bool hidden behind robots seen at ``polar`` ``(k, 2)`` (distance m, bearing rad).

        A robot is a disc of ``radius``; a cell is hidden when its centre lies at least as far
        as the disc's near edge and within ``atan((radius + cell / 2) / distance)`` of the
        robot's direction (half a cell of margin: a partly hidden cell is not "seen"). The
        camera's own cell is never hidden. Used to take occluded cells out of a viewing
        sector, so that they keep their memory instead of being "seen empty".
        """
        hidden = np.zeros((self.ny, self.nx), dtype=bool)
        polar = np.asarray(polar, dtype=float).reshape(-1, 2)
        if len(polar) == 0:
            return hidden
        dx, dy = self.cx - x, self.cy - y
        distance = np.hypot(dx, dy)
        bearing = np.arctan2(dy, dx)
        for d, b in polar.tolist():
            d = max(d, 1e-6)
            width = math.atan((radius + 0.5 * self.cell) / d)
            off = np.abs((bearing - (theta + b) + math.pi) % (2 * math.pi) - math.pi)
            hidden |= (distance >= d - radius) & (off <= width)
        gx = min(self.nx - 1, max(0, math.floor(x / self.cell + 1e-9)))
        gy = min(self.ny - 1, max(0, math.floor(y / self.cell + 1e-9)))
        hidden[gy, gx] = False
        return hidden

    def quantised(self, x: float, y: float, theta: float) -> tuple[float, float, float]:
        """The pose :meth:`cached` uses for ``(x, y, θ)``."""
        step, turns = self.cell / self.subdivisions, self.heading_steps
        return (
            (math.floor(x / step) + 0.5) * step,
            (math.floor(y / step) + 0.5) * step,
            (round(theta / (2 * math.pi) * turns) % turns) * 2 * math.pi / turns,
        )

    def _window(self, fx: int, fy: int, heading: int) -> np.ndarray:
        step, w = self.cell / self.subdivisions, self.reach
        theta = heading * 2 * math.pi / self.heading_steps
        offsets = (np.arange(-w, w + 1) + 0.5) * self.cell
        dx = offsets[None, :] - (fx + 0.5) * step
        dy = offsets[:, None] - (fy + 0.5) * step
        d2 = dx * dx + dy * dy
        along = dx * math.cos(theta) + dy * math.sin(theta)
        window = (d2 <= self.range2) & (along >= np.sqrt(d2) * self.cos_half)
        window[w, w] = True
        return window

    def cached(self, x: float, y: float, theta: float) -> np.ndarray:
        """:meth:`mask` at the quantised pose (see the class docstring); a new array."""
        sub, turns, w = self.subdivisions, self.heading_steps, self.reach
        bx, by = math.floor(x / self.cell * sub), math.floor(y / self.cell * sub)
        gx, gy = bx // sub, by // sub
        heading = round(theta / (2 * math.pi) * turns) % turns
        inside = 0 <= gx < self.nx and 0 <= gy < self.ny
        near_partial = (self._partial_x and gx + w >= self.nx - 1) or (self._partial_y and gy + w >= self.ny - 1)
        if not inside or near_partial:
            return self.mask(*self.quantised(x, y, theta))
        key = (bx - gx * sub, by - gy * sub, heading)
        window = self._windows.get(key)
        if window is None:
            window = self._windows[key] = self._window(*key)
        seen = np.zeros((self.ny, self.nx), dtype=bool)
        x0, y0 = max(0, gx - w), max(0, gy - w)
        x1, y1 = min(self.nx, gx + w + 1), min(self.ny, gy + w + 1)
        seen[y0:y1, x0:x1] = window[y0 - gy + w : y1 - gy + w, x0 - gx + w : x1 - gx + w]
        return seen


def local_maxima(
    layer: np.ndarray, threshold: float, buffer: np.ndarray | None = None, separation: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """Peaks of a grid ``(ny, nx)`` of probabilities: cells ``(k, 2)`` as ``(gx, gy)`` and their values, strongest first.

    A peak is a cell at least ``threshold`` (and > 0) and no lower than any of its 8
    neighbours; of peaks within ``separation`` cells (Chebyshev) of each other only the first
    (strongest, then lowest flat index) is kept — 1 merges plateaus, 2 also merges two hills of
    one object reported at cells two apart. ``buffer``: an optional ``(ny + 2, nx + 2)`` array
    with a zero border, reused to avoid an allocation.
    """
    ny, nx = layer.shape
    threshold = max(threshold, 1e-12)
    if layer.max() < threshold:  # nothing to find (cheap early exit)
        return np.zeros((0, 2), dtype=np.int64), np.zeros(0)
    padded = np.zeros((ny + 2, nx + 2)) if buffer is None else buffer
    padded[1:-1, 1:-1] = layer
    rows = np.maximum(np.maximum(padded[:, :-2], padded[:, 1:-1]), padded[:, 2:])
    around = np.maximum(np.maximum(rows[:-2], rows[1:-1]), rows[2:], out=rows[1:-1])
    peak = layer >= around
    peak &= layer >= threshold
    flat = np.flatnonzero(peak).tolist()
    if not flat:
        return np.zeros((0, 2), dtype=np.int64), np.zeros(0)
    values = layer.ravel()[flat].tolist()
    if len(flat) == 1:
        gy, gx = divmod(flat[0], nx)
        return np.array([[gx, gy]], dtype=np.int64), np.array(values)
    found = sorted(zip(values, flat), key=lambda vf: (-vf[0], vf[1]))
    kept: list[tuple[int, int]] = []
    kept_values: list[float] = []
    for value, index in found:
        gy, gx = divmod(index, nx)
        if all(abs(gx - kx) > separation or abs(gy - ky) > separation for kx, ky in kept):
            kept.append((gx, gy))
            kept_values.append(value)
    return np.array(kept, dtype=np.int64), np.array(kept_values)


def _rows(tuples) -> list[list[float]]:
    """Tuples as a list of ``[class, gx, gy, Pc]`` rows (a Python list is faster than numpy for a few rows)."""
    if isinstance(tuples, np.ndarray):
        return tuples.reshape(-1, 4).tolist()
    return [list(t) for t in tuples]


class GridWorldModel:
    """One robot's world model: partial grids per robot, fusion (eqs. 4–5), self-bias, ``last_seen``.

    ``GridWorldModel(grid, n_robots, owner)``; feed it every step with
    :meth:`observe_own` (the owner's tuples and viewing sector) and :meth:`receive` (each
    teammate's packet), then read :meth:`fused`. Tuples are ``(m, 4)`` arrays or sequences
    of ``(class, gx, gy, Pc)``. Times are in seconds and must not decrease. See the module
    docstring for every modelling choice.
    """

    def __init__(self, grid: GridSpec, n_robots: int, owner: int, params: WorldModelParams | None = None) -> None:
        if not 0 <= owner < n_robots:
            raise ValueError(f"owner must be in [0, n_robots={n_robots}), got {owner}")
        self.grid = grid
        self.n_robots, self.owner = int(n_robots), int(owner)
        self.params = params or WorldModelParams()
        p = self.params
        self.blobs = BlobKernels(p.blob_k, p.min_pc, p.pc_levels)
        ny, nx = grid.shape
        self.shape = (ny, nx)
        r = self.blobs.radius
        self._scratch = np.zeros((N_CLASSES, ny + 2 * r, nx + 2 * r))
        self._interior = self._scratch[:, r : r + ny, r : r + nx]
        # 1 / half-life (s⁻¹) per robot and layer; 0 means no decay (the owner's target layer).
        self._inv_half_life = [[1.0 / p.teammate_target_half_life, 1.0 / p.robot_half_life] for _ in range(self.n_robots)]
        self._inv_half_life[self.owner][TARGET_LAYER] = 0.0
        self._kernels = self.blobs.trimmed
        self._coef = np.ones((N_CLASSES, 1, 1))
        self._peaks_buffer = np.zeros((ny + 2, nx + 2))
        self.reset()

    # -- state ------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget everything (a new episode)."""
        ny, nx = self.shape
        r = self.blobs.radius  # grids are stored with a border of r cells so that blobs stamp without clipping
        self._padded = np.zeros((self.n_robots, N_CLASSES, ny + 2 * r, nx + 2 * r))
        self._models = self._padded[:, :, r : r + ny, r : r + nx]
        self._stamp = [0.0] * self.n_robots  # time each stored grid is valid at (decay is lazy)
        self.contributed = np.zeros(self.n_robots, dtype=bool)
        self.contributed[self.owner] = True
        self._contributors = [self.owner]
        self.last_seen = np.full((ny, nx), -np.inf)
        self.sector = np.zeros((ny, nx), dtype=bool)
        self._keep = np.ones((N_CLASSES, ny, nx))  # 0 where the owner sees a cell empty now
        self._keep_now = self._keep
        self._empty_time = -math.inf
        self.time = 0.0
        #: Per robot: latest reported cell ``(gx, gy)`` (``(-1, -1)``: none yet; the owner's stays so),
        #: the time (s) of that report (−inf: none) and the reported certainty Pl (plain lists).
        self.sender_cells: list[tuple[int, int]] = [(-1, -1)] * self.n_robots
        self.sender_times: list[float] = [-math.inf] * self.n_robots
        self.sender_pls: list[float] = [0.0] * self.n_robots

    @property
    def sender_cell(self) -> np.ndarray:
        """:attr:`sender_cells` as an ``(n, 2)`` array."""
        return np.array(self.sender_cells, dtype=np.int64)

    @property
    def sender_time(self) -> np.ndarray:
        """:attr:`sender_times` as an ``(n,)`` array."""
        return np.array(self.sender_times)

    @property
    def n_contributors(self) -> int:
        return len(self._contributors)

    def _factor(self, r: int, layer: int) -> float:
        """Decay factor of robot ``r``'s stored ``layer`` at :attr:`time`."""
        return 2.0 ** (-max(0.0, self.time - self._stamp[r]) * self._inv_half_life[r][layer])

    def _decay_to_now(self, r: int) -> None:
        """Apply robot ``r``'s grid decay up to :attr:`time` (decay is kept lazy between writes)."""
        if self.time > self._stamp[r]:
            if r == self.owner:  # the owner's target layer does not decay
                self._padded[r, ROBOT_LAYER] *= self._factor(r, ROBOT_LAYER)
            else:  # (the padded grid is contiguous: faster than its interior view)
                coef = self._coef
                coef[0, 0, 0] = self._factor(r, TARGET_LAYER)
                coef[1, 0, 0] = self._factor(r, ROBOT_LAYER)
                self._padded[r] *= coef
            self._stamp[r] = self.time

    def partial(self, r: int) -> np.ndarray:
        """``P(X | R = r)`` ``(2, ny, nx)`` at the current time (a copy)."""
        out = self._models[r].copy()
        for layer in (TARGET_LAYER, ROBOT_LAYER):
            out[layer] *= self._factor(r, layer)
        return out

    @property
    def own(self) -> np.ndarray:
        """The owner's partial model ``(2, ny, nx)`` (a view; updated in place)."""
        return self._models[self.owner]

    # -- input ------------------------------------------------------------------------
    def blob_grid(self, tuples) -> np.ndarray:
        """The max-combined blobs ``(2, ny, nx)`` of ``tuples``; a view of a scratch buffer (overwritten by the next call)."""
        scratch = self._scratch
        scratch.fill(0.0)
        self._stamp_rows(_rows(tuples), scratch)
        return self._interior

    def _stamp_rows(self, rows: list[list[float]], padded: np.ndarray) -> None:
        """Max-combine the blobs of ``rows`` into ``padded`` ``(2, ny + 2R, nx + 2R)`` (R: the kernels' radius)."""
        kernels, levels, pad = self._kernels, self.blobs.levels, self.blobs.radius
        ny, nx = self.shape
        for cls, gx, gy, pc in rows:
            kernel, r = kernels[round(min(1.0, max(0.0, pc)) * levels)]
            if r == 0:  # below min_pc
                continue
            x = min(nx - 1, max(0, int(gx))) + pad
            y = min(ny - 1, max(0, int(gy))) + pad
            window = padded[LAYER_OF_CLASS[min(2, max(0, int(cls)))], y - r : y + r + 1, x - r : x + r + 1]
            np.maximum(window, kernel, out=window)

    def observe_own(self, tuples, sector: np.ndarray, time: float) -> None:
        """The owner's own perception tuples ``(m, 4)`` this step and its viewing ``sector`` ``(ny, nx)`` bool."""
        self.time = max(self.time, float(time))
        self._decay_to_now(self.owner)
        rows = _rows(tuples)
        self.sector = sector
        if rows:
            own = self._models[self.owner]
            np.copyto(own, 0.0, where=sector)  # inside the sector: replaced by the current view ...
            self._stamp_rows(rows, self._padded[self.owner])  # ... outside: memory max-combined with blob tails
            empty = np.less(own, self.params.empty_threshold)
            empty &= sector
            keep = np.logical_not(empty, out=self._keep, casting="unsafe")
        else:  # nothing seen: the whole sector is empty
            keep = np.logical_not(sector, out=self._keep[0], casting="unsafe")
        self._models *= keep  # seen empty now: cleared in every partial model
        self._keep_now = keep
        self._empty_time = self.time
        np.copyto(self.last_seen, self.time, where=sector)

    def receive(self, sender: int, tuples, time: float) -> None:
        """Tuples of a packet of teammate ``sender`` (its ``SENDER`` tuple first) at ``time``.

        Several packets of one sender may come in one call (in order, each with its ``SENDER``
        tuple); the last ``SENDER`` tuple gives the sender's latest cell.
        """
        sender = int(sender)
        rows = _rows(tuples)
        if sender == self.owner or not 0 <= sender < self.n_robots or not rows:
            return
        p = self.params
        self.time = max(self.time, float(time))
        self._decay_to_now(sender)
        if not self.contributed[sender]:
            self.contributed[sender] = True
            self._contributors = np.flatnonzero(self.contributed).tolist()
        model = self._models[sender]
        ny, nx = self.shape
        for head in rows:  # normally one SENDER tuple; several when packets of one sender queue up
            if int(head[0]) != SENDER:
                continue
            gx, gy = min(nx - 1, max(0, int(head[1]))), min(ny - 1, max(0, int(head[2])))
            self.sender_cells[sender] = (gx, gy)  # the last one is the latest
            self.sender_times[sender] = self.time
            self.sender_pls[sender] = float(head[3])
            s = p.sender_seen_radius
            self.last_seen[max(0, gy - s) : gy + s + 1, max(0, gx - s) : gx + s + 1] = self.time  # none is later
            c = p.sender_clear_radius
            if c >= 0:  # the sender's surroundings: overwritten by this report (cleared, then stamped)
                model[TARGET_LAYER, max(0, gy - c) : gy + c + 1, max(0, gx - c) : gx + c + 1] = 0.0
        self._stamp_rows(rows, self._padded[sender])
        if self._empty_time >= self.time:  # the owner sees these cells empty at this very time
            model *= self._keep_now

    def clear(self, cell: tuple[int, int] | np.ndarray, radius: int = 1, layer: int = TARGET_LAYER) -> None:
        """Set ``layer`` to 0 in every partial model within Chebyshev ``radius`` of ``cell`` (e.g. a consumed target)."""
        gx, gy = int(cell[0]), int(cell[1])
        self._models[:, layer, max(0, gy - radius) : gy + radius + 1, max(0, gx - radius) : gx + radius + 1] = 0.0

    # -- output -----------------------------------------------------------------------
    def equal_weights(self) -> np.ndarray:
        """``P(R = r)`` ``(n,)``: 1 / n_contributors for every contributor, 0 otherwise (eq. 5)."""
        return self.contributed / self.contributed.sum()

    def _fused_equal(self) -> np.ndarray:
        """Eq. (4) with equal weights over the contributors, each partial grid decayed to :attr:`time`."""
        weight = 1.0 / len(self._contributors)
        out = np.empty((N_CLASSES, *self.shape))
        coef = self._coef
        first = True
        for r in self._contributors:
            coef[0, 0, 0] = weight * self._factor(r, TARGET_LAYER)
            coef[1, 0, 0] = weight * self._factor(r, ROBOT_LAYER)
            if first:
                np.multiply(self._models[r], coef, out=out)
                first = False
            else:
                out += self._models[r] * coef
        return out

    def self_biased(self, fused_equal: np.ndarray | None = None) -> np.ndarray:
        """Cells ``(2, ny, nx)`` bool where the weights are self-biased (section 3.2, see the module docstring)."""
        fused = self._fused_equal() if fused_equal is None else fused_equal
        diff = np.subtract(self._models[self.owner], fused)
        biased = np.abs(diff, out=diff) > self.params.self_bias_threshold
        biased &= self.sector
        return biased

    def fused_map(self, self_bias: bool = False) -> np.ndarray:
        """The fused map ``P(X_ij)`` ``(2, ny, nx)`` float64 of eq. (4); ``self_bias`` applies section 3.2."""
        fused = self._fused_equal()
        if self_bias and len(self._contributors) > 1:
            np.copyto(fused, self._models[self.owner], where=self.self_biased(fused))
        return fused

    def fused(self, self_bias: bool = False) -> np.ndarray:
        """:meth:`fused_map` as float32 (the env's ``world_model`` observation uses equal weights)."""
        return self.fused_map(self_bias).astype(np.float32)

    def weights(self, self_bias: bool = False) -> np.ndarray:
        """``P(R = r)`` per cell ``(n, 2, ny, nx)`` as :meth:`fused` uses them; they sum to 1 in every cell (eq. 5)."""
        w = np.broadcast_to(self.equal_weights()[:, None, None, None], (self.n_robots, N_CLASSES, *self.shape)).copy()
        if self_bias and self.n_contributors > 1:
            biased = self.self_biased()
            w[:, biased] = 0.0
            w[self.owner, biased] = 1.0
        return w

    def known(
        self, layer: int, threshold: float, fused: np.ndarray | None = None, separation: int = 1
    ) -> tuple[np.ndarray, np.ndarray]:
        """Peaks ``(gx, gy)`` and values of a fused layer above ``threshold / n_contributors``.

        Equal weights divide a peak seen by one robot of n by n, so the threshold is meant
        per partial model: a peak counts if, on average, the contributors' evidence reaches
        ``threshold / n``. ``fused`` defaults to the self-biased fused map; ``separation``: see
        :func:`local_maxima`.
        """
        grid = self.fused_map(self_bias=True)[layer] if fused is None else fused[layer]
        return local_maxima(grid, threshold / self.n_contributors, self._peaks_buffer, separation)
