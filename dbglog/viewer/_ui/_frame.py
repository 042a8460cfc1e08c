"""One widget on the canvas: its frame (title strip, status pill, resize grip) around the widget's body."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Sequence
from dataclasses import replace
from typing import Protocol

import dearpygui.dearpygui as dpg

from dbglog.viewer._data._model import EVERY_ROBOT, SELECTED_ROBOT, Binding, SeriesSnapshot, Status
from dbglog.viewer._data._robots import Fleet, is_relative
from dbglog.viewer._data._timeline import Timeline
from dbglog.viewer._document._dashboard import RawWidget, WatchConfig, WidgetConfig
from dbglog.viewer._ui._theme import DIM, HEADER, STATUS_COLORS, TEXT
from dbglog.viewer._widgets._common import text_size
from dbglog.viewer._widgets._geometry import Rect
from dbglog.viewer.widget_api import (
    PropValue,
    PublishService,
    TimeRange,
    Widget,
    WidgetContext,
    WidgetHost,
    shown_as,
)

__all__ = [
    "TITLE_H",
    "CanvasItem",
    "FrameSnapshots",
    "SnapshotReader",
    "StatusNote",
    "combined_status",
    "parameter_misbound",
]

_log = logging.getLogger(__name__)

TITLE_H = 28
"""Height of the title strip in pixels: dragging it moves the widget."""
GRIP = 14
"""Size of the bottom-right resize grip."""
PAD = 6

_ORDER = {Status.ERROR: 0, Status.WAITING: 1, Status.STALE: 2, Status.LIVE: 3}


class SnapshotReader(Protocol):
    """Where a canvas item reads its series from: any `DataSource`, or the frame's `FrameSnapshots`."""

    def snapshot(self, binding: Binding) -> SeriesSnapshot:
        """Return the series of `binding` as the frame shows it."""


class StatusNote(Protocol):
    """What, besides its series, has a say in a widget's status (a watch: armed, its process gone)."""

    def over(self, status: Status, reason: str) -> tuple[Status, str, str]:
        """The status, the pill's text and the reason to show, given those of the widget's series."""
        ...


class FrameSnapshots:
    """The snapshots of one look at the data: each binding read from the timeline once per frame.

    `ViewerApp._look` (is anything new?) and `_work` (redraw what is) ask for the same series, and
    several widgets may share one: a paused snapshot costs a history search, so it is read once. What
    was read is forgotten at `begin` (each look), and as soon as the cursor, the source or the stale
    time differs from when it was read. Paused over a history that did not change (its sample count,
    span, evictions), a look keeps what was read, for at most `keep_s` (a series' state that comes with
    no sample, such as a type error, still shows within that time). Paused, a reader may ask for only the
    last `past` seconds of samples (a gauge needs the value, a plot its range): a copy of the whole
    window is then read only for a widget that wants it.
    """

    def __init__(self, timeline: Timeline, *, keep_s: float = 1.0) -> None:
        self.timeline = timeline
        self.keep_s = keep_s
        self.reads = 0
        """Snapshots read from the timeline so far (the tests and the benchmark read this)."""
        self._memo: dict[Binding, tuple[float | None, SeriesSnapshot]] = {}
        """Each binding's snapshot with the `past` it was read for (None: all of it)."""
        self._state: tuple[object, ...] = ()
        self._history: object = None
        self._read_at = -math.inf

    def _now(self) -> tuple[object, ...]:
        timeline = self.timeline
        return (timeline.cursor, id(timeline.source), timeline.stale_after)

    def begin(self) -> None:
        """A new look: forget what was read, unless paused over a history that did not change."""
        state = self._now()
        history = self.timeline.stats() if state[0] is not None else None
        now = time.monotonic()
        if (
            history is not None
            and (state, history) == (self._state, self._history)
            and now < self._read_at + self.keep_s
        ):
            return
        self._memo.clear()
        self._state, self._history, self._read_at = state, history, now

    def snapshot(self, binding: Binding, past: float | None = None) -> SeriesSnapshot:
        """Return the timeline's snapshot of `binding`, read once since `begin` at this cursor.

        Args:
            binding: the series.
            past: the seconds of samples before the cursor the caller needs (None: all the source gives);
                a snapshot read for more is handed out as it is.
        """
        state = self._now()
        if state != self._state:
            self._memo.clear()
            self._state = state
        held = self._memo.get(binding)
        if held is not None and (held[0] is None or (past is not None and past <= held[0])):
            return held[1]
        snap = self.timeline.snapshot(binding, past)
        if snap.count:  # nothing yet is no search to save, and a binding just made fills within a frame
            self._memo[binding] = (past, snap)
        self.reads += 1
        return snap


def combined_status(snapshots: Sequence[SeriesSnapshot]) -> tuple[Status, str]:
    """Return the worst status of a widget's series and the reasons behind it (no series = waiting)."""
    if not snapshots:
        return Status.WAITING, "no topic set: right-click \u203a Topic setup"
    worst = min(snapshots, key=lambda s: _ORDER[s.status])
    reasons = [f"{s.binding.topic}: {s.reason}" for s in snapshots if s.status == worst.status and s.reason]
    return worst.status, "\n".join(reasons)


class CanvasItem:
    """A placed widget: owns its Dear PyGui frame and its widget instance (None for a placeholder)."""

    def __init__(
        self,
        config: WidgetConfig | RawWidget,
        widget_cls: type[Widget] | None,
        canvas: int | str,
        theme: int | str,
        *,
        publisher: PublishService | None = None,
        host: WidgetHost | None = None,
        time_range: TimeRange | None = None,
    ) -> None:
        self.config = config
        self.widget_cls = widget_cls
        self.publisher = publisher
        """The app's publishing service, handed to the widget in its `WidgetContext`."""
        self.host = host
        """The app's other services for widgets (log stores, the time cursor), in the `WidgetContext` too."""
        self.time_range = time_range
        """The time range the app's time plots share, in the `WidgetContext` too."""
        self._resolved: tuple[Binding, ...] = tuple(b for b in config.bindings if not is_relative(b))
        """Its bindings as resolved for the selected robot (`resolve`): a control's publish targets, or the
        series the data source fills."""
        self.widget: Widget | None = None
        self.failed = ""
        """Why the widget was disabled after raising, or empty."""
        self.status = Status.WAITING
        self.reason = ""
        self.updates = 0
        """How many times the widget was redrawn (tests and the benchmark read this)."""
        self.edited = False
        """Set by `refresh` when the widget changed a saved property itself; the viewer clears it."""
        self._key: tuple[object, ...] | None = None
        self._pill_state: tuple[Status, str, bool, str | None] | None = None
        self._paused = False
        self.pill_label = ""
        """What the status pill says (``live``; paused, ``live then``)."""
        """The dashboard is paused at a time: the pill says the status *then* ("live then")."""
        self.note: StatusNote | None = None
        """What besides the series has a say in the status (a watch); set on the UI thread, compared by
        value (a new one redraws the pill)."""
        self._pill_text: str | None = None
        """The pill's text when the note gives one (``armed``, ``gone``), else the status's."""
        x, y, w, h = self.geometry()
        self.window = dpg.add_child_window(
            parent=canvas,
            pos=(int(x), int(y)),
            width=int(w),
            height=int(h),
            no_scrollbar=True,
            no_scroll_with_mouse=True,
            border=True,
        )
        dpg.bind_item_theme(self.window, theme)
        self.frame_look = (False, True)
        """(selected, filled): the look of the frame's theme, as the app last bound it."""
        self._build(int(w), int(h))

    # -- geometry and config ------------------------------------------------------------------------

    def geometry(self) -> tuple[float, float, float, float]:
        """Return x, y, width, height on the canvas."""
        return self.config.geometry()

    @property
    def rect(self) -> Rect:
        """The frame's rectangle in canvas pixels."""
        return Rect(*self.geometry())

    @property
    def name(self) -> str:
        """The title shown on the frame."""
        return self.config.name

    @property
    def bindings(self) -> tuple[Binding, ...]:
        """The widget's series (none for a placeholder)."""
        return self.config.bindings

    @property
    def publishes(self) -> bool:
        """Whether the widget is a control (its bindings are where it publishes)."""
        return self.widget_cls is not None and self.widget_cls.publishes

    @property
    def series(self) -> tuple[Binding, ...]:
        """The bindings the data source fills, robot-relative ones resolved: none for a control (its bindings
        are where it publishes), nor a binding to a node's parameter of a widget that shows parameters."""
        cls = self.widget_cls
        if cls is not None and cls.publishes:
            return ()
        return tuple(b for b in self._resolved if b.parameter is None)  # no data source has parameters

    def _parameter_errors(self) -> list[SeriesSnapshot]:
        """A widget that shows topics, bound to a node's parameter: an error saying which widgets take one."""
        cls = self.widget_cls
        if cls is None or cls.parameters or cls.publishes:
            return []
        return [
            SeriesSnapshot(b, Status.ERROR, reason=parameter_misbound(b, cls.label))
            for b in self._resolved
            if b.parameter is not None
        ]

    def context(self) -> WidgetContext:
        """What the widget is given at mount: a control's publish targets (a widget's parameters), robot-
        relative ones resolved, and the app's publisher."""
        return WidgetContext(self._targets(), self.publisher, self.host, self.time_range)

    def _targets(self) -> tuple[Binding, ...]:
        cls = self.widget_cls
        if cls is not None and cls.publishes:
            return self._resolved
        if cls is not None and cls.parameters:
            return tuple(b for b in self._resolved if b.parameter is not None)
        return ()

    def resolve(self, fleet: Fleet) -> tuple[Binding, ...]:
        """Resolve the bindings against `fleet` (the selected robot; every robot's for an overlay) and return
        the series to fill; a control that publishes to the selected robot gets its new target."""
        bindings = self.bindings
        resolved = tuple(fleet.shown(b) for b in bindings) if self.publishes else fleet.expand_all(bindings)
        if resolved != self._resolved:
            targets = self._targets()
            self._resolved = resolved
            self.invalidate()
            if self.widget is not None and self._targets() != targets and not self.failed:
                try:
                    self.widget.set_context(self.context())  # publishes to the robot now selected
                except Exception as exc:
                    self._fail(f"widget failed to take its new bindings: {exc!r}")
            if dpg.does_item_exist(self.header):
                self._draw_header(int(self.geometry()[2]))
        return self.series

    @property
    def label(self) -> str | None:
        """The widget type's label (None for a placeholder)."""
        return self.widget_cls.label if self.widget_cls is not None else None

    @property
    def min_size(self) -> tuple[int, int]:
        """The smallest frame the widget accepts."""
        if self.widget_cls is None:
            return (80, 60)
        return (self.widget_cls.min_size[0], self.widget_cls.min_size[1] + TITLE_H)

    def body_size(self, w: float, h: float) -> tuple[int, int]:
        """Return the widget body size inside a frame of w x h."""
        return max(10, int(w) - 2 * PAD), max(10, int(h) - TITLE_H - 2 * PAD)

    # -- building -----------------------------------------------------------------------------------

    def _build(self, w: int, h: int) -> None:
        self.header_group = dpg.add_group(parent=self.window)
        self.header = dpg.add_drawlist(w, TITLE_H, parent=self.header_group)
        with dpg.tooltip(self.header_group) as tip:
            self.tooltip_text = dpg.add_text("", wrap=360)
        self.tooltip = tip
        self._draw_header(w)
        with dpg.group(parent=self.window, indent=PAD) as body:
            self.body = body
        bw, bh = self.body_size(w, h)
        config = self.config.editable
        if self.widget_cls is not None and config is not None:
            try:
                self.widget = self.widget_cls(dict(config.properties))
                # The context is set before mount, which keeps its three-argument form: plugins written
                # before the context existed override mount(parent, width, height) and still work.
                self.widget.context = self.context()
                self.widget.mount(self.body, bw, bh)
            except Exception as exc:  # a broken widget class must not take the viewer down
                self._fail(f"widget failed to build: {exc!r}")
        else:
            reason = self.config.reason if isinstance(self.config, RawWidget) else "unknown widget type"
            dpg.add_text(
                f"'{self.config.type}' is not available", parent=self.body, color=STATUS_COLORS[Status.ERROR]
            )
            dpg.add_text(reason, parent=self.body, wrap=max(60, bw), color=DIM)
            dpg.add_text(
                "Kept as it is in the dashboard file.", parent=self.body, wrap=max(60, bw), color=DIM
            )
            self.status, self.reason = Status.ERROR, reason
            self._draw_header(w)  # the pill was drawn before the status was known
        # A drawlist ignores `pos` (Dear PyGui 2.3 lays it out after the body, at the left): a group keeps it.
        self.grip_group = dpg.add_group(parent=self.window, pos=self._grip_pos(w, h))
        self.grip = dpg.add_drawlist(GRIP, GRIP, parent=self.grip_group)
        for k in (4, 8, 12):
            dpg.draw_line((GRIP - 2, GRIP - 2 - k), (GRIP - 2 - k, GRIP - 2), color=DIM, parent=self.grip)

    @staticmethod
    def _grip_pos(w: int, h: int) -> tuple[int, int]:
        """Where the resize grip sits in a frame of w x h: its bottom-right corner, inside the border."""
        return (w - GRIP - 2, h - GRIP - 2)

    def _draw_header(self, w: int) -> None:
        dl = self.header
        dpg.delete_item(dl, children_only=True)
        # The strip with rounded top corners, as two rectangles and two corner discs: a rounded rectangle is a
        # fan of long thin triangles, several times dearer for a software renderer than these few.
        r, none = 6, (0, 0, 0, 0)
        dpg.draw_rectangle((0, r), (w, TITLE_H), color=none, fill=HEADER, parent=dl)
        dpg.draw_rectangle((r, 0), (w - r, r), color=none, fill=HEADER, parent=dl)
        dpg.draw_circle((r, r), r, color=none, fill=HEADER, parent=dl)
        dpg.draw_circle((w - r, r), r, color=none, fill=HEADER, parent=dl)
        status = self.status
        then = self._paused and status in (Status.LIVE, Status.STALE)
        text = self._pill_text or status.value
        label = self.pill_label = f"{text} then" if then else text
        pill_w = text_size(label, 13)[0] + 26
        max_chars = max(3, int((w - pill_w - 24) / (15 * 0.55)))
        title = self.name if len(self.name) <= max_chars else self.name[: max_chars - 1] + "\u2026"
        dpg.draw_text((10, 6), title, size=15, color=TEXT, parent=dl)
        color = STATUS_COLORS[status]
        x1 = w - 8
        x0 = x1 - pill_w
        fill = (color[0], color[1], color[2], 60)
        dpg.draw_rectangle((x0, 5), (x1, TITLE_H - 5), color=color, fill=fill, rounding=9, parent=dl)
        dpg.draw_circle((x0 + 10, TITLE_H / 2), 4, color=color, fill=color, parent=dl)
        dpg.draw_text((x0 + 18, 6.5), label, size=13, color=TEXT, parent=dl)
        tip = {
            Status.WAITING: "Waiting for data",
            Status.LIVE: "Live",
            Status.STALE: "Stale: no new message for a while",
            Status.ERROR: "Error",
        }[status]
        if then:
            tip = f"{tip} at the cursor time (the dashboard is paused)"
        bindings = "\n".join(
            f"{b.topic}" + (f" \u203a {b.field}" if b.field else "") + (f"  /{b.regex}/" if b.regex else "")
            for b in self._resolved
        )
        following = {b.robot for b in self.bindings} & {SELECTED_ROBOT, EVERY_ROBOT}
        if following:
            whose = "every robot's" if EVERY_ROBOT in following else "the selected robot's"
            bindings = f"{whose} topics (the Robot menu switches):\n{bindings}"
        dpg.set_value(self.tooltip_text, "\n".join(x for x in (tip, self.reason, bindings) if x))
        self._pill_state = (status, self.reason, self._paused, self._pill_text)

    # -- live updates -------------------------------------------------------------------------------

    def snapshots(self, source: SnapshotReader) -> list[SeriesSnapshot]:
        """Return what the widget is given from `source`: its stale time applied, wrong kinds as errors."""
        return self._snapshots(source)

    def _snapshots(self, source: SnapshotReader) -> list[SeriesSnapshot]:
        past = self._past_needed(source)
        if past is not None and isinstance(source, FrameSnapshots):
            snapshots = [source.snapshot(b, past) for b in self.series]
        else:
            snapshots = [source.snapshot(b) for b in self.series]
        stale_after = self.config.stale_after
        if stale_after is not None:
            snapshots = [s.with_stale_time(stale_after) for s in snapshots]
        if self.widget_cls is not None:  # a kind the widget did not declare is an error, not shown
            snapshots = [shown_as(self.widget_cls, s) for s in snapshots]
        return snapshots + self._parameter_errors()

    def _past_needed(self, source: SnapshotReader) -> float | None:
        """The seconds of samples before the cursor the widget draws, if it says (`Widget.past_needed`);
        None: all of them (live, or a widget that does not say)."""
        if not isinstance(source, FrameSnapshots) or self.widget is None or self.failed:
            return None
        at = source.timeline.cursor
        if at is None:
            return None
        try:
            past = self.widget.past_needed(at)
            seconds = None if past is None else float(past)
        except Exception:  # a wrong answer costs only a copy: read everything
            _log.debug("%s: past_needed failed", self.name, exc_info=True)
            return None
        if seconds is None or not seconds < math.inf:  # NaN or infinite: everything
            return None
        return max(0.0, seconds)

    def current_status(self, source: SnapshotReader) -> tuple[Status, str]:
        """The status and reason `refresh` would show now, read from `source` without drawing anything.

        A widget out of view is not refreshed (`Canvas.refresh`): its pill shows what it showed last, and
        this says what it would show.
        """
        if self.widget is None or self.failed:
            return self.status, self.reason
        try:
            own = self.widget.status()
        except Exception as exc:  # `refresh` disables the widget and says why
            return Status.ERROR, f"widget failed to report its status: {exc!r}"
        status, reason = own if own is not None else combined_status(self._snapshots(source))
        if self.note is not None:
            status, _pill, reason = self.note.over(status, reason)
        return status, reason

    def changed(self, source: SnapshotReader, *, paused_at: float | None = None) -> bool:
        """Whether `refresh` would redraw now (a count, status or reason changed, the cursor moved)."""
        if self.widget is None or self.failed:
            return False
        try:
            own = self.widget.status()
            drawn = self.widget.redraw_key()
        except Exception:  # `refresh` disables the widget and says why
            return True
        key = _state_key(self._snapshots(source), (own, self.note), paused_at, drawn)
        return key != self._key or self.widget.props_changed

    def refresh(self, source: SnapshotReader, now: float, *, paused_at: float | None = None) -> None:
        """Read the snapshots; redraw only when a count, status or reason changed, or the cursor moved.

        Args:
            source: where the snapshots come from (the app's timeline: live, or as they stood at a time).
            now: the moment shown, given to the widget: the wall clock live, the cursor time paused.
            paused_at: the cursor's source time while paused (None live), set on the widget as
                `Widget.paused_at` before it draws.
        """
        if self.widget is None or self.failed:
            return
        snapshots = self._snapshots(source)
        try:
            own = self.widget.status()  # control widgets report their own state (publishing)
            drawn = self.widget.redraw_key()  # a widget's own input or data (a console's)
        except Exception as exc:
            self._fail(f"widget failed to report its status: {exc!r}")
            return
        config = self.config.editable
        if self.widget.props_changed and config is not None:
            # The widget changed a property itself (a control's value): keep it for saving, and say so
            # when the value really differs (a slider let go where it was changes nothing).
            self.widget.props_changed = False
            props = dict(self.widget.props)
            if props != dict(config.properties):
                self.config = replace(config, properties=props)
                self.edited = True
        key = _state_key(snapshots, (own, self.note), paused_at, drawn)
        if key == self._key:
            return
        self._key = key
        status, reason = own if own is not None else combined_status(snapshots)
        self._pill_text = None
        if self.note is not None:
            status, self._pill_text, reason = self.note.over(status, reason)
        self.status, self.reason = status, reason
        self._paused = paused_at is not None
        if (self.status, self.reason, self._paused, self._pill_text) != self._pill_state:
            self._draw_header(int(self.geometry()[2]))
        try:
            self.widget.paused_at = paused_at
            self.widget.update(snapshots, now)
        except Exception as exc:  # one failing widget is disabled; the others keep running
            self._fail(f"widget failed while drawing: {exc!r}")
            return
        self.updates += 1

    def _fail(self, reason: str) -> None:
        _log.warning("%s (%s): %s", self.name, self.config.type, reason)
        self.failed = reason
        self.status, self.reason = Status.ERROR, reason
        self._draw_header(int(self.geometry()[2]))
        self._show_disabled(reason)

    def _show_disabled(self, reason: str) -> None:
        """Replace a failed widget's half-drawn body with a notice saying it is disabled and why."""
        try:
            if dpg.does_item_exist(self.body):
                dpg.delete_item(self.body, children_only=True)
                wrap = max(60, self.body_size(*self.geometry()[2:])[0])
                dpg.add_text("Widget disabled", parent=self.body, color=STATUS_COLORS[Status.ERROR])
                dpg.add_text(reason, parent=self.body, wrap=wrap, color=DIM)
        except Exception:  # the notice is a courtesy: the frame must outlive whatever the widget left
            _log.debug("could not show the disabled notice of %s", self.name, exc_info=True)

    def invalidate(self) -> None:
        """Force a redraw on the next refresh."""
        self._key = None

    # -- edits --------------------------------------------------------------------------------------

    def place(self, rect: Rect, *, rebuild: bool) -> None:
        """Move/resize the frame; with `rebuild`, fit the widget body to the new size."""
        self.config = self.config.placed(rect.x, rect.y, rect.w, rect.h)
        w, h = int(rect.w), int(rect.h)
        dpg.configure_item(self.window, pos=(int(rect.x), int(rect.y)), width=w, height=h)
        if rebuild:
            dpg.configure_item(self.header, width=w)
            self._draw_header(w)
            dpg.configure_item(self.grip_group, pos=self._grip_pos(w, h))
            if self.widget is not None and not self.failed:
                try:
                    self.widget.resize(*self.body_size(w, h))
                except Exception as exc:
                    self._fail(f"widget failed to resize: {exc!r}")
            self.invalidate()

    def rename(self, name: str) -> None:
        """Change the title."""
        self.config = self.config.renamed(name)
        self._draw_header(int(self.geometry()[2]))

    def set_stale_after(self, seconds: float | None) -> None:
        """Give the widget its own stale time (None: the viewer's)."""
        config = self.config.editable
        if config is not None and seconds != config.stale_after:
            self.config = replace(config, stale_after=seconds)
            self.invalidate()

    def set_watch(self, watch: WatchConfig | None) -> None:
        """Give the widget the variable of a running program it shows (None: none); saved with it."""
        config = self.config.editable
        if config is not None and watch != config.watch:
            self.config = replace(config, watch=watch)
            self.invalidate()

    def set_bindings(self, bindings: tuple[Binding, ...]) -> None:
        """Point the widget at new series."""
        config = self.config.editable
        if config is not None:
            self.config = replace(config, bindings=bindings)
            # The robot-relative ones wait for the document to resolve them.
            self._resolved = tuple(b for b in bindings if not is_relative(b))
            self.invalidate()
            self._draw_header(int(self.geometry()[2]))
            if self.widget is not None and not self.failed:
                try:
                    self.widget.set_context(self.context())  # a control's new publish target
                except Exception as exc:
                    self._fail(f"widget failed to take its new bindings: {exc!r}")

    def set_properties(self, props: dict[str, PropValue]) -> None:
        """Apply validated property values and rebuild the widget."""
        config = self.config.editable
        if config is None or self.widget is None:
            return
        self.config = replace(config, properties={**config.properties, **props})
        if self.failed:
            return  # saved with the dashboard; a disabled widget is not called again
        try:
            self.widget.set_properties(props)
        except Exception as exc:
            self._fail(f"widget failed to apply properties: {exc!r}")
        self.invalidate()

    def destroy(self) -> None:
        """Remove the frame and the widget's items."""
        if self.widget is not None:
            try:
                self.widget.destroy()  # lets a widget release what it holds (a control's publisher)
            except Exception:
                _log.debug("%s: widget destroy failed", self.name, exc_info=True)
        if dpg.does_item_exist(self.window):
            dpg.delete_item(self.window)


def _state_key(
    snapshots: Sequence[SeriesSnapshot], own: object, paused_at: float | None, drawn: object = None
) -> tuple[object, ...]:
    """What a widget's redraw depends on: each series' count, status and reason, its own state, the cursor,
    and its own redraw key."""
    return (*((s.count, s.status, s.reason) for s in snapshots), own, paused_at, drawn)


def parameter_misbound(binding: Binding, label: str) -> str:
    """Why a widget that shows topics (a `label`) shows nothing of a binding to a node's parameter."""
    return (
        f"{binding.topic} is a node's parameter: a Slider, Knob, Toggle or Text field shows and sets one; "
        f"a {label} shows a topic's values (Topic setup)"
    )
