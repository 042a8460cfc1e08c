"""Where a time plot draws the events of its range (parameter changes, user markers): thin vertical lines
with labels (``pid_node.kp 1.25 → 2.5``), never a clutter of them.

Events closer together than a few pixels share one line (labelled ``pid_node.kp 1.0 → 2.5 (5 changes)``
when they change one parameter, else the newest one's label and how many more); a label names the node
without its namespace (the Events list and the timeline bar say it whole). Labels go in two rows along the
bottom of the plot, beside their line, cut to fit; the newest are placed first, and a label with no room
left in either row is left out (its line stays). Pure functions: the plot (`_plot`) draws what these return.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Final

from dbglog.viewer.widget_api import EventMark

__all__ = [
    "LABEL_GAP_PX",
    "LABEL_ROWS",
    "MERGE_PX",
    "EventLine",
    "event_lines",
    "fit_label",
    "group_label",
    "short_label",
]

MERGE_PX: Final = 10.0
"""Events closer than this many pixels to the first of a group share its line."""
LABEL_GAP_PX: Final = 8.0
"""Pixels kept free between two labels of a row."""
LABEL_ROWS: Final = 2
"""Rows of labels along the top of a plot."""
LABEL_PAD_PX: Final = 4.0
"""Pixels between a line and its label."""
ELLIPSIS: Final = "\u2026"


@dataclass(frozen=True, slots=True)
class EventLine:
    """One line a plot draws, for one event or several close together."""

    time: float
    """Where the line stands: the first of its events (source time; the next line is `MERGE_PX` or more
    to its right)."""
    x: float
    """Its pixel from the plot area's left."""
    marker: bool
    """A user's marker is among its events (the line takes the markers' colour)."""
    count: int
    """How many events it stands for."""
    full: str
    """Its whole label."""
    label: str = ""
    """The label as drawn (cut to fit), "" when there was no room for it."""
    row: int = 0
    """The label's row, 0 the lowest."""
    left: bool = False
    """The label stands left of the line (near the right edge)."""


def _short(subject: str) -> str:
    """``robot/pid_node.kp`` -> ``pid_node.kp`` (the node without its namespace)."""
    return subject.rsplit("/", 1)[-1]


def short_label(event: EventMark) -> str:
    """An event's label on a plot: ``pid_node.kp 1.25 → 2.5`` (its node without the namespace), a marker's
    note."""
    if not event.subject:
        return event.label
    if event.kind == "deleted":
        return f"{_short(event.subject)} deleted (was {event.old})"
    if event.kind == "declared":
        return f"{_short(event.subject)} = {event.new} (declared)"
    return f"{_short(event.subject)} {event.old} \u2192 {event.new}"


def group_label(events: Sequence[EventMark]) -> str:
    """One label for events that share a line: the event's own (`short_label`); changes of one parameter as
    its first old and last new value with their count; else the newest marker's note (the user's own
    words), or the newest change's label, and how many more."""
    if len(events) == 1:
        return short_label(events[0])
    first, last = events[0], events[-1]
    markers = [e for e in events if e.kind == "marker"]
    if markers:
        return f"{markers[-1].label} (+{len(events) - 1} more)"
    subjects = {e.subject for e in events}
    if len(subjects) == 1 and first.subject and all(e.kind == "changed" for e in events):
        return f"{_short(first.subject)} {first.old} \u2192 {last.new} ({len(events)} changes)"
    return f"{short_label(last)} (+{len(events) - 1} more)"


def fit_label(text: str, room: float, measure: Callable[[str], float]) -> str:
    """`text` cut (with an ellipsis) to at most `room` pixels as `measure` measures it; "" when not even a
    few characters fit."""
    if measure(text) <= room:
        return text
    lo, hi = 0, len(text)
    while lo < hi:  # the longest cut that fits
        mid = (lo + hi + 1) // 2
        if measure(text[:mid] + ELLIPSIS) <= room:
            lo = mid
        else:
            hi = mid - 1
    return text[:lo] + ELLIPSIS if lo >= 3 else ""


def event_lines(
    events: Sequence[EventMark],
    t0: float,
    t1: float,
    width: float,
    measure: Callable[[str], float],
    *,
    merge_px: float = MERGE_PX,
    max_label: float | None = None,
) -> list[EventLine]:
    """The lines and labels for `events` on a plot showing `t0`..`t1` over `width` pixels.

    Args:
        events: the events, oldest first.
        t0: the plot's first source time.
        t1: its last.
        width: the plot area's width in pixels.
        measure: a label's width in pixels.
        merge_px: events closer than this share a line.
        max_label: the widest a label may be (default: 40 % of the width).
    """
    if not events or not t1 > t0 or width <= 0:
        return []
    per_px = width / (t1 - t0)
    groups: list[list[EventMark]] = []
    first_x = 0.0
    for event in events:
        if not t0 <= event.time <= t1:
            continue
        x = (event.time - t0) * per_px
        if groups and x - first_x < merge_px:
            groups[-1].append(event)
        else:
            groups.append([event])
            first_x = x
    widest = max(40.0, width * 0.6) if max_label is None else max_label
    rows: list[float] = [float("inf")] * LABEL_ROWS
    """Each row's leftmost label start so far (labels are placed newest first, right to left)."""
    lines: list[EventLine] = []
    for group in reversed(groups):
        first = group[0]
        x = (first.time - t0) * per_px
        full = group_label(group)
        text = fit_label(full, widest, measure)
        placed: tuple[str, int, bool] = ("", 0, False)
        if text:
            w = measure(text)
            for row, bound in enumerate(rows):
                room = min(width, bound - LABEL_GAP_PX)
                if x + LABEL_PAD_PX + w <= room:  # right of its line
                    rows[row] = x
                    placed = (text, row, False)
                    break
                if x - LABEL_PAD_PX - w >= 0 and x - LABEL_PAD_PX <= room:  # left of it
                    rows[row] = x - LABEL_PAD_PX - w
                    placed = (text, row, True)
                    break
        marker = any(e.kind == "marker" for e in group)
        lines.append(EventLine(first.time, x, marker, len(group), full, *placed))
    lines.reverse()
    return lines
