"""ActionRowsChecker accepts exactly what ActionChecker accepts row by row, and names the failing agent."""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium import spaces
from hypothesis import given, settings
from hypothesis import strategies as st

from teamgym.envs.spaces import ActionChecker, ActionRowsChecker

BOX = spaces.Box(np.array([-0.4, -15.0], np.float32), np.array([0.4, 15.0], np.float32), dtype=np.float32)
DISCRETE = spaces.Discrete(5)
VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.sampled_from([0.4, -0.4, 15.0, -15.0, 0.4000000059604645, 0.40000001, 15.000001, 0.0, -0.0]),
)


def row_by_row(space: spaces.Space, actions: np.ndarray, names: list[str]) -> np.ndarray | Exception:
    checker = ActionChecker(space)
    try:
        return np.array([checker.check(n, a) for n, a in zip(names, actions)], dtype=float)
    except (TypeError, ValueError) as error:
        return error


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(VALUES, VALUES), min_size=1, max_size=6))
def test_box_rows_agree_with_the_per_agent_checker(rows):
    actions = np.array(rows, dtype=np.float64)
    names = [f"robot_{i}" for i in range(len(rows))]
    expected = row_by_row(BOX, actions, names)
    if isinstance(expected, Exception):
        with pytest.raises(type(expected)) as raised:
            ActionRowsChecker(BOX).check(actions, names)
        assert str(raised.value) == str(expected)  # the same message, naming the same agent
    else:
        assert np.array_equal(ActionRowsChecker(BOX).check(actions, names), expected)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(st.integers(-3, 8), st.floats(-3, 8), st.just(float("nan"))), min_size=1, max_size=6))
def test_discrete_rows_agree_with_the_per_agent_checker(values):
    actions = np.array(values, dtype=np.float64 if any(isinstance(v, float) for v in values) else np.int64)
    names = [f"robot_{i}" for i in range(len(values))]
    expected = row_by_row(DISCRETE, actions, names)
    if isinstance(expected, Exception):
        with pytest.raises(type(expected)) as raised:
            ActionRowsChecker(DISCRETE).check(actions, names)
        assert str(raised.value) == str(expected)
    else:
        checked = ActionRowsChecker(DISCRETE).check(actions, names)
        assert checked.dtype == np.int64 and np.array_equal(checked, expected)


def test_wrong_shapes_and_types_are_refused():
    checker = ActionRowsChecker(BOX)
    with pytest.raises(ValueError, match="shape"):
        checker.check(np.zeros((2, 3)), ["a", "b"])
    with pytest.raises(TypeError, match="'b'"):
        checker.check(np.array([[0.0, 0.0], ["x", 0.0]], dtype=object), ["a", "b"])
    with pytest.raises(TypeError, match="Box or Discrete"):
        ActionRowsChecker(spaces.MultiBinary(3))
