"""A plot's lines as pure data, the line worker that computes them during a render, `TimeRange.moving`."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from dbglog.viewer._data._model import Binding, SeriesSnapshot, Status, ValueKind
from dbglog.viewer._widgets._plotlines import LineJob, LineTask, LineWorker, plot_lines, stepped
from dbglog.viewer.widget_api import TimeRange


def _snap(
    times: np.ndarray, values: np.ndarray, name: str = "/a", last: float | int | bool | None = None
) -> SeriesSnapshot:
    kind = ValueKind.BOOL if isinstance(last, bool) else ValueKind.NUMBER
    return SeriesSnapshot(
        Binding(name), Status.LIVE, kind=kind, times=times, values=values, count=len(times), last=last
    )


def _segments(x: np.ndarray, y: np.ndarray) -> list[tuple[float, float]]:
    """The x spans of the line's drawn segments (a NaN in y ends one)."""
    ok = ~np.isnan(y)
    return [(float(x[i]), float(x[i + 1])) for i in range(len(x) - 1) if ok[i] and ok[i + 1]]


def _job(*snaps: SeriesSnapshot, start: float = 0.0, stop: float = 10.0, **kw: object) -> LineJob:
    fields: dict[str, object] = {
        "older": (None,) * len(snaps),
        "origin": stop,
        "max_points": 200,
        "fixed": None,
        "limits": None,
        "width": 400,
        "plot_h": 200,
    }
    fields.update(kw)
    return LineJob(snaps=tuple(snaps), start=start, stop=stop, **fields)  # type: ignore[arg-type]


def test_lines_are_decimated_relative_to_origin_with_the_y_axis_fitted() -> None:
    """10k samples over 20 s, 10 s shown: at most ~2 points a column, x from the origin, y fitted + 8 %."""
    t = np.linspace(0.0, 20.0, 10_000)
    a = _snap(t, np.sin(t))
    b = _snap(t, np.where(t > 5, 3.0, np.nan), "/b")  # NaN before 5 s: not in the fit, no crash
    lines = plot_lines(_job(a, b, start=0.0, stop=10.0))
    assert len(lines.lines) == 2
    for x, y in lines.lines:
        assert x.dtype == y.dtype == np.float64
        assert x.flags.c_contiguous
        assert y.flags.c_contiguous
        assert len(x) <= 2 * 200 + 2
        assert x[-1] > -10.0 / 200  # to the last pixel column
    assert lines.lines[0][0][0] <= -10.0 + 1e-9  # one sample beyond the start: the line runs to the edge
    assert lines.lines[1][0][0] > -5.0 - 0.01  # NaN is no point of the line: it starts after them
    lo, hi = -1.0, 3.0
    assert lines.limits is not None
    assert lines.limits == pytest.approx((lo - 0.08 * (hi - lo), hi + 0.08 * (hi - lo)), abs=1e-3)
    assert lines.drawn == sum(len(x) for x, _ in lines.lines)
    assert lines.oldest == pytest.approx(min(float(x[0]) for x, _ in lines.lines) + 10.0)
    assert lines.newest == pytest.approx(max(float(x[-1]) for x, _ in lines.lines) + 10.0)


def test_fixed_scale_and_nothing_finite() -> None:
    """A fixed scale's limits are the plot's; with nothing finite the limits shown are kept (None)."""
    t = np.linspace(0.0, 10.0, 100)
    assert plot_lines(_job(_snap(t, t), fixed=(0.0, 100.0))).limits == (0.0, 100.0)
    empty = plot_lines(_job(_snap(t, np.full(100, np.nan)), limits=(-1.0, 1.0)))
    assert empty.limits is None
    nothing = plot_lines(_job(_snap(np.empty(0), np.empty(0))))
    assert (nothing.drawn, nothing.oldest, nothing.newest) == (0, None, None)


def test_lines_moved_to_a_later_origin_keep_their_times() -> None:
    """A frame-old picture on the next frame's axis: x shifted by the origins' difference, y the same."""
    t = np.linspace(0.0, 10.0, 50)
    lines = plot_lines(_job(_snap(t, np.cos(t)), stop=10.0))
    assert lines.moved_to(10.0) is lines
    later = lines.moved_to(10.5)
    (x0, y0), (x1, y1) = lines.lines[0], later.lines[0]
    np.testing.assert_allclose(x1, x0 - 0.5)
    np.testing.assert_array_equal(y1, y0)
    assert (later.origin, later.oldest, later.newest) == (10.5, lines.oldest, lines.newest)


def test_lines_moved_back_end_at_the_cursor() -> None:
    """Dragged back, the frame-old lines lose the points after the new cursor: nothing drawn past it."""
    t = np.linspace(0.0, 10.0, 101)
    lines = plot_lines(_job(_snap(t, np.cos(t)), start=0.0, stop=10.0, max_points=1000))
    back = lines.moved_to(9.0, until=9.0)
    x, y = back.lines[0]
    assert float(x[-1]) <= 0.0 < float(x[-1]) + 0.1 + 1e-9  # the last point at or before the cursor
    assert back.newest is not None
    assert back.newest <= 9.0
    assert back.drawn == len(x) < lines.drawn
    np.testing.assert_allclose(y, lines.lines[0][1][: len(y)])
    assert lines.moved_to(10.0, until=10.0) is lines  # nothing past the cursor: the same lines
    assert lines.moved_to(10.0, until=-1.0).drawn == 0


def test_a_gap_in_the_data_is_drawn_as_a_gap() -> None:
    """A publisher killed for 20 s: no segment of the line spans the silence; zoomed out so far that the
    silence is under two pixel columns, the line goes on (a hole nobody sees is not drawn)."""
    before = np.arange(0.0, 20.0, 0.01)
    after = np.arange(40.0, 60.0, 0.01)
    t = np.concatenate((before, after))
    lines = plot_lines(_job(_snap(t, np.sin(t)), start=0.0, stop=60.0, origin=0.0, max_points=600))
    x, y = lines.lines[0]
    assert np.isnan(y).sum() == 1
    assert all(b - a < 1.0 for a, b in _segments(x, y)), "no segment across the silence"
    assert x[0] <= 0.0
    assert x[-1] >= 59.9
    far = plot_lines(_job(_snap(t, np.sin(t)), start=-20000.0, stop=60.0, origin=0.0, max_points=600))
    assert not np.isnan(far.lines[0][1]).any()


def test_nan_breaks_the_line_and_infinities_stand_at_the_edges_marked() -> None:
    """NaN: a gap in the line; +inf and -inf: the line runs to the top and the bottom edge of the y range
    fitted to the finite values, each marked; no RuntimeWarning (warnings are errors in the tests)."""
    t = np.arange(0.0, 10.0, 0.1)
    v = np.sin(t)
    v[30:33] = np.nan
    v[50], v[70] = np.inf, -np.inf
    lines = plot_lines(_job(_snap(t, v), start=0.0, stop=10.0, origin=0.0, max_points=1000))
    assert lines.limits is not None
    lo, hi = lines.limits
    assert -1.2 < lo < -0.9, lines.limits
    assert 0.9 < hi < 1.2, lines.limits
    x, y = lines.lines[0]
    assert not np.isinf(y).any()
    assert all(b <= 2.9 + 1e-9 or a >= 3.3 - 1e-9 for a, b in _segments(x, y)), "nothing across the NaN"
    assert y[np.isclose(x, 5.0)].tolist() == [hi]
    assert y[np.isclose(x, 7.0)].tolist() == [lo]
    (marks,) = lines.marks
    np.testing.assert_allclose(marks.above, [5.0])
    np.testing.assert_allclose(marks.below, [7.0])
    assert len(marks.lone[0]) == 0
    moved = lines.moved_to(1.0, until=6.0)
    np.testing.assert_allclose(moved.marks[0].above, [4.0])
    assert len(moved.marks[0].below) == 0


def test_a_sample_alone_between_gaps_is_marked() -> None:
    """A regular tag, silent, one sample, silent again, then regular: that sample is a dot of its own."""
    t = np.concatenate((np.arange(0.0, 10.0, 0.1), [20.0], np.arange(30.0, 40.0, 0.1)))
    lines = plot_lines(_job(_snap(t, np.cos(t)), start=0.0, stop=40.0, origin=0.0, max_points=1000))
    (marks,) = lines.marks
    assert marks.lone[0].tolist() == [20.0]
    assert marks.lone[1].tolist() == [np.cos(20.0)]


def test_integers_and_bools_are_drawn_as_steps_floats_as_lines() -> None:
    """An Int tag (its value an int) and a Bool hold each value until the next sample; a Float64 is a line."""
    t = np.array([0.0, 1.0, 2.0, 3.0])
    v = np.array([0.0, 5.0, 5.0, 2.0])
    counter, flag, level = _snap(t, v, last=2), _snap(t, v > 1, "/b", last=True), _snap(t, v, "/c", last=2.0)
    assert (stepped(counter), stepped(flag), stepped(level)) == (True, True, False)
    lines = plot_lines(_job(counter, level, start=0.0, stop=3.0, origin=0.0, max_points=100))
    (sx, sy), (lx, ly) = lines.lines
    dx, dy = np.diff(sx), np.diff(sy)
    assert np.all((dx == 0) | (dy == 0)), "only flat and upright segments"
    flat = [(sx[i], sx[i + 1], sy[i]) for i in range(len(sx) - 1) if dy[i] == 0 and dx[i] > 0]
    assert [next(y for a, b, y in flat if a < q < b) for q in (0.5, 1.5, 2.5)] == [0.0, 5.0, 5.0]
    assert (sx[-1], sy[-1]) == (3.0, 2.0)
    assert (lx.tolist(), ly.tolist()) == (t.tolist(), v.tolist())


def test_the_y_axis_fits_where_the_line_crosses_the_range_edges() -> None:
    """Zoomed (a box) between samples: the y range holds the line where it leaves the range, not only
    the samples inside it (a segment to a spike just outside ran off the top)."""
    t = np.arange(0.0, 10.0, 1.0)
    v = np.zeros(10)
    v[6] = 1000.0
    lines = plot_lines(_job(_snap(t, v), start=2.2, stop=5.5, origin=5.5))
    assert lines.limits is not None
    assert lines.limits[0] < 0.0, lines.limits
    assert lines.limits[1] >= 500.0, lines.limits
    between = plot_lines(_job(_snap(t, v), start=5.25, stop=5.75, origin=5.75))
    assert between.limits is not None
    assert between.limits[0] <= 250.0, between.limits
    assert between.limits[1] >= 750.0, between.limits
    held = plot_lines(_job(_snap(t, v, last=0), start=5.25, stop=5.75, origin=5.75))
    assert held.limits is not None
    assert held.limits[0] < 0.0 < held.limits[1] < 1000.0, "a step holds 0 until the spike's sample"


def test_a_task_not_started_is_computed_by_whoever_takes_it() -> None:
    """Taken before the worker starts (a frame that never rendered): computed there, the same lines."""
    t = np.linspace(0.0, 10.0, 500)
    job = _job(_snap(t, np.sin(3 * t)))
    worker = LineWorker()
    task = worker.submit(job)
    got, want = task.take(), plot_lines(job)
    for (x, y), (wx, wy) in zip(got.lines, want.lines, strict=True):
        np.testing.assert_array_equal(x, wx)
        np.testing.assert_array_equal(y, wy)
    worker.start()  # the worker finds it claimed and leaves it
    assert task.take() is got


def test_the_worker_computes_queued_tasks_on_its_thread() -> None:
    """Queued during a frame, started before its render: computed on the dbglog-lines thread, in order."""
    t = np.linspace(0.0, 10.0, 2000)
    worker = LineWorker()
    tasks = [worker.submit(_job(_snap(t, np.sin(k * t)))) for k in range(1, 6)]
    names: set[str] = set()
    original = LineTask.run

    def run(self: LineTask) -> None:
        names.add(threading.current_thread().name)
        original(self)

    LineTask.run = run  # type: ignore[method-assign]
    try:
        worker.start()
        results = [task.take() for task in tasks]
    finally:
        LineTask.run = original  # type: ignore[method-assign]
    assert any(name.startswith("dbglog-lines") for name in names)
    for k, lines in enumerate(results, 1):
        want = plot_lines(_job(_snap(t, np.sin(k * t))))
        np.testing.assert_array_equal(lines.lines[0][1], want.lines[0][1])


def test_an_error_on_the_worker_is_raised_where_the_lines_are_taken() -> None:
    """A job that fails on the worker fails the plot's next update (which disables the widget, saying why)."""
    t = np.linspace(0.0, 10.0, 10)
    bad = _job(_snap(t, t), older=())  # one series, no envelope entry: zip(strict=True) refuses
    worker = LineWorker()
    task = worker.submit(bad)
    worker.start()
    with pytest.raises(ValueError, match="zip"):
        task.take()


def test_time_range_moving_needs_the_cursor_moved_frame_after_frame() -> None:
    """Moving after two frames in a row with the cursor moved; a still frame or going live ends it."""
    rng = TimeRange()
    frames = [
        (100.0, None, False),  # live
        (100.0, 50.0, False),  # paused: a click
        (100.0, 50.1, False),  # one move: a click or a key step
        (100.0, 50.2, True),  # a drag
        (100.0, 50.2, False),  # the pointer stopped
        (100.0, 50.3, False),
        (100.0, 50.4, True),
        (101.0, None, False),  # live again
    ]
    seen = []
    for newest, cursor, _ in frames:
        rng.sync(newest, cursor)
        seen.append((rng.moving, rng.copy().moving))
    assert seen == [(want, want) for *_, want in frames]
