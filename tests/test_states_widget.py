"""The States widget's maths: bools as lamps, texts and numbers as lines, short labels, what fits."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from dbglog.viewer._data._model import Binding, SeriesSnapshot, Status, ValueKind
from dbglog.viewer._widgets._states import Entry, entries_of, states_layout


def _snap(tag: str, last: object, kind: ValueKind | None) -> SeriesSnapshot:
    return SeriesSnapshot(Binding(f"/robot1/rosdashboard/{tag}"), Status.LIVE, kind=kind, last=last)  # type: ignore[arg-type]


def test_bools_are_lamps_and_the_rest_lines_with_short_labels() -> None:
    """Bools light lamps, texts and numbers read as lines; labels drop the path all bindings share."""
    entries = entries_of(
        [
            _snap("s3/ok", True, ValueKind.BOOL),
            _snap("s3/fault", False, ValueKind.BOOL),
            _snap("s3/mode", "auto\nmanual", ValueKind.TEXT),
            _snap("s3/count", 42, ValueKind.NUMBER),
            _snap("s3/ratio", math.nan, ValueKind.NUMBER),
            _snap("s3/never", None, None),
        ]
    )
    assert entries == [
        Entry("ok", True, lit=True, text="true"),
        Entry("fault", True, lit=False, text="false"),
        Entry("mode", False, text="auto \u21b5 manual"),
        Entry("count", False, text="42"),
        Entry("ratio", False, text="NaN"),
        Entry("never", False, text="\u2014"),
    ]


def test_a_few_bools_alone_are_large_lamps() -> None:
    """One to three bools alone are large lamps side by side, names centred below, as an LED shows one."""
    _size, lamps, lines, left = states_layout([Entry("turning", True, lit=True)], 180, 150)
    assert lines == []
    assert left == 0
    (lamp,) = lamps
    assert lamp.r >= 30
    assert abs(lamp.x - 90) < 1e-9
    assert lamp.label_y > lamp.y + lamp.r
    _size, lamps, _lines, _left = states_layout([Entry(f"b{i}", True) for i in range(4)], 180, 150)
    assert max(lamp.r for lamp in lamps) < 10  # four: a row of small lamps with their names beside


def test_lines_that_do_not_fit_say_how_many_more() -> None:
    """Lines past the height are left out; the last line shown says how many."""
    entries = [Entry(f"t{i}", False, text="x") for i in range(16)]
    size, _lamps, lines, left = states_layout(entries, 180, 150)
    assert left > 0
    assert lines[-1].label == f"+{left} more"
    assert len(lines) - 1 + left == 16
    assert lines[-1].y + size <= 150


@given(
    st.lists(st.tuples(st.booleans(), st.text(min_size=1, max_size=30)), min_size=1, max_size=16),
    st.integers(min_value=120, max_value=800),
    st.integers(min_value=60, max_value=600),
)
def test_everything_drawn_stays_inside_the_widget(
    items: list[tuple[bool, str]], width: int, height: int
) -> None:
    """Whatever the entries and size, lamps and lines lie inside the body; every entry drawn or counted."""
    entries = [Entry(label, lamp, text="" if lamp else "value") for lamp, label in items]
    size, lamps, lines, left = states_layout(entries, width, height)
    assert len(lamps) == sum(1 for e in entries if e.lamp)
    assert len(lines) - (1 if left else 0) + left == sum(1 for e in entries if not e.lamp)
    for lamp in lamps:
        assert lamp.x - lamp.r >= 0
        assert lamp.x + lamp.r <= width + 1
    for line in lines:
        assert line.y >= 0
        assert line.y + size <= height + 1 or line is lines[0]
