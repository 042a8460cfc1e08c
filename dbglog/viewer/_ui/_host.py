"""What the viewer offers widgets besides their series (`WidgetHost`): log stores, the time cursor, "plot
this number", node parameters (`ParamBoard`) and the events store's changes and markers; and the warnings
and errors the timeline bar marks."""

from __future__ import annotations

import time
import weakref
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from dbglog._ros._params import ParamValue, join_name
from dbglog.viewer._data._events import (
    CHANGES,
    Event,
    EventKind,
    EventStore,
    ParamChange,
    event_kind,
    event_label,
)
from dbglog.viewer._data._history import History
from dbglog.viewer._data._logstore import LOG_TYPES, WARN, LogStore
from dbglog.viewer._data._timeline import Timeline
from dbglog.viewer._publishing._params import ParamBoard, ParamState
from dbglog.viewer._ui._modal import Dialogs
from dbglog.viewer._ui._plotnumber import NumberPlan, PlotNumberDialog
from dbglog.viewer._ui._timescale import TimeScale
from dbglog.viewer._widgets import WidgetRegistry
from dbglog.viewer.widget_api import DEFAULT_RATE_LIMIT_HZ, Binding, EventMark, ValueKind

if TYPE_CHECKING:
    from dbglog._ros._paramclient import ParamClient

__all__ = ["EVENTS_ASK_S", "AppHost", "event_mark", "mark_columns"]

EVENTS_ASK_S = 0.5
"""How often the data source is asked for its events store again (a recording's is made anew once it has
loaded whole; the engine's stays the same)."""


class AppHost:
    """The app's `WidgetHost`: hands log stores out (the engine's, or built from a recording's history),
    moves the cursor, opens "Plot this number", and collects the stores' marks for the timeline bar; owns
    the parameter service (`params`) and hands out the events store's changes and markers.

    Args:
        timeline: the window's time cursor over its data source.
        seek: pauses the dashboard at a source time (kept within what is held).
        registry: the widget types ("Plot this number" offers those that show numbers).
        dialogs: the window's dialogs.
        add_plan: adds the widget "Plot this number" asked for.
        params: the parameter client (live; None: no ROS, parameters are read from the events only).
    """

    def __init__(
        self,
        timeline: Timeline,
        *,
        seek: Callable[[float], None],
        registry: WidgetRegistry,
        dialogs: Dialogs,
        add_plan: Callable[[NumberPlan], object],
        params: ParamClient | None = None,
    ) -> None:
        self.timeline = timeline
        self._seek, self.registry, self.dialogs, self.add_plan = seek, registry, dialogs, add_plan
        self._stores: weakref.WeakValueDictionary[str, LogStore] = weakref.WeakValueDictionary()
        """The current data source's stores by topic (a recording opened in the window has its own)."""
        self._source: object = timeline.source
        self._events: tuple[object, EventStore | None, float] | None = None
        """(source, its events store, when it was asked) for `event_store`."""
        self._times: tuple[object, tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]] | None = None
        """`event_times` as last made, with the store and version it was made of."""
        self.params = ParamBoard(
            params,
            self.event_store,
            lambda: timeline.cursor,
            live=lambda: not timeline.recording,
        )
        """The widgets' node parameters: asked, followed through the events, set (`tick` each frame)."""

    def log_store(self, topic: str) -> LogStore | None:
        """The data source's store of `topic`'s lines; a source with only a history gets one built from it."""
        name = topic if topic.startswith("/") else "/" + topic
        source = self._current()
        found = self._stores.get(name)
        if found is not None:
            return found
        make = getattr(source, "log_store", None)
        store: LogStore | None = None
        if callable(make):
            made = make(name)
            store = made if isinstance(made, LogStore) else None
        else:
            history = getattr(source, "store", None)
            if isinstance(history, History) and history.msg_type(name) in LOG_TYPES:
                store = LogStore(worker=True)
                times, payloads = history.payloads(name, -np.inf, np.inf)
                store.push(history.msg_type(name), times, payloads)
        if store is not None:
            self._stores[name] = store
        return store

    def _current(self) -> object:
        """The data source; when it changed (a recording opened, live again), its stores start over."""
        source = self.timeline.source
        if source is not self._source:
            self._source = source
            self._stores = weakref.WeakValueDictionary()
        return source

    def seek(self, t: float) -> None:
        """Pause the dashboard at source time `t`."""
        self._seek(t)

    def cursor(self) -> float | None:
        """The time cursor (None while live)."""
        return self.timeline.cursor

    def marker_time(self) -> tuple[float, str]:
        """Where a marker added now goes, and how to say it: at the cursor; live, now; a recording shown to
        its end, its end."""
        timeline = self.timeline
        if timeline.cursor is not None:
            return timeline.cursor, "the cursor"
        span = timeline.span() if timeline.recording else None
        if span is not None:
            return span[1], "the end of the recording"
        return time.time(), "now"

    def envelope(
        self, binding: Binding, t0: float, t1: float, pixels: int
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None:
        """The history's min/max envelope of a binding over a range, up to the cursor (the timeline's)."""
        return self.timeline.envelope(binding, t0, t1, pixels)

    def plot_number(self, topic: str, line_id: int, number: int) -> None:
        """Open "Plot this number" for a number of a stored line (one dialog at a time, as every dialog)."""
        store = self.log_store(topic)
        if store is None or not store.has(line_id):
            return
        self.dialogs.close()
        types = [
            (cls.type_name, cls.label)
            for cls in self.registry
            if ValueKind.NUMBER in cls.accepts and not cls.publishes and cls.type_name != "log"
        ]
        types.sort(key=lambda t: t[0] != "plot")  # a Plot first: the default
        self.dialogs.open(
            PlotNumberDialog(store, topic, line_id, number, types, self.add_plan, self.dialogs.closed)
        )

    def event_store(self) -> EventStore | None:
        """The data source's events store (the engine's; a recording's, asked again now and then), None for a
        source that keeps none."""
        source = self.timeline.source
        held = self._events
        now = time.monotonic()
        if held is not None and held[0] is source and now - held[2] < EVENTS_ASK_S:
            return held[1]
        make = getattr(source, "events", None)
        made = make() if callable(make) else None
        store = made if isinstance(made, EventStore) else None
        self._events = (source, store, now)
        return store

    def parameter_list(self) -> list[tuple[str, ParamValue]]:
        """Every node's parameter the events store knows a value of, as ``/pid_node:kp`` with it (Topic
        setup's suggestions), sorted."""
        store = self.event_store()
        if store is None:
            return []
        return [
            (join_name(node, name), value)
            for node in store.nodes()
            for name, value in sorted(store.values(node).items())
        ]

    def tick(self) -> None:
        """Once a frame, on the UI thread (a frame hook): the parameters' answers and held-back sets."""
        self.params.tick()

    def parameter(self, target: str) -> ParamState:
        """What a widget bound to a node's parameter shows now (`ParamBoard.state`)."""
        return self.params.state(target)

    def set_parameter(
        self, target: str, value: object, *, final: bool, rate_hz: float = DEFAULT_RATE_LIMIT_HZ
    ) -> None:
        """Set a node's parameter (`ParamBoard.set`): rate limited while dragged, at once when `final`."""
        self.params.set(target, value, final=final, rate_hz=rate_hz)

    def events(self, t0: float, t1: float) -> list[EventMark]:
        """The parameter changes, deletions and user markers from `t0` to `t1`, oldest first."""
        store = self.event_store()
        if store is None:
            return []
        return [event_mark(e) for e in store.between(t0, t1, kinds=CHANGES)]

    def event_times(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
        """Every event's time (changes, deletions, markers), oldest first, and whether each is a user's
        marker: what the timeline bar marks. Made again only when the store changed (all of it: one pass)."""
        store = self.event_store()
        key = (id(store), store.version if store is not None else 0)
        if self._times is not None and self._times[0] == key:
            return self._times[1]
        events = store.all() if store is not None else []
        made = (
            np.array([e.time for e in events], dtype=np.float64),
            np.array([event_kind(e) is EventKind.MARKER for e in events], dtype=np.bool_),
        )
        self._times = (key, made)
        return made

    def events_version(self) -> int:
        """Changes whenever `events` may answer differently (new events, another source)."""
        store = self.event_store()
        return 0 if store is None else hash((id(store), store.version))

    def marks(self, t0: float, t1: float) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.uint8]]:
        """Times and levels of the WARN, ERROR and FATAL lines held from `t0` to `t1` (timeline marks)."""
        times: list[npt.NDArray[np.float64]] = []
        levels: list[npt.NDArray[np.uint8]] = []
        self._current()
        for store in list(self._stores.values()):
            t, lv = store.marks(WARN)
            keep = (t >= t0) & (t <= t1)
            times.append(t[keep])
            levels.append(lv[keep])
        if not times:
            return np.zeros(0), np.zeros(0, dtype=np.uint8)
        return np.concatenate(times), np.concatenate(levels)

    def mark_columns(self, scale: TimeScale) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.uint8]]:
        """The timeline bar's marks for `scale`: the pixel columns with a line, the worst level of each."""
        return mark_columns(*self.marks(scale.oldest, scale.newest), scale)


def event_mark(event: Event) -> EventMark:
    """An events store's change or marker as widgets draw it."""
    if isinstance(event, ParamChange):
        subject = f"{event.node.lstrip('/')}.{event.name}"
        old = "?" if event.old is None else event.old.text
        new = "" if event.new is None else event.new.text
        return EventMark(event.time, event.kind.value, event.label, subject, old, new)
    return EventMark(event.time, event_kind(event).value, event_label(event))


def mark_columns(
    times: npt.NDArray[np.float64], levels: npt.NDArray[np.uint8], scale: TimeScale
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.uint8]]:
    """The pixel columns of a timeline track that hold lines at `times`, in increasing order, and the worst
    of their `levels` in each: however many lines there are, one mark per pixel column at most."""
    if not len(times) or scale.seconds <= 0:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.uint8)
    f = np.clip((times - scale.oldest) / scale.seconds, 0.0, 1.0)
    x = np.round(scale.x0 + f * (scale.x1 - scale.x0)).astype(np.intp)
    first = int(x.min())
    worst = np.zeros(int(x.max()) - first + 1, dtype=np.uint8)
    np.maximum.at(worst, x - first, levels)  # one pass, in the lines' order: no sort
    columns = np.flatnonzero(worst)
    return columns + first, worst[columns]
