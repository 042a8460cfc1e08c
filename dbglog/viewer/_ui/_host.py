"""What the viewer offers widgets besides their series (`WidgetHost`): log stores, the time cursor, and
"plot this number"; and the warnings and errors the timeline bar marks."""

from __future__ import annotations

import weakref
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from dbglog.viewer._data._history import History
from dbglog.viewer._data._logstore import LOG_TYPES, WARN, LogStore
from dbglog.viewer._data._timeline import Timeline
from dbglog.viewer._ui._modal import Dialogs
from dbglog.viewer._ui._plotnumber import NumberPlan, PlotNumberDialog
from dbglog.viewer._ui._timescale import TimeScale
from dbglog.viewer._widgets import WidgetRegistry
from dbglog.viewer.widget_api import Binding, ValueKind

__all__ = ["AppHost", "mark_columns"]


class AppHost:
    """The app's `WidgetHost`: hands log stores out (the engine's, or built from a recording's history),
    moves the cursor, opens "Plot this number", and collects the stores' marks for the timeline bar.

    Args:
        timeline: the window's time cursor over its data source.
        seek: pauses the dashboard at a source time (kept within what is held).
        registry: the widget types ("Plot this number" offers those that show numbers).
        dialogs: the window's dialogs.
        add_plan: adds the widget "Plot this number" asked for.
    """

    def __init__(
        self,
        timeline: Timeline,
        *,
        seek: Callable[[float], None],
        registry: WidgetRegistry,
        dialogs: Dialogs,
        add_plan: Callable[[NumberPlan], object],
    ) -> None:
        self.timeline = timeline
        self._seek, self.registry, self.dialogs, self.add_plan = seek, registry, dialogs, add_plan
        self._stores: weakref.WeakValueDictionary[str, LogStore] = weakref.WeakValueDictionary()
        """The current data source's stores by topic (a recording opened in the window has its own)."""
        self._source: object = timeline.source

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

    def mark_columns(self, scale: TimeScale) -> list[tuple[int, int]]:
        """The timeline bar's marks for `scale`: the worst level held in each pixel column with one."""
        return mark_columns(*self.marks(scale.oldest, scale.newest), scale)


def mark_columns(
    times: npt.NDArray[np.float64], levels: npt.NDArray[np.uint8], scale: TimeScale
) -> list[tuple[int, int]]:
    """(pixel, level) of the worst level among the lines in each pixel column of a timeline track, by pixel.

    However many lines there are, the bar draws one mark per pixel column at most.
    """
    if not len(times) or scale.seconds <= 0:
        return []
    f = np.clip((times - scale.oldest) / scale.seconds, 0.0, 1.0)
    x = np.round(scale.x0 + f * (scale.x1 - scale.x0)).astype(np.int64)
    order = np.lexsort((levels, x))  # by column, then level: the last of a column is its worst
    xs, lv = x[order], levels[order]
    last = np.append(xs[1:] != xs[:-1], True)
    return list(zip(xs[last].tolist(), lv[last].astype(int).tolist(), strict=True))
