"""The series ring buffer, its status transitions and its rate, with explicit clocks (no ROS)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from dbglog.viewer._data._model import Binding, Status, ValueKind
from dbglog.viewer._data._series import Series

B = Binding("/t")


def _push(series: Series, values: list[float], now: float, t0: float = 0.0) -> None:
    arr = np.asarray(values, dtype=np.float64)
    series.push_numbers(np.arange(len(arr), dtype=np.float64) + t0, arr, values[-1], now)


@given(st.lists(st.integers(min_value=1, max_value=30), min_size=1, max_size=20), st.integers(1, 50))
def test_ring_keeps_the_latest_values_in_order(batches: list[int], capacity: int) -> None:
    """Whatever the batch sizes, the snapshot holds the last `capacity` values oldest first."""
    series = Series(B, capacity)
    series.set_type("std_msgs/msg/Float64", ValueKind.NUMBER)
    sent: list[float] = []
    for n in batches:
        batch = [float(len(sent) + i) for i in range(n)]
        sent.extend(batch)
        series.push_numbers(np.asarray(batch), np.asarray(batch), batch[-1], now=1.0)
    snap = series.snapshot(2.0, now=1.0)
    assert snap.values.tolist() == sent[-capacity:]
    assert snap.times.tolist() == sent[-capacity:]
    assert snap.count == len(sent)
    assert snap.last == sent[-1]


_BATCHES = st.lists(
    st.lists(st.integers(min_value=0, max_value=40), min_size=1, max_size=12), min_size=1, max_size=25
)


def _by_time(sent: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Every sample sent, ordered by source time, ties in arrival order (a stable sort)."""
    return sorted(sent, key=lambda s: s[0])


@given(_BATCHES, st.integers(1, 40))
def test_ring_is_ordered_by_source_time_whatever_the_arrival_order(
    batches: list[list[int]], capacity: int
) -> None:
    """Batches with late and unsorted source times (two publishers of one tag): the snapshot holds the
    `capacity` newest samples by source time, oldest first, ties in arrival order; the series' value is
    that of its newest sample."""
    series = Series(B, capacity)
    series.set_type("std_msgs/msg/Float64", ValueKind.NUMBER)
    sent: list[tuple[float, float]] = []
    for batch in batches:
        times = [float(t) for t in batch]
        values = [float(len(sent) + i) for i in range(len(batch))]  # the arrival rank: ties are told apart
        sent.extend(zip(times, values, strict=True))
        series.push_numbers(np.asarray(times), np.asarray(values), values[-1], now=1.0)
        want = _by_time(sent)[-capacity:]
        snap = series.snapshot(2.0, now=1.0)
        assert list(zip(snap.times.tolist(), snap.values.tolist(), strict=True)) == want
        assert (snap.last_time, snap.last) == want[-1]
    assert series.count == len(sent)


def test_a_late_batch_keeps_the_newest_value_and_its_type() -> None:
    """An Int64 series: a batch older than the newest sample does not change the value shown; a batch
    whose newest sample arrives first in it gives that sample's value, as an int."""
    series = Series(B, 10)
    series.set_type("std_msgs/msg/Int64", ValueKind.NUMBER)
    series.push_numbers(np.array([10.0, 11.0]), np.array([1.0, 2.0]), 2, now=1.0)
    series.push_numbers(np.array([5.0]), np.array([7.0]), 7, now=1.0)
    snap = series.snapshot(2.0, now=1.0)
    assert (snap.last, snap.last_time, snap.times.tolist()) == (2, 11.0, [5.0, 10.0, 11.0])
    series.push_numbers(np.array([13.0, 12.0]), np.array([9.0, 8.0]), 8, now=1.0)
    snap = series.snapshot(2.0, now=1.0)
    assert (snap.last, snap.last_time) == (9, 13.0)
    assert type(snap.last) is int
    assert snap.values.tolist() == [7.0, 1.0, 2.0, 8.0, 9.0]


@given(_BATCHES)
def test_texts_are_ordered_by_source_time_whatever_the_arrival_order(batches: list[list[int]]) -> None:
    """A text series' history (the String widget's) is ordered by source time, ties in arrival order."""
    series = Series(B, 30)
    series.set_type("std_msgs/msg/String", ValueKind.TEXT)
    sent: list[tuple[float, str]] = []
    for batch in batches:
        times = [float(t) for t in batch]
        texts = [f"m{len(sent) + i}" for i in range(len(batch))]
        sent.extend(zip(times, texts, strict=True))
        series.push_texts(times, texts, now=1.0)
    want = sorted(sent, key=lambda s: s[0])[-30:]
    snap = series.snapshot(2.0, now=1.0)
    assert list(zip(snap.times.tolist(), snap.texts, strict=True)) == want
    assert (snap.last_time, snap.last) == want[-1]


def test_an_older_array_does_not_replace_the_newest() -> None:
    """An array message older than the one shown is counted but does not replace it."""
    series = Series(B, 10)
    series.set_type("sensor_msgs/msg/LaserScan", ValueKind.ARRAY)
    series.push_array(1, (1.0,), 7.0, now=1.0)
    series.push_array(1, (2.0,), 6.0, now=1.0)
    snap = series.snapshot(2.0, now=1.0)
    assert (snap.last, snap.last_time, snap.count) == ((1.0,), 7.0, 2)


def test_status_moves_waiting_live_stale_error() -> None:
    """WAITING before data, LIVE while fresh, STALE after the stale time, ERROR until the next value."""
    series = Series(B, 10)
    series.set_waiting("topic is not on the ROS graph yet")
    first = series.snapshot(2.0, now=0.0)
    assert (first.status, first.reason) == (Status.WAITING, "topic is not on the ROS graph yet")
    series.set_type("std_msgs/msg/Float64", ValueKind.NUMBER)
    _push(series, [1.0], now=10.0)
    assert series.snapshot(2.0, now=11.0).status == Status.LIVE
    stale = series.snapshot(2.0, now=12.5)
    assert stale.status == Status.STALE
    assert stale.age_s == pytest.approx(2.5)
    series.set_error("field missing")
    assert series.snapshot(2.0, now=12.5).reason == "field missing"
    _push(series, [2.0], now=13.0)
    assert series.snapshot(2.0, now=13.0).status == Status.LIVE


def test_type_change_keeps_history_of_the_same_kind_and_clears_another() -> None:
    """A new type of the same kind keeps the values; a new kind starts over (count stays monotonic)."""
    series = Series(B, 10)
    series.set_type("std_msgs/msg/Float64", ValueKind.NUMBER)
    _push(series, [1.0, 2.0], now=1.0)
    series.set_type("std_msgs/msg/Int32", ValueKind.NUMBER, error="type changed")
    snap = series.snapshot(2.0, now=1.0)
    assert (snap.status, snap.values.tolist()) == (Status.ERROR, [1.0, 2.0])
    series.set_type("std_msgs/msg/String", ValueKind.TEXT)
    series.push_texts([5.0], ["hello"], now=2.0)
    text = series.snapshot(2.0, now=2.0)
    assert (text.kind, text.texts, text.values.size, text.count) == (ValueKind.TEXT, ("hello",), 0, 3)


def test_rate_follows_the_message_rhythm_and_decays() -> None:
    """Steady 10 Hz pushes read about 10 Hz; after the messages stop, the rate falls towards 0."""
    series = Series(B, 100)
    series.set_type("std_msgs/msg/Float64", ValueKind.NUMBER)
    for i in range(40):
        _push(series, [float(i)], now=i * 0.1)
    assert series.snapshot(2.0, now=3.95).rate_hz == pytest.approx(10.0, rel=0.1)
    assert series.snapshot(2.0, now=6.0).rate_hz < 6.0
    assert series.snapshot(2.0, now=20.0).rate_hz == 0.0


def test_latched_burst_does_not_inflate_the_rate() -> None:
    """A history burst at subscription is not counted as a rate."""
    series = Series(B, 200)
    series.set_type("std_msgs/msg/Float64", ValueKind.NUMBER)
    _push(series, [0.0] * 100, now=0.0)
    for i in range(1, 21):
        _push(series, [float(i)], now=i * 0.5)
    assert series.snapshot(2.0, now=10.2).rate_hz == pytest.approx(2.0, rel=0.15)


def test_array_series_keep_only_the_latest_array() -> None:
    """ARRAY series report the latest tuple and count messages, without numeric history."""
    series = Series(B, 10)
    series.set_type("sensor_msgs/msg/LaserScan", ValueKind.ARRAY)
    series.push_array(3, (1.0, 2.0), 7.0, now=1.0)
    snap = series.snapshot(2.0, now=1.0)
    assert (snap.last, snap.last_time, snap.count, snap.values.size) == ((1.0, 2.0), 7.0, 3, 0)


def test_capacity_must_be_positive() -> None:
    """A series that could hold nothing is refused."""
    with pytest.raises(ValueError, match="at least one"):
        Series(B, 0)


def test_a_widgets_stale_time_rejudges_live_and_stale_only() -> None:
    """with_stale_time turns live into stale past the time and back; waiting and error are untouched."""
    series = Series(Binding("/t"), 10)
    series.set_type("std_msgs/msg/Float64", ValueKind.NUMBER)
    series.push_numbers(np.array([1.0]), np.array([2.0]), 2.0, now=100.0)
    live = series.snapshot(stale_after=2.0, now=105.0)
    assert live.status == Status.STALE
    assert live.with_stale_time(30.0).status == Status.LIVE
    assert live.with_stale_time(30.0).reason == ""
    quick = series.snapshot(stale_after=30.0, now=101.5)
    assert quick.status == Status.LIVE
    judged = quick.with_stale_time(1.0)
    assert judged.status == Status.STALE
    assert judged.reason == "no message for 1.5 s"
    assert quick.with_stale_time(2.0) is quick
    waiting = Series(Binding("/w"), 10).snapshot(stale_after=2.0)
    assert waiting.with_stale_time(0.001) is waiting
    series.set_error("field missing")
    error = series.snapshot(stale_after=2.0, now=105.0)
    assert error.with_stale_time(30.0).status == Status.ERROR
