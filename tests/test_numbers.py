"""`as_number`: a number given the Python type its field holds, the one rule of recordings and viewer."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from dbglog._ros._numbers import NumberType, as_number, as_numbers


@given(st.integers(min_value=-(2**200), max_value=2**200))
def test_an_int_stays_exact_at_any_size(value: int) -> None:
    """An int in an int slot comes back equal and an int, far beyond 2**53."""
    got = as_number(value, int)
    assert (type(got), got) == (int, value)


@pytest.mark.parametrize(
    "value", [np.int64(2**63 - 1), np.int64(-(2**63)), np.uint64(2**64 - 1), np.uint64(2**53 + 1)]
)
def test_a_numpy_integer_stays_exact(value: np.integer) -> None:
    """A 64-bit numpy integer beyond 2**53 gives the exact Python int (no trip through a float)."""
    got = as_number(value, int)
    assert (type(got), got) == (int, int(value))


@pytest.mark.parametrize("value", [3.0, -0.0, 2.0**60, np.float64(7.0)])
def test_a_whole_float_in_an_int_slot_becomes_an_int(value: float) -> None:
    """A float holding a whole number in an int slot is that int."""
    got = as_number(value, int)
    assert (type(got), got) == (int, value)


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, 2.5, np.float64("nan")])
def test_a_float_that_is_no_whole_number_stays_a_float_in_an_int_slot(value: float) -> None:
    """NaN, infinities and fractions in an int slot stay floats rather than raise or turn into a wrong int."""
    got = as_number(value, int)
    assert type(got) is float
    assert got == value or (math.isnan(got) and math.isnan(value))


@pytest.mark.parametrize(
    ("value", "expected"), [(0, False), (1, True), (0.0, False), (2.5, True), (np.bool_(True), True)]
)
def test_a_bool_slot_gives_a_bool(value: float, expected: bool) -> None:
    """A bool slot gives a bool by the number's truth."""
    assert as_number(value, bool) is expected


def test_a_bool_in_a_number_slot_is_one_or_zero() -> None:
    """A bool in an int or float slot is 1 or 0 of that type."""
    assert (type(as_number(True, int)), as_number(True, int)) == (int, 1)
    assert (type(as_number(False, float)), as_number(False, float)) == (float, 0.0)


@pytest.mark.parametrize(
    ("value", "expected"),
    [(3, 3.0), (2**53 + 1, 2.0**53), (np.int64(5), 5.0), (math.inf, math.inf), (1.5, 1.5)],
)
def test_a_float_slot_gives_a_float(value: float, expected: float) -> None:
    """A float slot gives a Python float, an int rounded to the nearest one."""
    got = as_number(value, float)
    assert (type(got), got) == (float, expected)


def test_nan_in_a_float_slot_stays_nan() -> None:
    """NaN in a float slot is NaN."""
    assert math.isnan(as_number(math.nan, float))


@pytest.mark.parametrize("want", [bool, int, float])
def test_the_result_has_the_wanted_type_for_a_number(want: NumberType) -> None:
    """A whole number of any type comes back as exactly the wanted type."""
    for value in (0, 7, 7.0, np.int64(7), np.float64(7.0)):
        assert type(as_number(value, want)) is want


@pytest.mark.parametrize("want", [bool, int, float])
@pytest.mark.parametrize(
    "column",
    [
        np.array([0.0, 1.5, -2.0, math.nan, math.inf, 2.0**60]),
        np.array([0, -3, 2**63 - 1, -(2**63)], dtype=np.int64),
        np.array([0, 7, 2**64 - 1, 2**53 + 1], dtype=np.uint64),
        np.array([True, False]),
        np.array([], dtype=np.float64),
    ],
    ids=["float64", "int64", "uint64", "bool", "empty"],
)
def test_a_column_gives_what_each_value_gives(column: np.ndarray, want: NumberType) -> None:
    """`as_numbers` of a column is `as_number` of each of its values, type and value alike (NaN as NaN),
    whether the column already holds the wanted type (no call per value) or not."""
    got = as_numbers(column, want)
    expected = [as_number(v, want) for v in column.tolist()]
    assert [type(g) for g in got] == [type(e) for e in expected]
    assert [g if g == g else "nan" for g in got] == [e if e == e else "nan" for e in expected]
