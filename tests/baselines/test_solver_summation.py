"""The game solver's two cost paths (eq. 30) add in one fixed order on every Python and numpy.

``solver._cost_flat`` evaluates few candidates in plain Python and many with numpy; the
tie-break of eq. (31) needs both to give bit-identical costs. Neither may use an order that
depends on the version: the built-in ``sum()`` is compensated (Neumaier) from Python 3.12 on,
and ``ndarray.sum()`` sums pairwise along a contiguous axis once there are 8 or more terms.
The loss values below are chosen so that those orders give a different last bit than plain
left-to-right addition, so this file fails if either path drifts from it.
"""

import math

import numpy as np
import pytest

from baselines.game import arbiter_cost, solver

#: Columns (one candidate's loss vector each) whose eq. (30) cost differs in the last bit
#: between left-to-right and compensated summation, grouped by the number of players N.
CRAFTED = {
    3: [[1e16, 3.0, -1e16], [0.1, 0.3, -0.5], [1.0, 0.3, -0.5], [1.0, -0.5, 1e-16], [-1e16, 3.0, 7.0]],
    4: [[1.0, 0.1, 0.2, -1e16], [-1e16, 1.0, 0.1, 2.0**53], [1e-16, 1.0, 0.1, 0.2]],
}


def _left_to_right(values):
    total = values[0]
    for v in values[1:]:
        total += v
    return total


def _cost(column, add):
    """Eq. (30) for one loss vector, sorted, with the summation ``add``."""
    v = sorted(float(x) for x in column)
    mean = add(v) / len(v)
    return add([x + abs(x - mean) for x in v])


def _both_paths(monkeypatch, flat):
    idx = np.arange(flat.shape[1])
    monkeypatch.setattr(solver, "_PYTHON_COST_LIMIT", 10**6)
    python = solver._cost_flat(flat, idx)
    monkeypatch.setattr(solver, "_PYTHON_COST_LIMIT", 0)
    vectorised = solver._cost_flat(flat, idx)
    return python, vectorised


def _random_losses(n, rng):
    """(n, 40) losses mixing scales, ties and permuted columns."""
    flat = rng.standard_normal((n, 40)) * np.repeat([1e-3, 1.0, 1e3, 1e15], 10)
    flat[:, ::3] = np.round(flat[:, ::3], 1)
    flat[:, 1] = flat[::-1, 0]
    return flat


def test_crafted_losses_tell_the_summation_orders_apart():
    # Guards the data: a compensated (here exact) sum gives another cost for every column.
    for columns in CRAFTED.values():
        for column in columns:
            assert _cost(column, _left_to_right) != _cost(column, math.fsum), column


@pytest.mark.parametrize("n", sorted(CRAFTED))
def test_both_cost_paths_add_left_to_right_on_crafted_losses(monkeypatch, n):
    flat = np.array(CRAFTED[n], dtype=np.float64).T  # (N, P)
    python, vectorised = _both_paths(monkeypatch, flat)
    expected = np.array([_cost(column, _left_to_right) for column in CRAFTED[n]])
    assert python.tobytes() == vectorised.tobytes()
    assert python.tobytes() == expected.tobytes()


@pytest.mark.parametrize("n", [2, 3, 5, 7, 8, 9, 12, 20])
def test_both_cost_paths_add_left_to_right_for_any_player_count(monkeypatch, n):
    # N >= 8 is where numpy's pairwise summation would start to differ.
    flat = _random_losses(n, np.random.default_rng(100 + n))
    python, vectorised = _both_paths(monkeypatch, flat)
    expected = np.array([_cost(flat[:, j], _left_to_right) for j in range(flat.shape[1])])
    assert python.tobytes() == vectorised.tobytes()
    assert python.tobytes() == expected.tobytes()


def test_arbiter_cost_of_a_candidate_does_not_depend_on_how_many_are_costed():
    # 9 players x 2 actions: all 512 joint actions go through numpy, one at a time through Python.
    rng = np.random.default_rng(7)
    n = 9
    losses = rng.standard_normal((n,) + (2,) * n) * 1e3
    losses[0] += 1e15  # a large loss beside small ones: summation order shows in the last bit
    candidates = np.array(np.unravel_index(np.arange(2**n), (2,) * n)).T
    together = arbiter_cost(losses, candidates)
    one_by_one = np.array([arbiter_cost(losses, c[None, :])[0] for c in candidates])
    assert together.tobytes() == one_by_one.tobytes()
