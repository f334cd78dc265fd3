"""The DMAPS world model of paper 002 (teamgym/envs/foraging/world_model.py): blobs, sectors, fusion."""

import math

import numpy as np
import pytest

from teamgym.envs.foraging.grid import GridSpec
from teamgym.envs.foraging.world_model import (
    N_CLASSES,
    ROBOT,
    ROBOT_LAYER,
    SENDER,
    TARGET,
    TARGET_LAYER,
    BlobKernels,
    GridWorldModel,
    ViewSector,
    WorldModelParams,
    local_maxima,
)

GRID = GridSpec(3.0, 2.4, 0.2)  # 15 × 12, the paper's field
NOTHING = np.zeros((12, 15), dtype=bool)


def sector_at(cells):
    mask = NOTHING.copy()
    for gx, gy in cells:
        mask[gy, gx] = True
    return mask


def box(x0, x1, y0, y1):
    """Sector covering cells x0..x1 × y0..y1 (inclusive)."""
    mask = NOTHING.copy()
    mask[y0 : y1 + 1, x0 : x1 + 1] = True
    return mask


# -- constants and blobs (section 2.2) ----------------------------------------------------------


def test_classes_match_the_envs_perception_tuples():
    from teamgym.envs.foraging import perception

    assert (TARGET, ROBOT, SENDER) == (perception.TARGET, perception.ROBOT, perception.SENDER) == (0, 1, 2)
    assert N_CLASSES == 2 and (TARGET_LAYER, ROBOT_LAYER) == (0, 1)


def test_blob_peak_is_pc_and_higher_pc_gives_a_sharper_higher_blob():
    blobs = BlobKernels(k=0.25, min_pc=0.05, levels=100)
    c = blobs.radius
    previous_peak, previous_neighbour_ratio = 0.0, 0.0
    for pc in (0.1, 0.3, 0.6, 1.0):
        kernel = blobs.kernels[blobs.level(pc)]
        assert kernel.max() == pytest.approx(pc) and kernel[c, c] == pytest.approx(pc)
        assert blobs.sigma(pc) == pytest.approx(math.sqrt(0.25 / pc))  # σ² = k / Pc
        ratio = kernel[c, c] / kernel[c, c + 1]  # peak over a neighbour: larger = sharper
        assert kernel[c, c] > previous_peak and ratio > previous_neighbour_ratio
        previous_peak, previous_neighbour_ratio = kernel[c, c], ratio
    # Pc = 1: σ = 0.5 cell, a neighbour at e^-2 of the peak.
    assert blobs.kernels[100][c, c + 1] == pytest.approx(math.exp(-2))


def test_blob_mass_is_about_the_constant_2_pi_k():
    blobs = BlobKernels(k=0.25)
    for pc in (0.3, 0.5, 1.0):  # 2πk exactly for the continuous blob; sampling on cells adds < 3 %
        assert blobs.kernels[blobs.level(pc)].sum() == pytest.approx(2 * math.pi * 0.25, rel=0.03)


def test_tuples_below_min_pc_are_dropped():
    model = GridWorldModel(GRID, 1, 0, WorldModelParams(min_pc=0.1))
    assert not model.blob_grid([(TARGET, 3, 3, 0.05)]).any()
    assert model.blob_grid([(TARGET, 3, 3, 0.5)])[TARGET_LAYER, 3, 3] == pytest.approx(0.5)


def test_blob_grid_puts_classes_in_layers_and_max_combines():
    model = GridWorldModel(GRID, 2, 0)
    grid = model.blob_grid(np.array([(TARGET, 2, 3, 0.8), (TARGET, 3, 3, 0.6), (ROBOT, 10, 7, 0.7), (SENDER, 0, 0, 0.9)]))
    assert grid.shape == (2, 12, 15)
    assert grid[TARGET_LAYER, 3, 2] == pytest.approx(0.8)  # (gx, gy) = (2, 3) is row 3, column 2
    assert grid[TARGET_LAYER, 3, 3] == pytest.approx(0.6)  # the max, not the sum, of the two blobs
    assert grid[ROBOT_LAYER, 7, 10] == pytest.approx(0.7) and grid[ROBOT_LAYER, 0, 0] == pytest.approx(0.9)
    assert grid[TARGET_LAYER, 7, 10] == 0 and grid[ROBOT_LAYER, 3, 2] == 0
    # Cells are clipped into the grid; an empty list gives an empty grid.
    assert model.blob_grid([(TARGET, 40, -3, 1.0)])[TARGET_LAYER, 0, 14] == pytest.approx(1.0)
    assert not model.blob_grid(np.zeros((0, 4))).any()


# -- sectors ------------------------------------------------------------------------------------


@pytest.mark.parametrize("grid", [GRID, GridSpec(3.1, 2.3, 0.2), GridSpec(6.0, 4.8, 0.25)])
def test_view_sector_matches_the_grid_sector_mask(grid):
    rng = np.random.default_rng(3)
    sectors = ViewSector(grid, 1.0, 1.28)
    for _ in range(300):
        x, y, theta = rng.uniform(0, grid.width), rng.uniform(0, grid.height), rng.uniform(-4, 4)
        assert np.array_equal(sectors.mask(x, y, theta), grid.sector_mask(x, y, theta, 1.0, 1.28))
        q = sectors.quantised(x, y, theta)
        assert np.array_equal(sectors.cached(x, y, theta), grid.sector_mask(*q, 1.0, 1.28))
        assert abs(q[0] - x) <= grid.cell_size / 8 + 1e-9 and abs(q[1] - y) <= grid.cell_size / 8 + 1e-9


def test_the_paper_sector_covers_about_16_cells():
    sectors = ViewSector(GRID, 1.0, 1.28)
    counts = [sectors.mask(1.5, 1.2, theta).sum() for theta in np.linspace(-math.pi, math.pi, 16, endpoint=False)]
    assert 12 <= np.mean(counts) <= 20


def test_shadow_hides_cells_behind_a_seen_robot():
    sectors = ViewSector(GRID, 1.0, 1.28)
    x, y = 0.5, 1.3  # cell (2, 6), looking along +x
    hidden = sectors.shadow(x, y, 0.0, np.array([[0.4, 0.0]]), 0.09)
    assert hidden[6, 6] and hidden[6, 7]  # behind the robot at 0.9 m
    assert not hidden[6, 2] and not hidden[6, 3]  # in front of it, and the camera's own cell
    assert not hidden[9, 6] and not hidden[3, 6]  # off to the side
    assert not sectors.shadow(x, y, 0.0, np.zeros((0, 2)), 0.09).any()


# -- own model ------------------------------------------------------------------------------------


def test_own_sector_is_overwritten_and_memory_kept_outside():
    model = GridWorldModel(GRID, 1, 0)
    model.observe_own([(TARGET, 3, 3, 0.9)], box(2, 4, 2, 4), 0.0)
    assert model.own[TARGET_LAYER, 3, 3] == pytest.approx(0.9)
    # Looking elsewhere: the target stays in memory (targets are static) ...
    model.observe_own([], box(8, 12, 5, 9), 5.0)
    assert model.own[TARGET_LAYER, 3, 3] == pytest.approx(0.9)
    assert model.last_seen[3, 3] == 0.0 and model.last_seen[7, 10] == 5.0 and model.last_seen[0, 0] == -np.inf
    # ... until its cell is seen empty.
    model.observe_own([], box(3, 3, 3, 3), 6.0)
    assert model.own[TARGET_LAYER, 3, 3] == 0.0
    assert model.own[TARGET_LAYER, 3, 2] > 0  # a blob tail outside the sector just seen stays


def test_own_robot_layer_decays_outside_the_sector():
    params = WorldModelParams(robot_half_life=1.0)
    model = GridWorldModel(GRID, 2, 0, params)
    model.observe_own([(ROBOT, 5, 5, 0.8)], box(4, 6, 4, 6), 0.0)
    model.observe_own([], box(10, 12, 0, 2), 2.0)
    assert model.own[ROBOT_LAYER, 5, 5] == pytest.approx(0.8 / 4)  # two half-lives
    model.observe_own([], box(5, 5, 5, 5), 2.5)
    assert model.own[ROBOT_LAYER, 5, 5] == 0.0  # seen empty


# -- teammates, fusion and self-bias (section 2.3, 3.2) ----------------------------------------------


def two_robot_model(**params):
    return GridWorldModel(GRID, 2, 0, WorldModelParams(**params))


def test_received_packet_builds_the_teammates_model():
    model = two_robot_model()
    assert model.n_contributors == 1
    model.receive(1, np.array([(SENDER, 10, 5, 0.7), (TARGET, 12, 6, 0.8), (ROBOT, 2, 2, 0.6)]), 0.0)
    assert model.n_contributors == 2 and model.contributed.tolist() == [True, True]
    teammate = model.partial(1)
    assert teammate[TARGET_LAYER, 6, 12] == pytest.approx(0.8)
    assert teammate[ROBOT_LAYER, 5, 10] == pytest.approx(0.7) and teammate[ROBOT_LAYER, 2, 2] == pytest.approx(0.6)
    assert model.sender_cell[1].tolist() == [10, 5] and model.sender_time[1] == 0.0 and model.sender_pls[1] == pytest.approx(0.7)
    # last_seen: the sender's cell and its 8 neighbours.
    seen = np.isfinite(model.last_seen)
    assert seen.sum() == 9 and seen[4:7, 9:12].all()
    # The owner's own packets and empty ones are ignored.
    model.receive(0, [(TARGET, 1, 1, 1.0)], 0.0)
    model.receive(1, [], 0.0)
    assert model.partial(0)[TARGET_LAYER, 1, 1] == 0


def test_queued_packets_of_one_sender_in_one_call():
    model = two_robot_model()
    model.receive(1, [(SENDER, 2, 2, 0.8), (TARGET, 4, 2, 0.8), (SENDER, 3, 2, 0.7)], 1.0)
    assert model.sender_cells[1] == (3, 2) and model.sender_pls[1] == pytest.approx(0.7)
    assert np.isfinite(model.last_seen[1:4, 1:5]).all()
    assert model.partial(1)[TARGET_LAYER, 2, 4] == pytest.approx(0.8)


def test_teammate_memory_decays_with_its_half_lives():
    model = two_robot_model(teammate_target_half_life=10.0, robot_half_life=1.0)
    model.receive(1, [(SENDER, 10, 5, 0.8), (TARGET, 4, 6, 0.8)], 0.0)
    model.observe_own([], box(0, 1, 0, 1), 10.0)
    teammate = model.partial(1)
    assert teammate[TARGET_LAYER, 6, 4] == pytest.approx(0.4)
    assert teammate[ROBOT_LAYER, 5, 10] == pytest.approx(0.8 / 2**10)
    # A new report max-combines with the decayed memory.
    model.receive(1, [(SENDER, 10, 5, 0.8), (TARGET, 4, 6, 0.3)], 10.0)
    assert model.partial(1)[TARGET_LAYER, 6, 4] == pytest.approx(0.4)
    assert model.partial(1)[ROBOT_LAYER, 5, 10] == pytest.approx(0.8)


def test_cells_seen_empty_clear_the_teammates_model():
    model = two_robot_model()
    model.receive(1, [(SENDER, 10, 5, 0.8), (TARGET, 4, 6, 0.8)], 0.0)
    model.observe_own([], box(3, 5, 5, 7), 0.1)
    assert not model.partial(1)[:, 5:8, 3:6].any()
    # Received after the owner's view at the same time: cleared as well.
    model.receive(1, [(SENDER, 10, 5, 0.8), (TARGET, 4, 6, 0.8)], 0.1)
    assert model.partial(1)[TARGET_LAYER, 6, 4] == 0.0


def test_a_teammates_own_surroundings_are_cleared_unless_it_reports_a_target_there():
    model = two_robot_model()
    model.receive(1, [(SENDER, 10, 5, 0.8), (TARGET, 11, 5, 0.9)], 0.0)  # at a target
    assert model.partial(1)[TARGET_LAYER, 5, 11] == pytest.approx(0.9)
    model.receive(1, [(SENDER, 10, 5, 0.8)], 0.1)  # the target is gone (consumed)
    assert model.partial(1)[TARGET_LAYER, 4:7, 9:12].max() == 0.0
    assert model.partial(1)[TARGET_LAYER, 5, 12] > 0  # beyond the cleared neighbourhood: memory


def test_fusion_is_the_weighted_sum_of_eq_4_with_equal_weights():
    model = GridWorldModel(GRID, 3, 0)
    model.observe_own([(TARGET, 2, 2, 0.9)], box(1, 3, 1, 3), 0.0)
    assert np.allclose(model.fused(), model.partial(0))  # alone: the own model
    model.receive(1, [(SENDER, 10, 5, 0.8), (TARGET, 12, 8, 0.6)], 0.0)
    model.receive(2, [(SENDER, 6, 10, 0.5)], 0.0)
    fused = model.fused()
    assert fused.dtype == np.float32 and fused.shape == (2, 12, 15)
    expected = sum(model.partial(r) for r in range(3)) / 3
    assert np.allclose(fused, expected, atol=1e-6)
    assert fused[TARGET_LAYER, 2, 2] == pytest.approx(0.3) and fused[TARGET_LAYER, 8, 12] == pytest.approx(0.2)
    assert np.allclose(model.equal_weights(), [1 / 3] * 3)
    weights = model.weights()
    assert weights.shape == (3, 2, 12, 15) and np.allclose(weights.sum(axis=0), 1.0)  # eq. (5)


def test_weights_cover_only_the_robots_that_contributed():
    model = GridWorldModel(GRID, 4, 2)
    model.receive(0, [(SENDER, 1, 1, 1.0)], 0.0)
    assert model.equal_weights().tolist() == [0.5, 0.0, 0.5, 0.0]
    assert np.allclose(model.weights().sum(axis=0), 1.0)


def test_self_bias_where_the_fused_map_disagrees_with_the_own_view():
    model = two_robot_model(self_bias_threshold=0.25)
    # The owner sees a target at (2, 2); the teammate reports it one cell over, at (3, 2) (a
    # localisation error), and another target outside the owner's view.
    model.observe_own([(TARGET, 2, 2, 0.9)], box(1, 6, 1, 4), 0.0)
    model.receive(1, [(SENDER, 12, 9, 0.9), (TARGET, 3, 2, 0.9), (TARGET, 12, 7, 0.6)], 0.0)
    tail = 0.9 * math.exp(-0.9 / (2 * 0.25))  # a blob of Pc 0.9 one cell from its centre
    equal = model.fused(self_bias=False)
    assert equal[TARGET_LAYER, 2, 3] == pytest.approx((tail + 0.9) / 2) == pytest.approx(equal[TARGET_LAYER, 2, 2])
    biased = model.fused(self_bias=True)
    assert biased[TARGET_LAYER, 2, 3] == pytest.approx(tail)  # own view wins: |0.15 − 0.52| > 0.25
    assert biased[TARGET_LAYER, 2, 2] == pytest.approx(0.9)
    assert biased[TARGET_LAYER, 7, 12] == pytest.approx(0.3) == equal[TARGET_LAYER, 7, 12]  # outside the sector
    weights = model.weights(self_bias=True)
    assert np.allclose(weights.sum(axis=0), 1.0)  # eq. (5) in every cell
    assert weights[0, TARGET_LAYER, 2, 3] == 1.0 and weights[1, TARGET_LAYER, 2, 3] == 0.0
    assert weights[0, TARGET_LAYER, 7, 12] == 0.5 == weights[1, TARGET_LAYER, 7, 12]
    mask = model.self_biased()
    assert mask[TARGET_LAYER, 2, 3] and mask[TARGET_LAYER, 2, 2] and not mask[TARGET_LAYER, 7, 12]
    assert not (mask & ~model.sector).any()  # only in the owner's view
    assert np.allclose(np.where(mask, model.partial(0), equal), biased)


def test_known_peaks_use_a_threshold_per_contributor():
    model = two_robot_model()
    model.observe_own([(TARGET, 2, 2, 0.3)], box(1, 3, 1, 3), 0.0)
    cells, values = model.known(TARGET_LAYER, 0.25)
    assert cells.tolist() == [[2, 2]] and values[0] == pytest.approx(0.3)
    model.receive(1, [(SENDER, 12, 9, 0.9), (TARGET, 10, 3, 0.4)], 0.0)
    cells, _ = model.known(TARGET_LAYER, 0.25, model.fused_map(self_bias=False))
    assert cells.tolist() == [[10, 3], [2, 2]]  # 0.2 and 0.15 ≥ 0.25 / 2, strongest first


def test_local_maxima_keeps_one_cell_of_a_plateau():
    layer = np.zeros((12, 15))
    layer[4, 4:6] = 0.5  # a two-cell plateau
    layer[9, 10] = 0.7
    layer[1, 1] = 0.05
    cells, values = local_maxima(layer, 0.1)
    assert cells.tolist() == [[10, 9], [4, 4]] and values.tolist() == [0.7, 0.5]
    assert local_maxima(np.zeros((12, 15)), 0.0)[0].shape == (0, 2)
    # Two hills two cells apart: two peaks, or one with a separation of 2.
    layer[4, 4:6] = 0.0
    layer[4, 6] = 0.4
    layer[4, 4] = 0.5
    assert local_maxima(layer, 0.1)[0].tolist() == [[10, 9], [4, 4], [6, 4]]
    assert local_maxima(layer, 0.1, separation=2)[0].tolist() == [[10, 9], [4, 4]]


def test_clear_and_reset():
    model = two_robot_model()
    model.observe_own([(TARGET, 5, 5, 0.9)], box(4, 6, 4, 6), 0.0)
    model.receive(1, [(SENDER, 12, 9, 0.9), (TARGET, 5, 5, 0.9)], 0.0)
    model.clear((5, 5), radius=1)
    assert model.partial(0)[TARGET_LAYER, 4:7, 4:7].max() == 0 and model.partial(1)[TARGET_LAYER, 4:7, 4:7].max() == 0
    model.reset()
    assert model.n_contributors == 1 and not model.fused().any() and np.isneginf(model.last_seen).all()


def test_owner_must_be_a_robot_index():
    with pytest.raises(ValueError, match="owner"):
        GridWorldModel(GRID, 2, 2)
    with pytest.raises(ValueError, match="half-lives"):
        WorldModelParams(robot_half_life=0.0)
