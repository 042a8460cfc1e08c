"""`cut_at`: a snapshot as it stood at a time, for sources without a history of their own (pure)."""

from __future__ import annotations

import numpy as np

from dbglog.viewer._data._model import Binding, SeriesSnapshot, Status, ValueKind
from dbglog.viewer._data._timeline import NOT_YET, Timeline, cut_at
from dbglog.viewer._ui import StaticSource

B = Binding("/x")


def _numbers() -> SeriesSnapshot:
    times = np.array([10.0, 11.0, 12.0, 15.0])
    return SeriesSnapshot(
        B,
        Status.LIVE,
        kind=ValueKind.NUMBER,
        times=times,
        values=np.array([1.0, 2.0, 3.0, 4.0]),
        last=4,
        last_time=15.0,
        count=104,
        age_s=0.1,
    )


def test_numbers_at_a_time_keep_their_samples_up_to_it_and_the_type_of_the_value() -> None:
    """At 12.5: three samples, the value 3 as an int (the live value is an int), live then."""
    cut = cut_at(_numbers(), 12.5, stale_after=2.0)
    assert cut.values.tolist() == [1.0, 2.0, 3.0]
    assert cut.last == 3
    assert isinstance(cut.last, int)
    assert cut.last_time == 12.0
    assert cut.status is Status.LIVE
    assert cut.count == 103  # counts stay those of the whole series, minus what came after t
    assert abs(cut.age_s - 0.5) < 1e-9  # type: ignore[operator]


def test_a_gap_longer_than_the_stale_time_is_stale_and_before_the_first_sample_waits() -> None:
    """At 14.5 nothing came for 2.5 s; at 9 nothing had come yet."""
    stale = cut_at(_numbers(), 14.5, stale_after=2.0)
    assert stale.status is Status.STALE
    assert stale.reason == "no message for 2.5 s"
    before = cut_at(_numbers(), 9.0, stale_after=2.0)
    assert before.status is Status.WAITING
    assert before.reason == NOT_YET
    assert before.last is None


def test_texts_and_errors() -> None:
    """A text series keeps the texts up to t; an error without data stays the error."""
    text = SeriesSnapshot(
        B,
        Status.LIVE,
        kind=ValueKind.TEXT,
        times=np.array([1.0, 2.0, 3.0]),
        texts=("a", "b", "c"),
        last="c",
        last_time=3.0,
        count=3,
    )
    cut = cut_at(text, 2.0, stale_after=5.0)
    assert cut.texts == ("a", "b")
    assert cut.last == "b"
    error = SeriesSnapshot(B, Status.ERROR, reason="bad field")
    assert cut_at(error, 2.0, stale_after=5.0) is error


def test_a_timeline_over_a_source_without_history_cuts_its_snapshots() -> None:
    """StaticSource has no history: paused, the Timeline cuts what it holds; live, it passes through."""
    source = StaticSource()
    for k in range(5):
        source.push("/x", "", float(k), t=100.0 + k)
    timeline = Timeline(source)
    assert timeline.span() is None
    assert timeline.snapshot(B).last == 4.0
    timeline.pause(at=102.0)
    assert timeline.snapshot(B).last == 2.0
    assert timeline.step([B], +1)
    assert timeline.cursor == 103.0
    timeline.resume()
    assert timeline.live
