"""A plot's lines as pure data, the line worker that computes them during a render, `TimeRange.moving`."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from dbglog.viewer._data._model import Binding, SeriesSnapshot, Status, ValueKind
from dbglog.viewer._widgets._plotlines import LineJob, LineTask, LineWorker, plot_lines
from dbglog.viewer.widget_api import TimeRange


def _snap(times: np.ndarray, values: np.ndarray, name: str = "/a") -> SeriesSnapshot:
    return SeriesSnapshot(
        Binding(name), Status.LIVE, kind=ValueKind.NUMBER, times=times, values=values, count=len(times)
    )


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
        assert x[0] <= -10.0 + 1e-9  # one sample beyond the start: the line runs to the plot's edge
        assert x[-1] > -10.0 / 200  # to the last pixel column
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
