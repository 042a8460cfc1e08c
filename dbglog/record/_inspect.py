"""What ``dbglog tags FILE`` and ``dbglog echo TARGET --file FILE`` print about a recording.

A dbglog tag's samples come from the batch topic (every sample with its source time) when the file
holds it, else from the tag's own topic. Other topics are decoded with the message definition stored
in the file (``mcap_ros2``'s dynamic decoder), so types not installed here are read too.
"""

from __future__ import annotations

import os
import re
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from dbglog._ros._batch import BatchError, batch_robot, decode_batch
from dbglog._ros._numbers import NumberType, as_number, as_numbers
from dbglog._ros._tags import TagError, TagName, parse_target, parse_topic
from dbglog._ros._text import format_line
from dbglog.record._reader import Recording, TopicData, read_recording
from dbglog.record._writer import RecordingError

__all__ = ["TagSeries", "echo_lines", "tag_series", "tags_table"]

_FIELD = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+)\])?$")


@dataclass
class TagSeries:
    """One dbglog tag's samples from a recording, oldest first."""

    tag: str
    """The tag as shown (`TagName.label`: the user's text, ``robot1:speed`` in a robot's namespace)."""
    std_type: str
    """``Float64``, ``Int32``, ``Bool``, ``String`` ..."""
    times_ns: npt.NDArray[np.int64]
    values: npt.NDArray[Any] | list[str]
    """As the tag type holds them (int64/uint64 exact, float64, bool), from the batch topic or the tag's
    own topic alike."""
    topic: str = ""
    """The tag's topic."""


def _stderr(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def tag_series(recording: Recording) -> dict[str, TagSeries]:
    """Every dbglog tag's samples by its label (``speed``, ``robot1:speed``): from its robot's batch topic
    where that carries the tag, else its own topic."""
    out: dict[str, TagSeries] = {}
    for name, batch in recording.topics.items():
        robot = batch_robot(name)
        if robot is not None and len(batch):
            _batch_series(batch, robot, out)
    for name, topic in recording.topics.items():
        tag_name = parse_topic(name)
        if tag_name is None:
            continue
        tag = tag_name.label
        if tag in out or not topic.msg_type.startswith("std_msgs/msg/"):
            continue
        std_type = topic.msg_type.rsplit("/", 1)[1]
        if topic.values is not None:
            out[tag] = TagSeries(tag, std_type, topic.times_ns, topic.values, name)
        elif std_type == "String":
            payloads = [_cdr_string(p) for p in topic.payloads()]
            out[tag] = TagSeries(tag, std_type, topic.times_ns, payloads, name)
    return dict(sorted(out.items()))


def _batch_series(batch: TopicData, robot: str, out: dict[str, TagSeries]) -> None:
    """Add the tags of one robot's batch topic to `out`."""
    times: dict[str, list[npt.NDArray[np.int64]]] = {}
    values: dict[str, list[Any]] = {}
    kinds: dict[str, str] = {}
    seen: set[tuple[int, int]] = set()
    for payload in batch.payloads():
        try:
            decoded = decode_batch(payload)
        except BatchError:
            continue
        if (decoded.writer, decoded.seq) in seen:  # re-sent history after a re-subscription
            continue
        seen.add((decoded.writer, decoded.seq))
        for s in decoded.tags:
            kinds[s.tag] = s.std_type
            times.setdefault(s.tag, []).append(s.times_ns)
            values.setdefault(s.tag, []).append(s.values)
    for tag, parts in times.items():
        name = TagName(robot, tag)
        t = np.concatenate(parts)
        order = np.argsort(t, kind="stable")
        if kinds[tag] == "String":
            texts = [x for chunk in values[tag] for x in chunk]
            series = TagSeries(name.label, "String", t[order], [texts[i] for i in order.tolist()], name.topic)
        else:
            v = np.concatenate(values[tag])
            series = TagSeries(name.label, kinds[tag], t[order], v[order], name.topic)
        out[series.tag] = series


def _cdr_string(payload: bytes) -> str:
    n = int.from_bytes(payload[4:8], "little" if payload[1:2] == b"\x01" else "big")
    return payload[8 : 8 + max(0, n - 1)].decode(errors="replace")


def _rate(times_ns: npt.NDArray[np.int64]) -> str:
    if len(times_ns) < 2:
        return "-"
    span = (int(times_ns[-1]) - int(times_ns[0])) / 1e9
    return f"{(len(times_ns) - 1) / span:.1f} Hz" if span > 0 else "-"


def _fmt(value: object, width: int = 24) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, float):
        text = f"{value:.6g}"
    else:
        text = str(value).replace("\n", "⏎")
    return text if len(text) <= width else text[: width - 1] + "…"


def _number_type(std_type: str) -> NumberType:
    """The Python type a numeric std_msgs type's ``data`` has (``Int64`` -> int, ``Bool`` -> bool ...)."""
    if std_type == "Bool":
        return bool
    if std_type.startswith(("Int", "UInt")) or std_type in ("Byte", "Char"):
        return int
    return float


def _open(path: str | os.PathLike[str], warn: Callable[[str], None]) -> Recording:
    recording = read_recording(path)
    for problem in recording.problems:
        warn(f"warning: {problem}")
    for topic, why in recording.unreadable.items():
        warn(f"warning: {recording.path}: {topic} is unreadable: {why}")
    return recording


def tags_table(
    path: str | os.PathLike[str], *, all_topics: bool = False, warn: Callable[[str], None] = _stderr
) -> str:
    """Return the table of a recording's tags (``all_topics``: every topic) with count, rate, first/last.

    Problems with the file (truncated, no index) and unreadable topics are passed to `warn`.

    Raises:
        RecordingError: the file cannot be read at all.
    """
    recording = _open(path, warn)
    rows: list[list[str]] = []
    series = tag_series(recording)
    for tag, s in series.items():
        first: object = None
        last: object = None
        if len(s.times_ns):
            if isinstance(s.values, list):
                first, last = s.values[0], s.values[-1]
            else:
                ends = s.values[[0, -1]].tolist()  # Python numbers: an int64 stays exact
                want = _number_type(s.std_type)
                first, last = as_number(ends[0], want), as_number(ends[1], want)
        name = s.topic if all_topics else tag
        rows.append(
            [
                name,
                f"std_msgs/msg/{s.std_type}",
                f"{len(s.times_ns):,}",
                _rate(s.times_ns),
                _fmt(first),
                _fmt(last),
            ]
        )
    if all_topics:
        for name, topic in recording.topics.items():
            tag_name = parse_topic(name)
            if tag_name is not None and tag_name.label in series:
                continue
            first = last = None
            if topic.values is not None and len(topic):
                want = _number_type(topic.msg_type.rsplit("/", 1)[1])
                ends = topic.values[[0, -1]].tolist()  # Python numbers: an int64 stays exact
                first, last = as_number(ends[0], want), as_number(ends[1], want)
            rows.append(
                [name, topic.msg_type, f"{len(topic):,}", _rate(topic.times_ns), _fmt(first), _fmt(last)]
            )
        for name in recording.unreadable:
            rows.append([name, "(unreadable)", "-", "-", "-", "-"])
        rows.sort(key=lambda r: r[0])
    if not rows:
        return f"{recording.path}: no dbglog tags in this recording (--all lists every topic)"
    header = ["topic" if all_topics else "tag", "type", "count", "rate", "first value", "last value"]
    return _table(header, rows)


def _table(header: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(c) for c in col) for col in zip(header, *rows, strict=True)]
    lines = [
        "  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip() for row in [header, *rows]
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _resolve(recording: Recording, target: str) -> tuple[str, list[tuple[str, int | None]]]:
    """Split TARGET into a topic of the file and a field path (``a.b[2]`` or rqt-style ``/a/b``)."""
    if target.startswith("/"):
        topic, _, path = target.partition(".")
        if topic not in recording.topics:
            parts = topic.split("/")
            for k in range(len(parts) - 1, 1, -1):
                candidate = "/".join(parts[:k])
                if candidate in recording.topics:
                    path = ".".join(parts[k:] + ([path] if path else []))
                    topic = candidate
                    break
    else:
        tag = _tag_target(target)
        topic, path = (tag.topic if tag is not None else target), ""
    fields: list[tuple[str, int | None]] = []
    for part in path.split(".") if path else []:
        m = _FIELD.match(part)
        if not m:
            raise RecordingError(f"{target!r}: {part!r} is not a field name")
        fields.append((m.group(1), int(m.group(2)) if m.group(2) is not None else None))
    return topic, fields


def echo_lines(
    path: str | os.PathLike[str],
    target: str,
    *,
    stamp: bool = False,
    warn: Callable[[str], None] = _stderr,
) -> Iterator[str]:
    """Yield one line per value of `target` (a tag, or ``/topic[.field.path]``) in the recording.

    `stamp` prefixes each with its source time in seconds. Problems with the file go to `warn`.

    Raises:
        RecordingError: the file cannot be read, or the target or field is not in it (named).
    """
    recording = _open(path, warn)
    tag = _tag_target(target)
    if tag is not None:
        series = tag_series(recording).get(tag.label)
        if series is None:
            tags = ", ".join(tag_series(recording)) or "none"
            raise RecordingError(f"{recording.path}: no tag {target!r} in this recording (tags: {tags})")
        times = (series.times_ns / 1e9).tolist()
        want = _number_type(series.std_type)
        values: list[Any] = (
            series.values if isinstance(series.values, list) else as_numbers(series.values, want)
        )
        yield from _lines(times, values, stamp)
        return
    topic, fields = _resolve(recording, target)
    data = recording.topics.get(topic)
    if data is None:
        if topic in recording.unreadable:
            raise RecordingError(f"{recording.path}: {topic} is unreadable: {recording.unreadable[topic]}")
        raise RecordingError(f"{recording.path}: no topic {topic} in this recording")
    times = (data.times_ns / 1e9).tolist()
    if data.values is not None and all(name == "data" for name, idx in fields) and len(fields) <= 1:
        want = _number_type(data.msg_type.rsplit("/", 1)[1])
        yield from _lines(times, as_numbers(data.values, want), stamp)
        return
    decode = _decoder(data)
    for t, payload in zip(times, data.payloads(), strict=True):
        value: Any = decode(payload)
        if not fields and len(_slots(value)) == 1:
            value = getattr(value, _slots(value)[0])  # a single-value message: its value
        for name, idx in fields:
            if not hasattr(value, name):
                have = ", ".join(_slots(value)) or "none"
                raise RecordingError(
                    f"{topic}: field {name!r} is not in {data.msg_type}; its fields are: {have}"
                )
            value = getattr(value, name)
            if idx is not None:
                try:
                    value = value[idx]
                except IndexError:
                    raise RecordingError(f"{topic}: index {idx} is out of range in {name}") from None
        yield format_line(_plain(value), t if stamp else None)


def _tag_target(target: str) -> TagName | None:
    """The tag `target` names (``speed``, ``robot1:speed``: `parse_target`), None for a ``/topic``.

    Raises:
        RecordingError: the tag's topic would be too long for ROS 2 (no recording can hold it).
    """
    try:
        tag = parse_target(target)
    except TagError as exc:
        raise RecordingError(f"{target!r} is not a tag: {exc}") from None
    return tag if isinstance(tag, TagName) else None


def _decoder(data: TopicData) -> Callable[[bytes], Any]:
    from mcap.records import Schema
    from mcap_ros2.decoder import DecoderFactory

    schema = Schema(id=1, name=data.msg_type, encoding="ros2msg", data=data.definition.encode())
    decoder = DecoderFactory().decoder_for("cdr", schema)
    if decoder is None:
        raise RecordingError(f"{data.topic}: cannot decode {data.msg_type}")
    return decoder


def _slots(value: Any) -> list[str]:
    """Field names of a message decoded by mcap_ros2 (empty for a plain value)."""
    return [s for s in getattr(value, "__slots__", ()) if not s.startswith("_")]


def _plain(value: Any) -> object:
    if isinstance(value, (list, tuple)):
        return tuple(_plain(v) for v in value)
    if isinstance(value, bytes):
        return tuple(value)
    names = _slots(value)
    if names:
        return {k: _plain(getattr(value, k)) for k in names}
    return value


def _lines(times: list[float], values: list[Any], stamp: bool) -> Iterator[str]:
    for t, v in zip(times, values, strict=True):
        yield format_line(v, t if stamp else None)
