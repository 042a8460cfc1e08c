"""A recording as the viewer's data source: its messages in a `History`, bindings fed by the engine's code.

`load_replay(path)` reads an MCAP file (``dbglog record``'s, ``ros2 bag``'s, any ROS 2 profile file)
into a history: dbglog tags from the batch topic (every sample with its source time) or their own topics,
single-value std_msgs topics as numbers, every other topic as its CDR bytes. `ReplaySource` then
answers like the live engine: `bind` resolves a binding's field, regex and transforms with the same
sink code (`_sinks`) and fills its series from the whole recording at once; `snapshot_at` gives the
state at any time, so the same `Timeline`, widgets and dashboards replay what they showed live. No
ROS graph, no Dear PyGui; rclpy only to deserialize payloads of types installed here.
"""

from __future__ import annotations

import os
import threading

import numpy as np

from dbglog._ros._batch import batch_robot
from dbglog._ros._cdr import string_payload
from dbglog.record._inspect import tag_series
from dbglog.record._reader import Recording, read_recording, recording_span
from dbglog.viewer._data._events import EventStore, events_of
from dbglog.viewer._data._fields import FieldPathError, list_fields, message_class
from dbglog.viewer._data._history import History
from dbglog.viewer._data._model import Binding, FieldInfo, SeriesSnapshot, TopicInfo
from dbglog.viewer._data._series import Series, SeriesTimes
from dbglog.viewer._data._sinks import backfill, make_sink, prepare, same_values
from dbglog.viewer._data._suggest import close_matches

__all__ = ["ReplaySource", "history_of", "load_replay"]

_FOREVER_S = 100 * 365 * 86400.0
"""A recording is kept whole: its history has no duration limit (the memory cap still holds)."""


def history_of(recording: Recording, *, max_bytes: int) -> tuple[History, dict[str, str]]:
    """Return a history holding every readable message of `recording`, and each topic's type."""
    store = History(clock=None, max_seconds=_FOREVER_S, max_bytes=max_bytes)
    types: dict[str, str] = {}
    for series in tag_series(recording).values():
        name = series.topic
        times = series.times_ns.astype(np.float64) * 1e-9
        types[name] = f"std_msgs/msg/{series.std_type}"
        if isinstance(series.values, list):
            payloads = [string_payload(v) for v in series.values]
            store.append_payloads(name, times, payloads, msg_type=types[name])
        else:
            store.append_numbers(name, times, series.values)
    for name, topic in recording.topics.items():
        if batch_robot(name) is not None or name in types or not len(topic):
            continue
        types[name] = topic.msg_type
        times = topic.times_ns.astype(np.float64) * 1e-9
        if topic.values is not None:
            store.append_numbers(name, times, topic.values)
        else:
            store.append_payloads(name, times, list(topic.payloads()), msg_type=topic.msg_type)
    return store, types


_FIRST_SECONDS = 10.0
"""A long recording opens with its last this many seconds, the rest loading behind."""
_LONG_FILE_BYTES = 32 << 20
"""Files at least this big open progressively (a smaller one loads whole in well under a second)."""


def _problems(recording: Recording) -> list[str]:
    unreadable = recording.unreadable.items()
    return [*recording.problems, *(f"{recording.path}: {t} is unreadable: {why}" for t, why in unreadable)]


def load_replay(
    path: str | os.PathLike[str],
    *,
    max_bytes: int = 4 << 30,
    stale_after: float = 2.0,
    progressive: bool | None = None,
) -> ReplaySource:
    """Open a recording for the viewer (read-only).

    A long file (``progressive`` None: 32 MB or more; True: always, when it has an index) opens with
    its last seconds at once and loads the rest on a background thread: the source's `loading` is
    True until the whole file is held, then every binding is filled again from all of it.

    Raises:
        RecordingError: the file cannot be read at all (the message names it and says why).
    """
    path = os.fspath(path)
    if progressive is None:
        progressive = os.path.isfile(path) and os.path.getsize(path) >= _LONG_FILE_BYTES
    span = recording_span(path) if progressive else None
    if span is None:
        recording = read_recording(path)
        store, types = history_of(recording, max_bytes=max_bytes)
        return ReplaySource(
            store, types, stale_after=stale_after, name=recording.path, problems=_problems(recording)
        )
    first = read_recording(path, start_ns=max(span[0], span[1] - round(_FIRST_SECONDS * 1e9)))
    store, types = history_of(first, max_bytes=max_bytes)
    source = ReplaySource(store, types, stale_after=stale_after, name=first.path, problems=_problems(first))
    source.loading = True

    def load_all() -> None:
        try:
            whole = read_recording(path)
            full, full_types = history_of(whole, max_bytes=max_bytes)
        except Exception as exc:  # the first seconds stay shown; say why the rest is missing
            source.problems.append(f"{path}: only the last {_FIRST_SECONDS:g} s could be read: {exc}")
            source.loading = False
            return
        source.replace(full, full_types, _problems(whole))

    threading.Thread(target=load_all, name="dbglog-replay-load", daemon=True).start()
    return source


class ReplaySource(SeriesTimes):
    """A `DataSource` and `TimeSource` over a history nothing feeds live (a recording).

    Live (no cursor), a series shows the end of the recording.

    Args:
        store: the recording's history (topics by name).
        types: each topic's ROS type.
        stale_after: seconds without a sample that make a series STALE at a time.
        capacity: values a series hands a widget at most (as the live engine's ring).
        name: what the recording is called in messages (its path).
        problems: what is wrong with the file (shown to the user, the readable part plays).
    """

    def __init__(
        self,
        store: History,
        types: dict[str, str],
        *,
        stale_after: float = 2.0,
        capacity: int = 10_000,
        name: str = "the recording",
        problems: list[str] | None = None,
    ) -> None:
        self.store = store
        self.types = dict(types)
        self.stale_after = stale_after
        self.capacity = capacity
        self.name = name
        self.problems = list(problems or [])
        self._lock = threading.Lock()
        self._series: dict[Binding, Series] = {}
        span = store.stats()
        self._end = span.newest if span.newest is not None else 0.0
        self.loading = False
        """True while the rest of a long recording loads behind its first seconds."""
        self._events: tuple[History, EventStore] | None = None

    def replace(self, store: History, types: dict[str, str], problems: list[str]) -> None:
        """Serve a fuller history of the same recording: every binding is filled again from it."""
        fresh: dict[Binding, Series] = {}
        for binding in list(self._series):
            series = fresh[binding] = Series(binding, self.capacity, store)
            self._fill(binding, series, store, types)
        with self._lock:
            for binding in [b for b in self._series if b not in fresh]:  # bound meanwhile
                series = fresh[binding] = Series(binding, self.capacity, store)
                self._fill(binding, series, store, types)
            self.store, self.types, self.problems = store, dict(types), list(problems)
            self._series = fresh
            stats = store.stats()
            self._end = stats.newest if stats.newest is not None else self._end
            self.loading = False

    # --- DataSource ---------------------------------------------------------------------------------

    def bind(self, binding: Binding) -> None:
        """Fill a series for `binding` from the whole recording (idempotent)."""
        with self._lock:
            if binding in self._series:
                return
            store, types = self.store, self.types
            series = self._series[binding] = Series(binding, self.capacity, store)
        self._fill(binding, series, store, types)

    def _fill(self, binding: Binding, series: Series, store: History, types: dict[str, str]) -> None:
        """Resolve a binding against its topic's type and fill its series from `store`."""
        name = binding.topic.strip()
        name = name if name.startswith("/") else "/" + name
        msg_type = types.get(name)
        if msg_type is None:
            near = close_matches(name, set(types))
            hint = f" (did you mean {', '.join(near)}?)" if near else ""
            series.set_error(f"{name} is not in {self.name}{hint}")
            return
        try:
            cls = message_class(msg_type)
        except FieldPathError as exc:
            series.set_error(str(exc), msg_type=msg_type)
            return
        prepared = prepare(binding)
        if isinstance(prepared, str):
            series.set_error(prepared, msg_type=msg_type)
            return
        sink = make_sink(binding, series, cls, msg_type, *prepared)
        if same_values(sink, cls, msg_type) and store.kind(name) == "numbers":
            series.share(name)
        if sink.kind is None:
            return
        series.set_type(msg_type, sink.kind)
        if not backfill(store, name, cls, sink):
            series.set_waiting(f"{name} has no message in {self.name}")

    def unbind(self, binding: Binding) -> None:
        """Forget the series of `binding` (its values leave the history)."""
        with self._lock:
            series = self._series.pop(binding, None)
            store = self.store
        if series is not None:
            series.store = None
            store.drop(series.own_key)

    def snapshot(self, binding: Binding) -> SeriesSnapshot:
        """Return the series at the end of the recording."""
        return self.snapshot_at(binding, self._end)

    def topics(self) -> list[TopicInfo]:
        """Return the recording's readable topics."""
        return [TopicInfo(name, (t,), 1) for name, t in sorted(self.types.items())]

    def fields(self, topic: str) -> list[FieldInfo]:
        """Return the field paths of a topic's type (empty when that type is not installed here)."""
        msg_type = self.types.get(topic if topic.startswith("/") else "/" + topic)
        if msg_type is None:
            return []
        try:
            return list_fields(message_class(msg_type))
        except FieldPathError:
            return []

    def events(self) -> EventStore:
        """Return the recording's parameter changes and user markers (its ``/parameter_events`` and
        ``/_dbglog/markers``). Call it again rather than keeping it: once a long recording has loaded whole
        this is a new store of the whole file (with the markers added to the old one)."""
        with self._lock:
            store, made = self.store, self._events
            if made is not None and made[0] is store:
                return made[1]
            events = events_of(store)
            if made is not None:
                events.adopt_markers(made[1])
            self._events = (store, events)
            return events

    # --- history (the TimeSource methods come from SeriesTimes) ----------------------------------

    def held_types(self) -> dict[str, str]:
        """Return the ROS type of every topic of the recording."""
        return dict(self.types)

    @property
    def duration(self) -> float:
        """Seconds from the first to the last message."""
        span = self.time_span()
        return 0.0 if span is None else max(0.0, span[1] - span[0])
