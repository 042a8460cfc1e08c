"""A DataSource that serves series you fill by hand: for UI tests, the benchmark baseline and offline docs.

Not a ROS stand-in: it only holds arrays and returns them as snapshots; the viewer cannot tell it from
the engine, which is the point of coding the UI against the `DataSource` protocol.
"""

from __future__ import annotations

import threading
import time
from dataclasses import replace

import numpy as np

from dbglog.viewer._data._model import Binding, FieldInfo, SeriesSnapshot, Status, TopicInfo, ValueKind

__all__ = ["StaticSource"]


class StaticSource:
    """Series by binding, topics and fields, all set by the caller; thread-safe."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._series: dict[tuple[str, str], SeriesSnapshot] = {}
        self._topics: dict[str, TopicInfo] = {}
        self._fields: dict[str, list[FieldInfo]] = {}
        self.bound: set[Binding] = set()
        self.bind_calls = 0

    def add_topic(self, name: str, msg_type: str, fields: list[FieldInfo] | None = None) -> None:
        """Make a topic appear on the 'graph' with its fields."""
        with self._lock:
            self._topics[name] = TopicInfo(name, (msg_type,), 1)
            self._fields[name] = list(fields or [])

    def push(self, topic: str, field: str, value: float | bool | str, t: float | None = None) -> None:
        """Append one value to the series of (topic, field), marking it live."""
        now = time.time() if t is None else t
        with self._lock:
            old = self._series.get((topic, field))
            binding = Binding(topic, field)
            if isinstance(value, str):
                texts = ((old.texts if old else ()) + (value,))[-500:]
                times = np.append(old.times if old else np.empty(0), now)[-500:]
                snap = SeriesSnapshot(binding, Status.LIVE, kind=ValueKind.TEXT, times=times, texts=texts)
            else:
                kind = ValueKind.BOOL if isinstance(value, bool) else ValueKind.NUMBER
                times = np.append(old.times if old else np.empty(0), now)[-20000:]
                values = np.append(old.values if old else np.empty(0), float(value))[-20000:]
                snap = SeriesSnapshot(binding, Status.LIVE, kind=kind, times=times, values=values)
            count = (old.count if old else 0) + 1
            self._series[(topic, field)] = replace(snap, last=value, last_time=now, count=count, age_s=0.0)

    def set_series(self, topic: str, field: str, times: np.ndarray, values: np.ndarray) -> None:
        """Replace the whole numeric series of (topic, field)."""
        with self._lock:
            old = self._series.get((topic, field))
            count = (old.count if old else 0) + len(values)
            self._series[(topic, field)] = SeriesSnapshot(
                Binding(topic, field),
                Status.LIVE,
                kind=ValueKind.NUMBER,
                times=np.asarray(times, dtype=np.float64),
                values=np.asarray(values, dtype=np.float64),
                last=float(values[-1]) if len(values) else None,
                last_time=float(times[-1]) if len(times) else None,
                count=count,
            )

    def set_status(
        self, topic: str, field: str, status: Status, reason: str = "", *, age_s: float | None = None
    ) -> None:
        """Force the status (and reason, and optionally the age) of a series, e.g. to show stale or error."""
        with self._lock:
            old = self._series.get((topic, field)) or SeriesSnapshot(Binding(topic, field), status)
            age = old.age_s if age_s is None else age_s
            self._series[(topic, field)] = replace(
                old, status=status, reason=reason, count=old.count + 1, age_s=age
            )

    # -- DataSource ---------------------------------------------------------------------------------

    def bind(self, binding: Binding) -> None:
        """Record the binding (the data is whatever the caller pushed)."""
        with self._lock:
            self.bound.add(binding)
            self.bind_calls += 1

    def unbind(self, binding: Binding) -> None:
        """Forget the binding."""
        with self._lock:
            self.bound.discard(binding)

    def snapshot(self, binding: Binding) -> SeriesSnapshot:
        """Return the series for (topic, field), with the regex applied to text values when set."""
        with self._lock:
            snap = self._series.get((binding.topic, binding.field))
        if snap is None:
            return SeriesSnapshot(binding, Status.WAITING, reason=f"{binding.topic} is not published")
        snap = replace(snap, binding=binding)
        if binding.regex and isinstance(snap.last, str):
            from dbglog._regex._compile import RegexError, compile_regex

            try:
                found = compile_regex(binding.regex).extract(snap.last)
            except RegexError as exc:
                return replace(snap, status=Status.ERROR, reason=str(exc))
            if found is None:
                return replace(snap, status=Status.ERROR, reason="regex does not match the latest value")
            return replace(snap, last=found)
        return snap

    def topics(self) -> list[TopicInfo]:
        """Return the topics added so far, sorted by name."""
        with self._lock:
            return sorted(self._topics.values(), key=lambda t: t.name)

    def fields(self, topic: str) -> list[FieldInfo]:
        """Return the fields given for the topic."""
        with self._lock:
            return list(self._fields.get(topic, []))
