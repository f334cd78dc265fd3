"""PoseRows (teamgym/control/poses.py): robot poses as floats, converted once per state array."""

import numpy as np

from teamgym.control.poses import PoseRows


def test_rows_are_the_arrays_values_and_are_kept_until_the_array_changes():
    rows = PoseRows()
    states = np.random.default_rng(0).normal(size=(3, 6))
    first = rows(states)
    assert first == [tuple(float(v) for v in row[:3]) for row in states]
    assert all(type(v) is float for row in first for v in row)
    assert rows(states) is first  # the same array: not converted again
    moved = states.copy()
    moved[1, 0] += 1.0
    assert rows(moved) is not first and rows(moved)[1][0] == moved[1, 0]
    assert rows(states[:, :]) == first  # a new view of the same values: converted again, same rows
