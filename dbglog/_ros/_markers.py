"""User markers ("robot bumped here"): the hidden topic they travel and are recorded on, and its payload.

A marker is one ``std_msgs/msg/String`` on ``/_dbglog/markers`` whose text is a small JSON object:
``{"time": 1767225600.25, "note": "robot bumped here", "id": "3f2a…"}``. `time` is the moment the marker
marks (epoch seconds: the viewer's time cursor, which may be in the past), not when it was sent; `id` tells
a marker received twice (its sender's own copy, a re-sent latched history) from a new one. A topic, not
MCAP metadata: a viewer's marker reaches a ``dbglog record`` running in another process (and ``ros2 bag
record``), lands in the viewer's own history and saved recordings like any topic, and replays with no
reader change. Publishers keep every marker (reliable, transient-local): a recorder started later
still gets them. No import of rclpy at module level.
"""

from __future__ import annotations

import json
import math
import uuid
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Final

from dbglog._ros._cdr import read_string, string_payload

if TYPE_CHECKING:
    from rclpy.qos import QoSProfile

__all__ = [
    "MARKER_DEPTH",
    "MARKER_TOPIC",
    "MARKER_TYPE",
    "MAX_NOTE",
    "Marker",
    "decode_marker",
    "encode_marker",
    "marker_qos",
]

MARKER_TOPIC: Final = "/_dbglog/markers"
MARKER_TYPE: Final = "std_msgs/msg/String"
MARKER_DEPTH: Final = 1000
"""Markers a publisher keeps for subscribers that join later (a recorder started after them)."""
MAX_NOTE: Final = 1000
"""Characters of a note that are kept (a marker is a label, not a document)."""


@dataclass(frozen=True, slots=True)
class Marker:
    """A user's marker: a note at a moment.

    Example:
        >>> marker = Marker(1767225600.25, "robot bumped here")
        >>> decode_marker(encode_marker(marker)) == marker
        True
    """

    time: float
    """The moment it marks (epoch seconds, the time axis of every series)."""
    note: str
    id: str = field(default_factory=lambda: uuid.uuid4().hex)

    def __post_init__(self) -> None:
        if not math.isfinite(self.time):
            raise ValueError(f"a marker's time must be a finite number of seconds, not {self.time!r}")
        if len(self.note) > MAX_NOTE:
            object.__setattr__(self, "note", self.note[:MAX_NOTE])


def encode_marker(marker: Marker) -> bytes:
    """Return the CDR bytes of the ``std_msgs/msg/String`` that carries `marker`."""
    text = json.dumps({"time": marker.time, "note": marker.note, "id": marker.id}, ensure_ascii=False)
    return string_payload(text)


def decode_marker(payload: bytes) -> Marker:
    """Read a marker from the CDR bytes of its String message.

    Raises:
        ValueError: the bytes are not a marker (the message says what is wrong).
    """
    raw = read_string(payload)
    if raw is None:
        raise ValueError("not a std_msgs/msg/String")
    try:
        data = json.loads(raw.decode("utf-8", "replace"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"not a marker's JSON: {exc}") from None
    if not isinstance(data, dict):
        raise ValueError("a marker is a JSON object with time, note and id")
    t, note, ident = data.get("time"), data.get("note", ""), data.get("id")
    if not isinstance(t, int | float) or isinstance(t, bool):
        raise ValueError(f"a marker's time must be a number, not {t!r}")
    if not isinstance(note, str):
        raise ValueError(f"a marker's note must be text, not {note!r}")
    if not isinstance(ident, str) or not ident:
        raise ValueError(f"a marker's id must be non-empty text, not {ident!r}")
    return Marker(float(t), note, ident)


def marker_qos() -> QoSProfile:
    """Return the markers' QoS: reliable, transient-local, keep the last `MARKER_DEPTH` (imports rclpy)."""
    from dbglog._ros._qos import subscription_qos

    return subscription_qos(MARKER_DEPTH, reliable=True, transient=True)
