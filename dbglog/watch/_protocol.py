"""The watch protocol: JSON requests, answers, events and announcements, checked at the boundary.

Every message is one JSON object with ``"v": PROTOCOL_VERSION`` in a ``std_msgs/msg/String`` on the
topics of `dbglog._ros._watch.watch_topics`. A watcher addresses each request to one process (``to``: its
agent id) and repeats it until answered; the process answers a repeat from its cache, so every request is
handled (and logged) once. docs/watch.md, *Protocol*, lists the fields.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any, Final

from dbglog._ros._watch import PROTOCOL_VERSION

__all__ = [
    "DEFAULT_MAX_CPU",
    "MAX_EXPRESSIONS",
    "MAX_MESSAGE",
    "OPS",
    "STATES",
    "ArmSpec",
    "ProtocolError",
    "dumps",
    "loads",
]

MAX_MESSAGE: Final = 1 << 20
"""Longest message read, in characters."""
MAX_EXPRESSIONS: Final = 16
"""Most expressions in one watch."""
DEFAULT_MAX_CPU: Final = 0.05
"""A watch that takes more than this share of one CPU (hits and their events over a second) disarms."""
MAX_CPU_LIMIT: Final = 0.5
MIN_CPU_LIMIT: Final = 0.001
OPS: Final = frozenset({"files", "source", "names", "arm", "disarm"})
STATES: Final = frozenset(
    {"armed", "no_file", "no_line", "expr_error", "refused", "cpu", "done", "disarmed", "gone"}
)
"""A watch's state in one process: armed; not armed (no such file, no such line, an expression that is
not allowed, refused); ended (over its CPU share, its count reached, disarmed, the process gone)."""


class ProtocolError(ValueError):
    """A message that does not follow the protocol; the message says what is wrong."""


def dumps(message: dict[str, Any]) -> str:
    """Encode a message (adds the protocol version)."""
    return json.dumps({"v": PROTOCOL_VERSION, **message}, separators=(",", ":"), allow_nan=False)


def loads(text: str) -> dict[str, Any]:
    """Decode a message.

    Raises:
        ProtocolError: not JSON, not an object, too long, or another protocol version.
    """
    if len(text) > MAX_MESSAGE:
        raise ProtocolError(f"a message of {len(text)} characters is longer than {MAX_MESSAGE}")
    try:
        message = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise ProtocolError(f"not JSON: {exc}") from None
    if not isinstance(message, dict):
        raise ProtocolError("a message must be a JSON object")
    if message.get("v") != PROTOCOL_VERSION:
        raise ProtocolError(f"protocol version {message.get('v')!r} is not {PROTOCOL_VERSION}")
    return message


def text_field(message: dict[str, Any], key: str, *, optional: bool = False, limit: int = 4096) -> str | None:
    """Return a string field.

    Raises:
        ProtocolError: missing (unless `optional`), not a string, or longer than `limit`.
    """
    value = message.get(key)
    if value is None and optional:
        return None
    if not isinstance(value, str):
        raise ProtocolError(f"field {key!r} must be a string")
    if len(value) > limit:
        raise ProtocolError(f"field {key!r} is longer than {limit} characters")
    return value


def number_field(
    message: dict[str, Any], key: str, *, optional: bool = False, low: float = 0.0, high: float = math.inf
) -> float | None:
    """Return a finite number field within [low, high].

    Raises:
        ProtocolError: missing (unless `optional`), not a number, or out of range.
    """
    value = message.get(key)
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ProtocolError(f"field {key!r} must be a finite number")
    if not low <= value <= high:
        raise ProtocolError(f"field {key!r} must be between {low:g} and {high:g}")
    return float(value)


@dataclass(frozen=True, slots=True)
class ArmSpec:
    """What an ``arm`` request asks for."""

    file: str
    line: int
    exprs: tuple[str, ...]
    when: str | None = None
    throttle: float | None = None
    """At most one published hit per this many seconds; None: every hit up to 1 kHz; 0: every hit."""
    count: int | None = None
    """Stop after this many published hits."""
    label: str | None = None
    max_cpu: float = DEFAULT_MAX_CPU
    local_path: str | None = None
    """The watcher's absolute path for `file`, when it exists on the watcher's machine."""

    def to_json(self) -> dict[str, Any]:
        """The request fields."""
        return {
            "file": self.file,
            "line": self.line,
            "exprs": list(self.exprs),
            "when": self.when,
            "throttle": self.throttle,
            "count": self.count,
            "label": self.label,
            "max_cpu": self.max_cpu,
            "local_path": self.local_path,
        }

    @classmethod
    def from_json(cls, message: dict[str, Any]) -> ArmSpec:
        """Read and check an arm request's fields.

        Raises:
            ProtocolError: a field is missing, of the wrong type or out of range.
        """
        exprs = message.get("exprs")
        if not isinstance(exprs, list) or not exprs or len(exprs) > MAX_EXPRESSIONS:
            raise ProtocolError(f"field 'exprs' must be a list of 1 to {MAX_EXPRESSIONS} strings")
        if not all(isinstance(e, str) and len(e) <= 1000 for e in exprs):
            raise ProtocolError("field 'exprs' must hold strings (at most 1000 characters each)")
        line = message.get("line")
        if isinstance(line, bool) or not isinstance(line, int) or not 1 <= line <= 10_000_000:
            raise ProtocolError("field 'line' must be a line number (an integer from 1)")
        count = message.get("count")
        if count is not None and (isinstance(count, bool) or not isinstance(count, int) or count < 1):
            raise ProtocolError("field 'count' must be a positive integer")
        max_cpu = number_field(message, "max_cpu", optional=True, low=MIN_CPU_LIMIT, high=MAX_CPU_LIMIT)
        return cls(
            file=str(text_field(message, "file")),
            line=line,
            exprs=tuple(exprs),
            when=text_field(message, "when", optional=True, limit=1000),
            throttle=number_field(message, "throttle", optional=True, high=3600.0),
            count=count,
            label=text_field(message, "label", optional=True, limit=200),
            max_cpu=DEFAULT_MAX_CPU if max_cpu is None else max_cpu,
            local_path=text_field(message, "local_path", optional=True),
        )

    def shared_key(self) -> tuple[object, ...]:
        """What two watchers must agree on to share one watch (and its tags) in a process."""
        return (self.exprs, self.when, self.throttle, self.label)
