"""The Log console's maths without a display: rows, scrolling, copying, timeline marks, plot bindings."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from dbglog._regex._propose import propose
from dbglog.viewer._data._model import Binding
from dbglog.viewer._ui._host import mark_columns
from dbglog.viewer._ui._plotnumber import number_binding, plot_window
from dbglog.viewer._ui._timescale import TimeScale, mark_runs
from dbglog.viewer._widgets._log import (
    HEADER_H,
    ROW_H,
    columns,
    copy_text,
    row_at,
    thumb,
    top_for,
    top_from_thumb,
)


def test_columns_leave_the_message_the_rest_of_the_row() -> None:
    """Time, level and node come first in fixed places; the message takes what is left of the row."""
    wide, narrow = columns(1200), columns(420)
    assert wide.time_x < wide.level_x < wide.node_x < wide.message_x
    assert wide.node_w == 170
    assert narrow.node_w < wide.node_w
    assert wide.message_x + wide.message_w <= 1200


def test_rows_under_the_mouse() -> None:
    """The header is no row; rows are ROW_H apart; below the last row is none."""
    assert row_at(HEADER_H - 1, 10) is None
    assert row_at(HEADER_H, 10) == 0
    assert row_at(HEADER_H + 3 * ROW_H + 1, 10) == 3
    assert row_at(HEADER_H + 10 * ROW_H + 1, 10) is None


@given(total=st.integers(0, 100_000), rows=st.integers(1, 80), top=st.integers(-50, 200_000))
def test_scrolling_stays_in_range(total: int, rows: int, top: int) -> None:
    """Whatever is asked, the first row shown keeps the rows filled; following shows the end."""
    first = top_for(total, rows, top)
    assert 0 <= first <= max(0, total - rows)
    assert top_for(total, rows, None) == max(0, total - rows)
    track = 300.0
    y0, y1 = thumb(total, rows, first, track)
    assert 0.0 <= y0 <= y1 <= track + 1e-9
    assert top_from_thumb(y0, 0.0, total, rows, track) == pytest.approx(first, abs=max(1, total / track))


def test_copied_lines_read_like_dbglog_logs() -> None:
    """Copy gives ``HH:MM:SS.mmm LEVEL [node] message`` lines, a message's own lines indented."""
    text = copy_text([(0.0, 40, "driver", "motor stalled\ncurrent 12 A"), (1.5, 0, "", "plain")])
    first, second, third = text.splitlines()
    assert first.endswith(" ERROR [driver] motor stalled")
    assert second == "    current 12 A"
    assert third.endswith(" -     plain")


def test_marks_keep_the_worst_level_of_each_pixel_column() -> None:
    """However many lines, one mark per pixel column, in order, the worst level winning."""
    scale = TimeScale(100.0, 200.0, 10.0, 110.0)  # one pixel a second
    times = np.array([100.0, 150.2, 150.4, 150.3, 199.9, 250.0])
    levels = np.array([30, 30, 50, 40, 40, 30], dtype=np.uint8)
    xs, worst = mark_columns(times, levels, scale)
    assert list(zip(xs.tolist(), worst.tolist(), strict=True)) == [
        (10, 30),
        (60, 50),
        (110, 40),
    ]  # 250 s is clamped to the end
    xs, worst = mark_columns(np.zeros(0), np.zeros(0, dtype=np.uint8), scale)
    assert len(xs) == len(worst) == 0


def test_adjacent_marks_of_one_level_are_one_run() -> None:
    """The timeline draws a run of adjacent columns of one level as one rectangle: a new run at a hole or
    another level; a flood's hundreds of marked columns are a few runs."""
    xs = np.array([3, 4, 5, 7, 8, 9, 10, 20], dtype=np.intp)
    levels = np.array([30, 30, 30, 40, 40, 30, 30, 50], dtype=np.uint8)
    assert mark_runs(xs, levels) == ((3, 5, 30), (7, 8, 40), (9, 10, 30), (20, 20, 50))
    assert mark_runs(np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.uint8)) == ()
    flood = np.arange(100, 500, dtype=np.intp)
    assert mark_runs(flood, np.full(len(flood), 40, dtype=np.uint8)) == ((100, 499, 40),)


@given(st.lists(st.tuples(st.floats(0.0, 100.0), st.sampled_from([30, 40, 50])), max_size=60))
def test_runs_cover_exactly_the_marked_columns(lines: list[tuple[float, int]]) -> None:
    """Runs, laid end to end, are the marked columns with their levels: none lost, none added."""
    scale = TimeScale(0.0, 100.0, 0.0, 50.0)
    times = np.array([t for t, _ in lines], dtype=np.float64)
    levels = np.array([lv for _, lv in lines], dtype=np.uint8)
    xs, worst = mark_columns(times, levels, scale)
    runs = mark_runs(xs, worst)
    spread = [(x, lv) for first, last, lv in runs for x in range(first, last + 1)]
    assert spread == list(zip(xs.tolist(), worst.tolist(), strict=True))
    assert all(a[1] + 1 < b[0] or a[2] != b[2] for a, b in itertools.pairwise(runs))


def test_a_number_plot_binds_the_log_text_with_pattern_node_and_level() -> None:
    """Plot this number binds a Log topic's msg field (a String topic's data) with the proposal's pattern."""
    proposal = propose("distance to wall: 0.42 m", 0, node="planner")
    log = number_binding("/rosout", "rcl_interfaces/msg/Log", proposal, node="planner", level="warn")
    assert log == Binding("/rosout", "msg", proposal.pattern, node="planner", level="warn")
    text = number_binding("/chatter", "std_msgs/msg/String", proposal, node="planner")
    assert (text.field, text.node) == ("", "")
    named = number_binding("/rosout", "rcl_interfaces/msg/Log", proposal, name="wall")
    assert named.regex == proposal.named("wall"), "the capture named after the tag: the legend shows it"


def test_a_number_plot_window_shows_every_matched_line() -> None:
    """The new plot's window reaches back to the oldest matched line: 10 s at least, an hour at most."""
    assert plot_window([], 1000.0) == 10.0
    assert plot_window([995.0], 1000.0) == 10.0
    assert plot_window([900.0, 990.0], 1000.0) == 110.0
    assert plot_window([0.0], 1e6) == 3600.0


def test_a_recording_gets_its_lines_from_its_history() -> None:
    """A data source with a history and no engine (a recording) gets a store built from its Log payloads;
    another source in the window gets its own."""
    from types import SimpleNamespace

    from rcl_interfaces.msg import Log
    from rclpy.serialization import serialize_message

    from dbglog.viewer._data._history import History
    from dbglog.viewer._ui._host import AppHost
    from dbglog.viewer._widgets import WidgetRegistry

    def payload(text: str, level: int) -> bytes:
        msg = Log()
        msg.name, msg.msg, msg.level = "recorded", text, level
        data: bytes = serialize_message(msg)
        return data

    history = History(clock=None)
    history.append_payloads(
        "/rosout", [10.0, 11.0], [payload("a", 20), payload("b", 40)], msg_type="rcl_interfaces/msg/Log"
    )
    app = SimpleNamespace(source=SimpleNamespace(store=history))  # a timeline over a recording
    host = AppHost(app, seek=print, registry=WidgetRegistry.builtin(), dialogs=None, add_plan=print)  # type: ignore[arg-type]
    store = host.log_store("/rosout")
    assert store is not None
    store.sync()
    assert [store.line(i).message for i in range(2)] == ["a", "b"]
    assert host.log_store("rosout") is store
    assert host.marks(0.0, 100.0)[0].tolist() == [11.0]
    app.source = SimpleNamespace(store=History(clock=None))  # another recording opened
    assert host.log_store("/rosout") is None
    assert host.marks(0.0, 100.0)[0].tolist() == []
