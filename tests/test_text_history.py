"""The String widget's history lines: newest first, repeated values collapsed into one line with a count."""

from __future__ import annotations

import numpy as np

from dbglog.viewer._data._model import Binding, SeriesSnapshot, Status, ValueKind
from dbglog.viewer._widgets._text import history_lines


def _texts(*values: str) -> SeriesSnapshot:
    times = np.arange(len(values), dtype=np.float64) + 1_700_000_000.0
    return SeriesSnapshot(Binding("/t"), Status.LIVE, kind=ValueKind.TEXT, times=times, texts=values)


def _numbers(*values: float) -> SeriesSnapshot:
    times = np.arange(len(values), dtype=np.float64) + 1_700_000_000.0
    arr = np.asarray(values, dtype=np.float64)
    return SeriesSnapshot(Binding("/n"), Status.LIVE, kind=ValueKind.NUMBER, times=times, values=arr)


def test_repeated_texts_become_one_line_with_a_count() -> None:
    """A mode published at a steady rate reads as a log of its changes, newest first."""
    snap = _texts("idle", "idle", "idle", "cruise", "cruise", "avoid", "cruise")
    assert history_lines(snap, 50, with_time=False) == ["cruise", "avoid", "cruise  \u00d72", "idle  \u00d73"]
    assert history_lines(snap, 50, with_time=False, collapse=False) == [
        "cruise",
        "avoid",
        "cruise",
        "cruise",
        "idle",
        "idle",
        "idle",
    ]


def test_the_limit_counts_lines_and_a_run_keeps_its_first_time() -> None:
    """`limit` is in lines after collapsing; a run is stamped with the time its value first came."""
    snap = _texts("a", "b", "b", "b", "c")
    lines = history_lines(snap, 2, with_time=True)
    assert len(lines) == 2
    assert lines[0].endswith("  c")
    assert lines[1].endswith("  b  \u00d73")
    stamp_b = history_lines(_texts("a", "b"), 1, with_time=True)[0].split("  ")[0]
    assert lines[1].startswith(stamp_b)  # b first came at index 1 in both snapshots


def test_numbers_collapse_by_value_including_nan() -> None:
    """Numbers compare by value (not by formatted text); NaN runs collapse too."""
    nan = float("nan")
    snap = _numbers(1.0, 1.0, 2.5, nan, nan, 1.0000001, 1.0)
    assert history_lines(snap, 10, with_time=False) == ["1", "1", "NaN  \u00d72", "2.5", "1  \u00d72"]
    assert len(history_lines(_numbers(*range(100)), 7, with_time=False)) == 7


def test_many_identical_values_are_cheap_and_one_line() -> None:
    """10,000 identical samples are one line, counted exactly."""
    snap = _numbers(*([3.0] * 10_000))
    assert history_lines(snap, 50, with_time=False) == ["3  \u00d710000"]


def test_no_history_shows_the_last_value_or_nothing() -> None:
    """An array series shows its last value; an empty series shows no lines; newlines are marked."""
    array = SeriesSnapshot(Binding("/a"), Status.LIVE, kind=ValueKind.ARRAY, last=(1.0, 2.0))
    assert history_lines(array, 5, with_time=True) == ["(1.0, 2.0)"]
    assert history_lines(SeriesSnapshot(Binding("/e"), Status.WAITING), 5, with_time=True) == []
    assert history_lines(_texts("two\nlines"), 5, with_time=False) == ["two \u21b5 lines"]


def test_numbers_that_are_not_finite_read_as_nan_and_inf() -> None:
    """NaN and ±inf in a number's history read NaN, +inf, -inf (repeats of NaN collapse too)."""
    lines = history_lines(_numbers(1.5, np.nan, np.nan, np.inf, -np.inf), 50, with_time=False)
    assert lines == ["-inf", "+inf", "NaN  \u00d72", "1.5"]
