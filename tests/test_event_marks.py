"""Parameter changes and markers as the viewer lays them out, without a display: a time plot's labelled
lines (collapsed and thinned to stay legible), the timeline bar's marks (one a pixel column), the Events
list's rows, and Topic setup's type-ahead over nodes' parameters."""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st

from dbglog._ros._markers import Marker
from dbglog._ros._params import ParamValue
from dbglog.viewer._data._events import EventKind, ParamChange
from dbglog.viewer._ui._dialogs import parameter_suggestions, typed_target
from dbglog.viewer._ui._eventlist import event_row
from dbglog.viewer._ui._host import event_mark
from dbglog.viewer._ui._timescale import TimeScale, event_columns
from dbglog.viewer._widgets._eventlines import (
    LABEL_ROWS,
    MERGE_PX,
    event_lines,
    fit_label,
    group_label,
)
from dbglog.viewer.widget_api import EventMark


def _measure(text: str) -> float:
    """A label's width: 7 px a character (a stand-in for the font)."""
    return 7.0 * len(text)


def _change(
    t: float, name: str = "kp", old: object = 1.25, new: object = 2.5, node: str = "/robot/pid"
) -> EventMark:
    return event_mark(ParamChange(t, node, name, ParamValue.of(old), ParamValue.of(new)))


def test_event_marks_say_what_changed() -> None:
    """A change's mark has its label, subject, old and new text; an unknown old value reads ?; a marker
    its note."""
    mark = _change(5.0)
    assert (mark.kind, mark.label, mark.subject, mark.old, mark.new) == (
        "changed",
        "robot/pid.kp 1.25 \u2192 2.5",
        "robot/pid.kp",
        "1.25",
        "2.5",
    )
    unknown = event_mark(ParamChange(1.0, "/n", "a", None, ParamValue.of(3)))
    assert (unknown.old, unknown.label) == ("?", "n.a ? \u2192 3")
    note = event_mark(Marker(2.0, "robot bumped here"))
    assert (note.kind, note.label, note.subject) == ("marker", "robot bumped here", "")


def test_one_event_a_line_labelled_without_the_namespace() -> None:
    """Events far apart get a line each, labelled ``node.name old → new`` beside it; one near the right
    edge is labelled on its left."""
    lines = event_lines([_change(1.0), _change(9.9, new=3.0)], 0.0, 10.0, 600, _measure)
    assert [(line.label, line.left, line.count) for line in lines] == [
        ("pid.kp 1.25 \u2192 2.5", False, 1),
        ("pid.kp 1.25 \u2192 3.0", True, 1),
    ]
    assert lines[0].x == 60.0
    assert all(0 <= line.x <= 600 for line in lines)


def test_close_events_share_a_line_whose_label_sums_them_up() -> None:
    """Changes of one parameter within a few pixels are one line, ``first old → last new (n changes)``; a
    group with a marker says its note first; a mix says the newest and how many more."""
    drag = [_change(5.0 + i * 0.001, old=1.0 + i, new=2.0 + i) for i in range(5)]
    [line] = event_lines(drag, 0.0, 10.0, 600, _measure)
    assert (line.count, line.label, line.time) == (5, "pid.kp 1.0 \u2192 6.0 (5 changes)", drag[0].time)
    mixed = [_change(5.0), event_mark(Marker(5.001, "bumped")), _change(5.002, name="ki")]
    assert group_label(mixed) == "bumped (+2 more)"
    assert group_label([_change(5.0), _change(5.001, name="ki")]) == "pid.ki 1.25 \u2192 2.5 (+1 more)"
    [marked] = event_lines(mixed, 0.0, 10.0, 600, _measure)
    assert marked.marker


@given(st.lists(st.floats(0.0, 60.0), min_size=1, max_size=300), st.integers(120, 1600))
@example([i * 0.1 for i in range(300)], 120)  # a slider dragged: a change every few tenths of a pixel
def test_many_changes_never_clutter_a_plot(times: list[float], width: int) -> None:
    """However many changes a range holds: lines at least a few pixels apart, every event in one line, at
    most two rows of labels that never overlap and stay within the plot."""
    events = [_change(t, new=float(i)) for i, t in enumerate(sorted(times))]
    lines = event_lines(events, 0.0, 60.0, width, _measure)
    assert sum(line.count for line in lines) == len(events)
    xs = [line.x for line in lines]
    assert xs == sorted(xs)
    assert all(b - a >= MERGE_PX - 1e-9 for a, b in itertools.pairwise(xs))
    for row in range(LABEL_ROWS):
        spans = sorted(
            (line.x - 4 - _measure(line.label), line.x - 4)
            if line.left
            else (line.x + 4, line.x + 4 + _measure(line.label))
            for line in lines
            if line.label and line.row == row
        )
        assert all(a >= 0 and b <= width for a, b in spans)
        assert all(b1 <= a2 for (_a1, b1), (a2, _b2) in itertools.pairwise(spans))
    assert all(line.label == "" or line.full.startswith(line.label.rstrip("\u2026")) for line in lines)


def test_the_newest_events_keep_their_labels() -> None:
    """With more labels than room, the newest are labelled and older lines stay bare."""
    events = [_change(float(t), new=float(t)) for t in range(10)]
    lines = event_lines(events, 0.0, 10.0, 300, _measure)
    labelled = {line.time for line in lines if line.label}
    assert {8.0, 9.0} <= labelled
    assert len(labelled) < len(lines)


def test_a_long_label_is_cut_to_fit() -> None:
    """A label wider than the room is cut with an ellipsis; one that cannot keep three characters is none."""
    assert fit_label("pid_node.kp 1.25 \u2192 2.5", 70, _measure) == "pid_node.\u2026"
    assert fit_label("short", 70, _measure) == "short"
    assert fit_label("pid_node.kp", 20, _measure) == ""


def test_timeline_marks_one_a_column_markers_first() -> None:
    """However many events, one mark a pixel column; a column with a user's marker is a marker."""
    scale = TimeScale(0.0, 100.0, 10.0, 110.0)  # a pixel a second
    times = np.array([1.0, 1.2, 1.4, 50.0, 50.3, 120.0, -5.0])
    markers = np.array([False, True, False, False, False, True, True])
    assert event_columns(times, markers, scale) == [(11, True), (60, False)]
    many = np.sort(np.random.default_rng(3).uniform(0, 100, 100_000))
    columns = event_columns(many, np.zeros(len(many), dtype=np.bool_), scale)
    assert len(columns) <= 101
    assert event_columns(np.zeros(0), np.zeros(0, dtype=np.bool_), scale) == []


def test_events_list_rows() -> None:
    """A row: time, node, name, old → new (deleted and declared said so), a marker its note."""
    changed = ParamChange(0.0, "/robot/pid", "kp", ParamValue.of(1.25), ParamValue.of(2.5))
    assert event_row(changed)[1:] == ("/robot/pid", "kp", "1.25 \u2192 2.5")
    gone = ParamChange(0.0, "/n", "kp", ParamValue.of(1.0), None, EventKind.DELETED)
    assert event_row(gone)[3] == "deleted (was 1.0)"
    unknown = ParamChange(0.0, "/n", "kp", None, ParamValue.of(3))
    assert event_row(unknown)[3] == "? \u2192 3"
    assert event_row(Marker(0.0, "robot bumped here"))[1:] == ("marker", "", "robot bumped here")
    assert len(event_row(changed)[0]) == len("12:00:00.000")


def test_topic_setup_suggests_parameters_and_reads_what_is_typed() -> None:
    """Typing part of a node or parameter name lists the parameters with type and value (names starting so
    first); NODE:NAME is a parameter when its node is known or the text starts with /, a robot's tag
    otherwise; a bare node name is found in its namespace."""
    params = [
        ("/robot/pid_node:kp", ParamValue.of(1.25)),
        ("/robot/pid_node:kd", ParamValue.of(0.5)),
        ("/arm/skip:label", ParamValue.of("a" * 60)),
    ]
    lines = parameter_suggestions(params, "kp")
    assert lines == ["/robot/pid_node:kp   [parameter: double = 1.25]"]
    assert parameter_suggestions(params, "pid")[:2] == [
        "/robot/pid_node:kd   [parameter: double = 0.5]",
        "/robot/pid_node:kp   [parameter: double = 1.25]",
    ]
    assert parameter_suggestions(params, "label")[0].endswith("\u2026]")
    known = [target for target, _ in params]
    assert typed_target(" /robot/pid_node:kp ", known) == "/robot/pid_node:kp"
    assert typed_target("pid_node:kd", known) == "/robot/pid_node:kd"
    assert typed_target("/later_node:gain", known) == "/later_node:gain"
    assert typed_target("robot1:speed", known) == "/robot1/rosdashboard/speed"
    assert typed_target("pid_node:kp", None) == "/pid_node/rosdashboard/kp", "a widget without parameters"
    assert typed_target("/turtle1/pose", known) == "/turtle1/pose"
