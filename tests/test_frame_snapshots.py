"""`FrameSnapshots`: each series read once per look, kept while paused over an unchanged history (pure)."""

from __future__ import annotations

import numpy as np

from dbglog.viewer._data._history import History
from dbglog.viewer._data._model import Binding
from dbglog.viewer._data._replay import ReplaySource
from dbglog.viewer._data._timeline import Timeline
from dbglog.viewer._ui import StaticSource
from dbglog.viewer._ui._frame import FrameSnapshots

A, B = Binding("/a", "data"), Binding("/b", "data")


def _replay() -> tuple[History, ReplaySource]:
    store = History(clock=None, max_seconds=3600, max_bytes=2**30)
    t = 1000.0 + np.arange(100) / 10
    for name in ("/a", "/b"):
        store.append_numbers(name, t, np.sin(t))
    source = ReplaySource(store, {"/a": "std_msgs/msg/Float64", "/b": "std_msgs/msg/Float64"})
    source.bind(A)
    source.bind(B)
    return store, source


def test_a_look_reads_each_series_once_however_often_it_is_asked() -> None:
    """Two passes over three widgets' bindings (one shared) read two snapshots, the same objects."""
    _, source = _replay()
    timeline = Timeline(source)
    timeline.pause(1005.0)
    snaps = FrameSnapshots(timeline)
    snaps.begin()
    first = [snaps.snapshot(b) for b in (A, B, A)]
    second = [snaps.snapshot(b) for b in (A, B, A)]
    assert snaps.reads == 2
    assert all(x is y for x, y in zip(first, second, strict=True))
    assert first[0].last_time == timeline.snapshot(A).last_time


def test_a_cursor_move_reads_again_even_within_a_look() -> None:
    """A seek between the change check and the redraw: the redraw reads the series at the new time."""
    _, source = _replay()
    timeline = Timeline(source)
    timeline.pause(1005.0)
    snaps = FrameSnapshots(timeline)
    snaps.begin()
    before = snaps.snapshot(A)
    timeline.seek(1002.0)
    after = snaps.snapshot(A)
    assert snaps.reads == 2
    assert before.last_time is not None
    assert after.last_time is not None
    assert after.last_time < before.last_time


def test_paused_over_an_unchanged_history_a_look_keeps_what_was_read_until_it_grows() -> None:
    """Paused, nothing new: the next look reads nothing; a sample more in the history: it reads again."""
    store, source = _replay()
    timeline = Timeline(source)
    timeline.pause(1005.0)
    snaps = FrameSnapshots(timeline)
    snaps.begin()
    snaps.snapshot(A)
    snaps.begin()
    snaps.snapshot(A)
    assert snaps.reads == 1
    store.append_numbers("/a", np.array([2000.0]), np.array([1.0]))
    snaps.begin()
    snaps.snapshot(A)
    assert snaps.reads == 2


def test_what_was_read_is_kept_no_longer_than_keep_s() -> None:
    """With no time to keep, every look reads again (a series' error that brings no sample still shows)."""
    _, source = _replay()
    timeline = Timeline(source)
    timeline.pause(1005.0)
    snaps = FrameSnapshots(timeline, keep_s=0.0)
    for _ in range(3):
        snaps.begin()
        snaps.snapshot(A)
    assert snaps.reads == 3


def test_live_every_look_reads_again() -> None:
    """Live (no cursor) the data move on by themselves: nothing is kept from one look to the next."""
    source = StaticSource()
    source.push("/a", "data", 1.0, 10.0)
    timeline = Timeline(source)
    snaps = FrameSnapshots(timeline)
    snaps.begin()
    assert snaps.snapshot(A).last == 1.0
    source.push("/a", "data", 2.0, 11.0)
    snaps.begin()
    assert snaps.snapshot(A).last == 2.0
    assert snaps.reads == 2


def test_a_short_past_carries_the_recent_samples_and_the_same_state() -> None:
    """Asked for the last 2 s (or none), the snapshot holds those samples and the one before; value, status,
    count and rate are those of the whole snapshot."""
    _, source = _replay()
    timeline = Timeline(source)
    timeline.pause(1005.04)
    whole = timeline.snapshot(A)
    for past, first in ((2.0, 1003.0), (0.0, 1005.0)):
        part = timeline.snapshot(A, past)
        assert part.times[0] == first  # the sample at or before the cursor - past
        assert np.array_equal(part.times, whole.times[whole.times >= first])
        assert np.array_equal(part.values, whole.values[whole.times >= first])
        assert (part.last, part.last_time, part.count, part.status, part.rate_hz) == (
            whole.last,
            whole.last_time,
            whole.count,
            whole.status,
            whole.rate_hz,
        )
    assert len(timeline.snapshot(A, 1e6).times) == len(whole.times)  # never more than without a past


def test_a_look_reads_a_series_again_only_when_asked_for_more_past() -> None:
    """A gauge's read (no past) serves a second gauge; a plot's longer past reads once more, and then serves
    both; a read of everything serves any past."""
    _, source = _replay()
    timeline = Timeline(source)
    timeline.pause(1005.0)
    snaps = FrameSnapshots(timeline)
    snaps.begin()
    gauge = snaps.snapshot(A, 0.0)
    assert snaps.snapshot(A, 0.0) is gauge
    assert len(gauge.times) == 1
    plot = snaps.snapshot(A, 3.0)
    assert snaps.reads == 2
    assert snaps.snapshot(A, 0.0) is plot
    assert len(plot.times) == 31
    everything = snaps.snapshot(B)
    assert snaps.snapshot(B, 3.0) is everything
    assert snaps.reads == 3


def test_live_a_past_changes_nothing() -> None:
    """Live (no cursor), the timeline hands out the source's snapshot whatever past is asked for."""
    _, source = _replay()
    timeline = Timeline(source)
    assert len(timeline.snapshot(A, 0.0).times) == len(source.snapshot(A).times)


def test_a_series_with_nothing_yet_is_read_again_at_the_next_look() -> None:
    """Paused over an unchanged history, a binding made after a first read that found nothing (a robot
    switched to: its past is held already) shows that past at the next look, not a second later."""
    store = History(clock=None, max_seconds=3600, max_bytes=2**30)
    t = 1000.0 + np.arange(100) / 10
    for name in ("/robot1/a", "/robot2/a"):
        store.append_numbers(name, t, np.full(100, 1.0 if "1" in name else 2.0))
    source = ReplaySource(store, dict.fromkeys(("/robot1/a", "/robot2/a"), "std_msgs/msg/Float64"))
    timeline = Timeline(source)
    timeline.pause(1005.0)
    snaps = FrameSnapshots(timeline)
    second = Binding("/robot2/a", "data")
    snaps.begin()
    assert snaps.snapshot(second).count == 0, "not bound yet: nothing"
    source.bind(second)
    snaps.begin()
    assert snaps.snapshot(second).last == 2.0
