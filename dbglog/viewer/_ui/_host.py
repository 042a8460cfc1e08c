"""What the viewer offers widgets besides their series (`WidgetHost`): log stores, the time cursor, and
"plot this number"; and the warnings and errors the timeline bar marks."""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from dbglog.viewer._data._history import History
from dbglog.viewer._data._logstore import LOG_TYPES, WARN, LogStore
from dbglog.viewer._ui._frame import TITLE_H
from dbglog.viewer._ui._plotnumber import NumberPlan, PlotNumberDialog
from dbglog.viewer._ui._timescale import TimeScale
from dbglog.viewer.widget_api import Binding, ValueKind

if TYPE_CHECKING:
    from dbglog.viewer._ui._app import ViewerApp

__all__ = ["AppHost", "mark_columns"]


class AppHost:
    """The app's `WidgetHost`: hands log stores out (the engine's, or built from a recording's history),
    moves the cursor, opens "Plot this number", and collects the stores' marks for the timeline bar."""

    def __init__(self, app: ViewerApp) -> None:
        self.app = app
        self._stores: weakref.WeakValueDictionary[str, LogStore] = weakref.WeakValueDictionary()
        """The current data source's stores by topic (a recording opened in the window has its own)."""
        self._source: object = app.source

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
                store = LogStore()
                times, payloads = history.payloads(name, -np.inf, np.inf)
                store.push(history.msg_type(name), times, payloads)
        if store is not None:
            self._stores[name] = store
        return store

    def _current(self) -> object:
        """The app's data source; when it changed (a recording opened, live again), its stores start over."""
        source = self.app.source
        if source is not self._source:
            self._source = source
            self._stores = weakref.WeakValueDictionary()
        return source

    def seek(self, t: float) -> None:
        """Pause the dashboard at source time `t`."""
        self.app.seek(t)

    def envelope(
        self, binding: Binding, t0: float, t1: float, pixels: int
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None:
        """The history's min/max envelope of a binding over a range, up to the cursor (the timeline's)."""
        return self.app.timeline.envelope(binding, t0, t1, pixels)

    def plot_number(self, topic: str, line_id: int, number: int) -> None:
        """Open "Plot this number" for a number of a stored line (one dialog at a time, as every dialog)."""
        store = self.log_store(topic)
        if store is None or not store.has(line_id):
            return
        app = self.app
        app.close_dialog()
        types = [
            (cls.type_name, cls.label)
            for cls in app.registry
            if ValueKind.NUMBER in cls.accepts and not cls.publishes and cls.type_name != "log"
        ]
        types.sort(key=lambda t: t[0] != "plot")  # a Plot first: the default
        dialog = PlotNumberDialog(store, topic, line_id, number, types, self.add_plan, app.dialog_closed)
        app.open_dialog(dialog)

    def add_plan(self, plan: NumberPlan) -> None:
        """Add the widget "Plot this number" asked for, below the selected widget (or where there is room)."""
        app = self.app
        near = app.selected.rect if app.selected is not None and app.selected in app.items else None
        x, y = (near.x, near.y + near.h + 10 + TITLE_H / 2) if near is not None else (40.0, 40.0)
        item = app.add_widget(plan.type_name, x + 20, y)
        if item is None:
            return
        app.apply_bindings(item, (plan.binding,))
        if plan.properties:
            item.set_properties(plan.properties)
        app.rename(item, plan.name)
        app.set_status(f"added {plan.name!r}: {plan.binding.topic} /{plan.binding.regex}/")

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
