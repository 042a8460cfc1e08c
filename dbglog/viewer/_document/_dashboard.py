"""Dashboard files: the versioned JSON schema, validation with clear messages, atomic saves, legacy import.

A dashboard loads as far as it can: a widget of an unknown type, or a bad field, gives a message naming
the widget and the field while the rest still loads; unknown-type entries are kept verbatim and saved
back unchanged. Only a file that is not a dashboard at all raises `DashboardError`. Files from the
original ROSDashboard (``DragDial`` ... with ``posX``/``posY`` and ``subscription``) open too; saving
always writes the current format. Loading never writes.

Hostile files are bounded here, once: only regular files of at most 16 MiB are read, every string that
reaches the viewer is valid Unicode without NUL or control characters (`text_problem`), nesting is at
most `MAX_DEPTH` levels, and at most `MAX_WIDGETS` widgets load (`LoadResult.left_out` counts the rest).
"""

from __future__ import annotations

import contextlib
import copy
import errno
import json
import math
import os
import re
import shutil
import stat
import threading
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, cast

import numpy as np

from dbglog._regex._compile import RegexError, compile_regex, parse_number
from dbglog._ros._loglevels import LEVELS
from dbglog.viewer._data._model import EVERY_ROBOT, SELECTED_ROBOT, Binding
from dbglog.viewer._values._transforms import Invalid, transforms_or_invalid, written_transforms
from dbglog.viewer.widget_api import PropertyError, PropValue, Widget

__all__ = [
    "FORMAT",
    "LEGACY_TYPES",
    "MAX_DEPTH",
    "MAX_FILE_BYTES",
    "MAX_MESSAGES",
    "MAX_STALE_AFTER",
    "MAX_WIDGETS",
    "VERSION",
    "WATCH_VERSION",
    "Dashboard",
    "DashboardError",
    "LoadResult",
    "RawWidget",
    "WatchConfig",
    "WidgetConfig",
    "check_stale_after",
    "dumps",
    "load_dashboard",
    "parse_dashboard",
    "save_dashboard",
    "text_problem",
]

FORMAT = "dbglog-dashboard"
VERSION = 3
"""The newest version this viewer reads. A file is written as the lowest version that holds it (1 unless a
binding follows the selected robot or every robot: 2, or a widget has a watch: 3), so older viewers still
open every other dashboard."""
ROBOT_VERSION = 2
"""The first version whose bindings may have a ``"robot"`` (``"$selected"``, ``"$every"``)."""
WATCH_VERSION = 3
"""The first version whose widgets may have a ``"watch"`` (a variable of a running program: docs/watch.md)."""
MAX_FILE_BYTES = 16 << 20
"""Largest dashboard file read (16 MiB)."""
MAX_WIDGETS = 1000
"""Most widgets one dashboard loads: the rest are left out, with a message (`LoadResult.left_out`)."""
MAX_DEPTH = 64
"""Deepest nesting of arrays and objects in a file (the top-level object is level 1)."""
MAX_MESSAGES = 500
"""Most load messages kept; one more line says how many were not listed."""
MAX_COORD = 100_000.0
MAX_NAME = 200
MAX_TOPIC = 1000
MAX_FIELD = 1000
MAX_REGEX = 10_000
MAX_WATCH_FILE = 4096
MAX_WATCH_LINE = 10_000_000
MAX_EXPR = 500
"""The longest watch expression (as the watch protocol reads them)."""
MAX_EXPRS = 16
MAX_THROTTLE = 3600.0
MIN_WATCH_CPU, MAX_WATCH_CPU = 0.1, 50.0
"""A watch's CPU share in percent (``dbglog watch --max-cpu``)."""
TEMP_MARK = ".dbglog-tmp-"
"""Temporary files of a save are named ``.NAME.dbglog-tmp-PID`` in the dashboard's folder."""

LEGACY_TYPES: dict[str, str] = {
    "DragDial": "dial",
    "DragKnob": "knob",
    "DragCompass": "compass",
    "DragThermo": "thermo",
    "DragString": "string",
    "DragLed": "led",
    "DragPlot": "plot",
}
"""ROSDashboard widget class names and the widget types they open as."""

_LEGACY_PROPS = {"min": "minimum", "max": "maximum", "minimum": "minimum", "maximum": "maximum"}
_LEGACY_BINDING_PROPS = {"datasource", "datafield", "topic"}

TypeLookup = Callable[[str], type[Widget] | None]


class DashboardError(ValueError):
    """A file that cannot be read as a dashboard at all; the message names the file and the problem."""


@dataclass(frozen=True)
class WatchConfig:
    """A variable of a running Python program that a widget shows: a line of a file and expressions.

    The viewer arms it in every watchable process that has the line (only those with an rclpy node called
    `node`, when given) and binds the widget to the tags it publishes (docs/watch.md, *In the viewer*).
    """

    file: str
    """The file as the process loaded it (an absolute path), or a unique end of its path."""
    line: int
    exprs: tuple[str, ...]
    """The expressions, as written: one that is not allowed shows as the widget's error when armed."""
    node: str = ""
    """Only processes with an rclpy node of this name (``""``: every process that has the line)."""
    when: str = ""
    """Only the hits where this expression is true (``""``: every hit)."""
    throttle: float | None = None
    """At most one hit per this many seconds (None: every hit up to 1 kHz)."""
    max_cpu: float | None = None
    """The share of one CPU, in percent, above which the watch disarms itself (None: the default 5)."""

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON form (optional fields only when set)."""
        out: dict[str, Any] = {"file": self.file, "line": self.line, "exprs": list(self.exprs)}
        if self.node:
            out["node"] = self.node
        if self.when:
            out["when"] = self.when
        if self.throttle is not None:
            out["throttle"] = self.throttle
        if self.max_cpu is not None:
            out["max_cpu"] = self.max_cpu
        return out

    @property
    def title(self) -> str:
        """How messages name it: ``loop.py:24 speed, robot.gain``."""
        return f"{Path(self.file).name}:{self.line} {', '.join(self.exprs)}"


@dataclass(frozen=True)
class WidgetConfig:
    """One widget on the canvas as saved: type, name, place and size, bindings, property values."""

    type: str
    name: str
    x: float
    y: float
    width: float
    height: float
    bindings: tuple[Binding, ...] = ()
    properties: Mapping[str, PropValue] = field(default_factory=dict)
    stale_after: float | None = None
    """Seconds without a message before this widget shows stale; None: the viewer's setting."""
    watch: WatchConfig | None = None
    """The variable of a running program it shows, armed while the dashboard is open (None: none)."""

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON form (current format)."""
        out: dict[str, Any] = {
            "type": self.type,
            "name": self.name,
            "x": self.x,
            "y": self.y,
            "width": self.width,
            "height": self.height,
            "bindings": [_binding_dict(b) for b in self.bindings],
            "properties": dict(self.properties),
        }
        if self.stale_after is not None:
            out["stale_after"] = self.stale_after
        if self.watch is not None:
            out["watch"] = self.watch.to_dict()
        return out

    # The union WidgetConfig | RawWidget answers these alike, so the canvas never asks which it holds.

    @property
    def editable(self) -> WidgetConfig:
        """This entry as a widget the viewer shows and edits (a placeholder answers None)."""
        return self

    def geometry(self) -> tuple[float, float, float, float]:
        """Place and size on the canvas: x, y, width, height."""
        return self.x, self.y, self.width, self.height

    def placed(self, x: float, y: float, width: float, height: float) -> WidgetConfig:
        """The entry moved and resized."""
        return replace(self, x=x, y=y, width=width, height=height)

    def renamed(self, name: str) -> WidgetConfig:
        """The entry with another name."""
        return replace(self, name=name)


def _binding_dict(b: Binding) -> dict[str, Any]:
    out: dict[str, Any] = {"topic": b.topic, "field": b.field, "regex": b.regex}
    if b.robot:  # robot-relative: the topic written relative, as ROS writes a name inside a namespace
        out = {"robot": b.robot, "topic": b.topic.lstrip("/"), "field": b.field, "regex": b.regex}
    if b.transforms:
        # Rejected transforms are kept as the user wrote them (any JSON), valid ones with sorted keys.
        out["transforms"] = written_transforms(b.transforms)
    if b.node:  # a log binding's filters, only when set: other files stay as they were
        out["node"] = b.node
    if b.level:
        out["level"] = b.level
    return out


@dataclass(frozen=True)
class RawWidget:
    """An entry the viewer cannot show (unknown type): kept verbatim so saving gives it back unchanged."""

    data: Mapping[str, Any]
    reason: str

    @property
    def type(self) -> str:
        """The entry's type name, or ``"?"``."""
        value = self.data.get("type")
        return value if isinstance(value, str) else "?"

    @property
    def name(self) -> str:
        """The entry's name, or its type."""
        value = self.data.get("name")
        return value if isinstance(value, str) else self.type

    def geometry(self) -> tuple[float, float, float, float]:
        """Best-effort place and size for a placeholder (either format's keys)."""
        keys = (("x", "posX"), ("y", "posY"), ("width", "width"), ("height", "height"))
        defaults = (20.0, 20.0, 220.0, 120.0)
        out = []
        for (key, legacy), default in zip(keys, defaults, strict=True):
            value = _as_float(self.data.get(key, self.data.get(legacy)))
            out.append(min(MAX_COORD, max(0.0, value)) if value is not None else default)
        return out[0], out[1], max(out[2], 80.0), max(out[3], 60.0)

    @property
    def editable(self) -> None:
        """A placeholder is not a widget the viewer shows or edits."""
        return None

    @property
    def bindings(self) -> tuple[Binding, ...]:
        """A placeholder fills no series."""
        return ()

    @property
    def stale_after(self) -> None:
        """A placeholder has no stale time."""
        return None

    def placed(self, x: float, y: float, width: float, height: float) -> RawWidget:
        """The entry moved and resized (in the keys of its own format), the rest kept verbatim."""
        data = dict(self.data)
        x_key, y_key = ("posX", "posY") if "posX" in data else ("x", "y")
        data.update({x_key: x, y_key: y, "width": width, "height": height})
        return RawWidget(data, self.reason)

    def renamed(self, name: str) -> RawWidget:
        """The entry with another name, the rest kept verbatim."""
        return RawWidget({**self.data, "name": name}, self.reason)

    def to_dict(self) -> dict[str, Any]:
        """Return the entry exactly as it was read."""
        return copy.deepcopy(dict(self.data))


@dataclass
class Dashboard:
    """A whole dashboard: its widgets (in drawing order, last on top) and the grid settings."""

    widgets: list[WidgetConfig | RawWidget] = field(default_factory=list)
    grid_size: int = 20
    snap: bool = True

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON form (current format), as the lowest version that holds it (`needed_version`)."""
        return {
            "format": FORMAT,
            "version": self.needed_version(),
            "grid": {"size": self.grid_size, "snap": self.snap},
            "widgets": [w.to_dict() for w in self.widgets],
        }

    def needed_version(self) -> int:
        """The lowest file version that holds this dashboard: 3 with a watch, 2 when a binding is
        robot-relative (an entry kept verbatim counts too), else 1."""
        version = 1
        for w in self.widgets:
            if isinstance(w, RawWidget):
                if w.data.get("watch") is not None:
                    return WATCH_VERSION
                raw = w.data.get("bindings")
                if isinstance(raw, list) and any(isinstance(b, dict) and "robot" in b for b in raw):
                    version = ROBOT_VERSION
            elif w.watch is not None:
                return WATCH_VERSION
            elif any(b.robot for b in w.bindings):
                version = ROBOT_VERSION
        return version


@dataclass
class LoadResult:
    """A loaded dashboard with the messages about what could not be taken as it was."""

    dashboard: Dashboard
    messages: list[str] = field(default_factory=list)
    legacy: bool = False
    """True when the file was in the original ROSDashboard format."""
    left_out: int = 0
    """Whole widget entries not loaded (more than `MAX_WIDGETS`, nested too deep, unsafe text in an
    entry kept verbatim); saving over the file would lose them."""
    version: int = VERSION
    """The file's format version (a legacy file counts as 1)."""

    @property
    def complete(self) -> bool:
        """True when every widget entry of the file is in `dashboard` (saving over the file loses none)."""
        return self.left_out == 0


def dumps(dashboard: Dashboard) -> str:
    """Serialise a dashboard to JSON text (current format)."""
    return json.dumps(dashboard.to_dict(), indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def load_dashboard(
    path: str | os.PathLike[str], lookup: TypeLookup, *, max_widgets: int = MAX_WIDGETS
) -> LoadResult:
    """Read and validate a dashboard file (never writes to it).

    Args:
        path: the file; only a regular file of at most 16 MiB is read (a FIFO or device is refused).
        lookup: returns the widget class for a type name (None when unknown).
        max_widgets: load at most this many widgets; the rest are counted in `LoadResult.left_out`.

    Raises:
        DashboardError: the file cannot be read, is not JSON, or is not a dashboard; the message
            names the file.
    """
    p = Path(path)
    raw = _read_regular_file(p)
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    try:
        raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DashboardError(f"{p}: not UTF-8 text (byte {exc.start})") from None
    data = _decode_json(raw, p)
    try:
        return parse_dashboard(data, lookup, max_widgets=max_widgets)
    except DashboardError as exc:
        raise DashboardError(f"{p}: {exc}") from None


_FILE_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def _not_regular(p: Path, mode: int) -> DashboardError:
    if stat.S_ISDIR(mode):
        return DashboardError(f"{p}: is a directory, not a dashboard file")
    kind = next((name for test, name in _FILE_KINDS if test(mode)), "not a regular file")
    return DashboardError(f"{p}: is {kind}, not a regular file; a dashboard must be a regular file")


def _read_regular_file(p: Path) -> bytes:
    """Return the bytes of a regular file of at most `MAX_FILE_BYTES`; never blocks on a FIFO or device."""
    too_large = f"{p}: file is too large (more than {MAX_FILE_BYTES} bytes; a dashboard is at most 16 MiB)"
    try:
        # Look before opening: opening some devices has effects; O_NONBLOCK covers a swap in between.
        if not stat.S_ISREG(mode := os.stat(p).st_mode):
            raise _not_regular(p, mode)
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
        try:
            st = os.fstat(fd)
            if not stat.S_ISREG(st.st_mode):
                raise _not_regular(p, st.st_mode)
            if st.st_size > MAX_FILE_BYTES:
                raise DashboardError(
                    f"{p}: file is too large ({st.st_size} bytes; a dashboard is at most 16 MiB)"
                )
            chunks: list[bytes] = []
            size = 0
            while chunk := os.read(fd, min(1 << 20, MAX_FILE_BYTES + 1 - size)):
                chunks.append(chunk)
                size += len(chunk)
                if size > MAX_FILE_BYTES:
                    raise DashboardError(too_large)  # it grew while being read
        finally:
            os.close(fd)
    except DashboardError:
        raise
    except FileNotFoundError:
        raise DashboardError(f"{p}: no such file") from None
    except NotADirectoryError:
        raise DashboardError(f"{p}: no such file (a folder on the way is a file)") from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise DashboardError(f"{p}: cannot read: too many levels of symbolic links") from None
        raise DashboardError(f"{p}: cannot read: {exc.strerror or exc}") from None
    return b"".join(chunks)


def _decode_json(raw: bytes, p: Path) -> Any:
    """Parse JSON text; if too deep for Python's reader, cut what lies past `MAX_DEPTH` + 1 levels first."""
    try:
        return _json_loads(raw)
    except RecursionError:
        pass  # nested deeper than Python's JSON reader goes: cut, then parse what is left
    except json.JSONDecodeError as exc:
        raise DashboardError(
            f"{p}: not valid JSON: {exc.msg} at line {exc.lineno} column {exc.colno}"
        ) from None
    except ValueError as exc:
        if "integer string conversion" in str(exc):  # Python's int_max_str_digits guard
            raise DashboardError(f"{p}: not valid JSON: a number has more than 4300 digits") from None
        raise DashboardError(f"{p}: not valid JSON: {_cut(str(exc))}") from None
    clipped = _clip_depth(raw, MAX_DEPTH + 1)
    if clipped is None:
        raise DashboardError(f"{p}: not valid JSON: nested deeper than {MAX_DEPTH} levels, unbalanced")
    try:
        return _json_loads(clipped)
    except (ValueError, RecursionError) as exc:
        raise DashboardError(f"{p}: not valid JSON: {exc}") from None


def _json_loads(raw: bytes) -> Any:
    return json.loads(raw.decode("utf-8"), parse_constant=_reject_constant, parse_float=_finite_float)


def _clip_depth(raw: bytes, keep: int) -> bytes | None:
    """Replace every array or object deeper than `keep` levels by ``null`` (None: brackets unbalanced).

    Linear (vectorised over the bytes): the loader then sees level ``keep`` and reports the entry
    holding it as too deep, however deep the file went.
    """
    b = np.frombuffer(raw, dtype=np.uint8)
    quote = b == ord('"')
    backslash = b == ord("\\")
    if backslash.any():
        # A quote is escaped when an odd run of backslashes precedes it.
        idx = np.arange(b.size, dtype=np.int32)  # at most 16 MiB: int32 is enough
        last_other = np.maximum.accumulate(np.where(backslash, np.int32(-1), idx))
        run = np.zeros(b.size, dtype=np.int32)
        run[1:] = idx[:-1] - last_other[:-1]
        quote &= run % 2 == 0
    in_string = (np.cumsum(quote, dtype=np.int32) & 1).astype(bool)
    opens = ((b == ord("[")) | (b == ord("{"))) & ~in_string
    closes = ((b == ord("]")) | (b == ord("}"))) & ~in_string
    depth = np.cumsum(opens.astype(np.int32) - closes.astype(np.int32), dtype=np.int32)
    starts = np.flatnonzero(opens & (depth == keep + 1))
    ends = np.flatnonzero(closes & (depth == keep))
    if starts.size != ends.size or not (
        np.all(starts < ends) and np.all(ends[:-1] < starts[1:]) if starts.size else True
    ):
        return None
    out: list[bytes] = []
    pos = 0
    for start, stop in zip(starts.tolist(), ends.tolist(), strict=True):
        out += (raw[pos:start], b"null")
        pos = stop + 1
    out.append(raw[pos:])
    return b"".join(out)


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"number {text[:30]} is out of range")
    return value


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not allowed in a dashboard file")


def parse_dashboard(data: object, lookup: TypeLookup, *, max_widgets: int = MAX_WIDGETS) -> LoadResult:
    """Validate decoded JSON as a dashboard (current or legacy format).

    Args:
        data: the decoded JSON.
        lookup: returns the widget class for a type name (None when unknown).
        max_widgets: load at most this many widgets; the rest are counted in `LoadResult.left_out`.

    Raises:
        DashboardError: `data` is not a dashboard at all (not an object, no widget list, a newer version).
    """
    if not isinstance(data, dict):
        raise DashboardError(f"expected a JSON object at the top, got {_kind(data)}")
    widgets = data.get("widgets")
    if "format" not in data:
        if not isinstance(widgets, list):
            raise DashboardError("not a dashboard: no 'format' key and no 'widgets' list")
        result = LoadResult(Dashboard(), legacy=True, version=1)
        result.dashboard.snap = False
        _parse_entries(widgets, lookup, result, max_widgets, _parse_legacy_widget)
        return _finish(result)
    if data["format"] != FORMAT:
        fmt = data["format"]
        shown = _q(fmt) if isinstance(fmt, str) else _short(fmt)
        raise DashboardError(f"'format' is {shown}, expected {FORMAT!r}")
    version = data.get("version")
    if isinstance(version, bool) or not isinstance(version, int):
        raise DashboardError(f"'version' must be an integer, got {_kind(version)}")
    if version > VERSION:
        raise DashboardError(
            f"version {_short(version)} is newer than this viewer understands (up to {VERSION})"
        )
    if version < 1:
        raise DashboardError(f"version {_short(version)} is not a valid version")
    if not isinstance(widgets, list):
        raise DashboardError(f"'widgets' must be a list, got {_kind(widgets)}")
    result = LoadResult(Dashboard(), version=version)
    _parse_grid(data.get("grid"), result)
    for key in data:
        if key not in {"format", "version", "grid", "widgets"}:
            result.messages.append(f"top level: unknown key {_q(key)} ignored")
    _parse_entries(widgets, lookup, result, max_widgets, _parse_widget)
    return _finish(result)


def _parse_entries(
    widgets: list[Any],
    lookup: TypeLookup,
    result: LoadResult,
    max_widgets: int,
    parse: Callable[[int, object, TypeLookup, LoadResult], None],
) -> None:
    for index, entry in enumerate(widgets[:max_widgets]):
        parse(index, entry, lookup, result)
    extra = len(widgets) - max_widgets
    if extra > 0:
        result.left_out += extra
        result.messages.insert(
            0,
            f"the file holds {len(widgets)} widgets, more than the {max_widgets} a dashboard can show: "
            f"widgets #{max_widgets + 1} to #{len(widgets)} are left out (saving over this file would "
            "lose them, so Save asks for a new name)",
        )


def _finish(result: LoadResult) -> LoadResult:
    msgs = result.messages
    if len(msgs) > MAX_MESSAGES:
        hidden = len(msgs) - (MAX_MESSAGES - 1)
        del msgs[MAX_MESSAGES - 1 :]
        msgs.append(f"... and {hidden} more problems not listed")
    return result


def _parse_grid(grid: object, result: LoadResult) -> None:
    if grid is None:
        return
    if not isinstance(grid, dict):
        result.messages.append(f"grid: expected an object, got {_kind(grid)}; defaults used")
        return
    size = grid.get("size", 20)
    if isinstance(size, int) and not isinstance(size, bool) and 2 <= size <= 400:
        result.dashboard.grid_size = size
    else:
        result.messages.append(f"grid: field 'size' must be a whole number 2..400, got {_short(size)}")
    snap = grid.get("snap", True)
    if isinstance(snap, bool):
        result.dashboard.snap = snap
    else:
        result.messages.append(f"grid: field 'snap' must be true or false, got {_short(snap)}")


# -- text and nesting ------------------------------------------------------------------------------------

_UNSAFE_TEXT = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f\ud800-\udfff]")
_UNSAFE_LINE = re.compile("[\x00-\x1f\x7f-\x9f\ud800-\udfff]")


def text_problem(text: str, *, line: bool = True) -> str | None:
    """Return why `text` cannot be handed to Dear PyGui or ROS, or None when it is fine.

    Refused: lone surrogates (not valid Unicode, so not UTF-8 encodable), NUL, and the C0/C1 control
    characters and DEL; tab, line feed and carriage return are allowed unless `line` (names, topics,
    field paths are single-line). Right-to-left text, combining marks and other valid Unicode are fine.
    """
    found = (_UNSAFE_LINE if line else _UNSAFE_TEXT).search(text)
    if found is None:
        return None
    code = ord(found.group())
    if 0xD800 <= code <= 0xDFFF:
        what = f"a lone surrogate U+{code:04X} (not valid Unicode)"
    elif code == 0:
        what = "a NUL character"
    else:
        what = f"the control character U+{code:04X}"
    return f"contains {what} at character {found.start() + 1}"


def _entry_problem(entry: object, base: int, *, strings: bool) -> str | None:
    """Say what makes an entry unfit to load: nesting past `MAX_DEPTH` or (``strings``) unsafe text.

    `base` is the entry's own level in the file. Iterative, so any depth is safe; linear in the entry.
    """
    stack: list[tuple[object, int, str]] = [(entry, base, "")]
    while stack:
        value, level, path = stack.pop()
        if level > MAX_DEPTH:
            shown = _cut(path, 40) if path else "the entry"
            return f"field '{shown}' is nested deeper than {MAX_DEPTH} levels (arrays and objects)"
        pairs: Iterable[tuple[object, object]]
        if isinstance(value, dict):
            pairs = value.items()
        elif isinstance(value, list):
            pairs = enumerate(value)
        else:
            continue
        for key, item in pairs:
            if strings and isinstance(key, str) and (problem := text_problem(key, line=False)):
                return f"key {_q(key)}{f' in field {_cut(path, 40)!r}' if path else ''} {problem}"
            if isinstance(item, str):
                if strings and (problem := text_problem(item, line=False)):
                    return f"field '{_cut(_sub(path, key), 40)}' {problem}"
            elif isinstance(item, dict | list):
                stack.append((item, level + 1, _sub(path, key)))
    return None


def _sub(path: str, key: object) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    name = key if isinstance(key, str) and len(key) <= 40 and text_problem(key) is None else "..."
    return f"{path}.{name}" if path else name


def _where(index: int, entry: Mapping[str, Any]) -> str:
    name = entry.get("name")
    return f"widget #{index + 1} {_q(name)}" if isinstance(name, str) and name else f"widget #{index + 1}"


def _leave_out(where: str, problem: str, result: LoadResult) -> None:
    result.left_out += 1
    result.messages.append(
        f"{where}: {problem}; left out (saving over this file would lose it, so Save asks for a new name)"
    )


def _keep_raw(where: str, entry: dict[str, Any], reason: str, result: LoadResult, note: str) -> None:
    """Keep an entry the viewer cannot show verbatim, unless its text could not be shown or saved."""
    problem = _entry_problem(entry, 3, strings=True)
    for key in ("type", "name"):  # the placeholder's title: one line
        value = entry.get(key)
        if problem is None and isinstance(value, str) and (line := text_problem(value)) is not None:
            problem = f"field '{key}' {line}"
    if problem is not None:
        _leave_out(where, f"{reason}, and {problem}", result)
        return
    result.messages.append(f"{where}: {reason}; {note}")
    result.dashboard.widgets.append(RawWidget(copy.deepcopy(entry), reason))


# -- widgets ---------------------------------------------------------------------------------------------


def _parse_widget(index: int, entry: object, lookup: TypeLookup, result: LoadResult) -> None:
    if not isinstance(entry, dict):
        result.messages.append(f"widget #{index + 1}: expected an object, got {_kind(entry)}; skipped")
        return
    where = _where(index, entry)
    if (problem := _entry_problem(entry, 3, strings=False)) is not None:
        _leave_out(where, problem, result)
        return
    type_name = entry.get("type")
    if not isinstance(type_name, str) or not type_name:
        reason = f"field 'type' must be a widget type name, got {_short(type_name)}"
        _keep_raw(where, entry, reason, result, "kept as is")
        return
    cls = lookup(type_name)
    if cls is None:
        reason = f"unknown widget type {_q(type_name)} (not installed?)"
        _keep_raw(where, entry, reason, result, "kept as is and saved back unchanged")
        return
    _parse_known(where, entry, type_name, cls, result)


def _parse_known(
    where: str, entry: dict[str, Any], type_name: str, cls: type[Widget], result: LoadResult
) -> None:
    msgs = result.messages
    name_value = entry.get("name")
    name = name_value if isinstance(name_value, str) and name_value else cls.label
    if not (isinstance(name_value, str) and name_value):
        msgs.append(
            f"{where}: field 'name' must be a non-empty string, got {_short(name_value)}; using {name!r}"
        )
    elif problem := text_problem(name):
        msgs.append(f"{where}: field 'name' {problem}; using {cls.label!r}")
        name = cls.label
    elif len(name) > MAX_NAME:
        msgs.append(f"{where}: field 'name' is longer than {MAX_NAME} characters; cut")
        name = name[:MAX_NAME]
    dw, dh = cls.default_size
    mw, mh = cls.min_size
    x = _coord(entry, "x", 0.0, 0.0, where, msgs)
    y = _coord(entry, "y", 0.0, 0.0, where, msgs)
    width = _coord(entry, "width", float(dw), float(mw), where, msgs)
    height = _coord(entry, "height", float(dh), float(mh), where, msgs)
    robots = result.version >= ROBOT_VERSION
    bindings = _parse_bindings(entry.get("bindings", []), cls, where, msgs, robots=robots)
    props = _parse_properties(entry.get("properties", {}), cls, where, msgs)
    stale_after = _stale_after(entry, where, msgs)
    watches = result.version >= WATCH_VERSION
    watch = _parse_watch(entry["watch"], where, msgs) if watches and entry.get("watch") is not None else None
    for key in entry:
        if key not in _WIDGET_KEYS and (key != "watch" or not watches):
            msgs.append(f"{where}: unknown field {_q(key)} ignored")
    result.dashboard.widgets.append(
        WidgetConfig(type_name, name, x, y, width, height, bindings, props, stale_after, watch)
    )


_WIDGET_KEYS = frozenset(
    {"type", "name", "x", "y", "width", "height", "bindings", "properties", "stale_after"}
)
MAX_STALE_AFTER = 86_400.0
"""A widget's own stale time is at most a day."""


def check_stale_after(value: object) -> float:
    """Return a valid per-widget stale time in seconds or raise ValueError saying what is wrong."""
    number = _as_float(value)
    if number is None:
        raise ValueError(f"must be a number of seconds, got {_short(value)}")
    if not 0 < number <= MAX_STALE_AFTER:
        raise ValueError(f"must be more than 0 and at most {MAX_STALE_AFTER:g} seconds, got {number:g}")
    return number


def _stale_after(entry: Mapping[str, Any], where: str, msgs: list[str]) -> float | None:
    if "stale_after" not in entry or entry["stale_after"] is None:
        return None
    try:
        return check_stale_after(entry["stale_after"])
    except ValueError as exc:
        msgs.append(f"{where}: field 'stale_after' {exc}; using the viewer's stale time")
        return None


_WATCH_KEYS = frozenset({"file", "line", "exprs", "node", "when", "throttle", "max_cpu"})


def _parse_watch(raw: object, where: str, msgs: list[str]) -> WatchConfig | None:
    """A widget's ``"watch"`` (version 3 on). A field of the wrong kind leaves the watch out with a message
    (the widget keeps its bindings); an expression the watch language refuses is kept as written and shows
    as the widget's error once armed, as a regex that does not compile does."""
    at = f"{where}: field 'watch'"
    if not isinstance(raw, dict):
        msgs.append(f"{at} must be an object, got {_kind(raw)}; the watch is left out")
        return None
    problems: list[str] = []
    file = raw.get("file")
    if not isinstance(file, str) or not file.strip():
        problems.append(f"'watch.file' must be a file name, got {_short(file)}")
    elif problem := text_problem(file):
        problems.append(f"'watch.file' {problem}")
    elif len(file) > MAX_WATCH_FILE:
        problems.append(f"'watch.file' is longer than {MAX_WATCH_FILE} characters")
    line = raw.get("line")
    if isinstance(line, bool) or not isinstance(line, int) or not 1 <= line <= MAX_WATCH_LINE:
        problems.append(f"'watch.line' must be a whole number 1..{MAX_WATCH_LINE}, got {_short(line)}")
    exprs = raw.get("exprs")
    if not isinstance(exprs, list) or not 1 <= len(exprs) <= MAX_EXPRS:
        problems.append(f"'watch.exprs' must be a list of 1 to {MAX_EXPRS} expressions, got {_short(exprs)}")
    else:
        for i, expr in enumerate(exprs):
            if not isinstance(expr, str) or not expr.strip():
                problems.append(f"'watch.exprs[{i}]' must be an expression, got {_short(expr)}")
            elif problem := text_problem(expr):
                problems.append(f"'watch.exprs[{i}]' {problem}")
            elif len(expr) > MAX_EXPR:
                problems.append(f"'watch.exprs[{i}]' is longer than {MAX_EXPR} characters")
    texts: dict[str, str] = {}
    for key in ("node", "when"):
        value = raw.get(key)
        if value is None:
            value = ""
        if not isinstance(value, str):
            problems.append(f"'watch.{key}' must be a string, got {_short(value)}")
        elif problem := text_problem(value):
            problems.append(f"'watch.{key}' {problem}")
        elif len(value) > MAX_EXPR:
            problems.append(f"'watch.{key}' is longer than {MAX_EXPR} characters")
        else:
            texts[key] = value.strip()
    throttle = raw.get("throttle")
    seconds = None if throttle is None else _as_float(throttle)
    if throttle is not None and (seconds is None or not 0 <= seconds <= MAX_THROTTLE):
        problems.append(f"'watch.throttle' must be 0..{MAX_THROTTLE:g} seconds, got {_short(throttle)}")
    max_cpu = raw.get("max_cpu")
    percent = None if max_cpu is None else _as_float(max_cpu)
    if max_cpu is not None and (percent is None or not MIN_WATCH_CPU <= percent <= MAX_WATCH_CPU):
        problems.append(
            f"'watch.max_cpu' must be {MIN_WATCH_CPU:g}..{MAX_WATCH_CPU:g} percent, got {_short(max_cpu)}"
        )
    if problems:
        msgs.append(f"{where}: field {'; '.join(problems)}; the watch is left out")
        return None
    for key in raw:
        if key not in _WATCH_KEYS:
            msgs.append(f"{at}: unknown field {_q(key)} ignored")
    return WatchConfig(
        cast(str, file).strip(),
        cast(int, line),
        tuple(str(e).strip() for e in cast(list[str], exprs)),
        node=texts.get("node", ""),
        when=texts.get("when", ""),
        throttle=seconds,
        max_cpu=percent,
    )


def _coord(
    entry: Mapping[str, Any], key: str, default: float, low: float, where: str, msgs: list[str]
) -> float:
    if key not in entry:
        msgs.append(f"{where}: field {key!r} is missing; using {default:g}")
        return default
    value = _as_float(entry[key])
    if value is None:
        msgs.append(f"{where}: field {key!r} must be a number, got {_short(entry[key])}; using {default:g}")
        return default
    if not low <= value <= MAX_COORD:
        fixed = min(MAX_COORD, max(low, value))
        msgs.append(f"{where}: field {key!r} = {value:g} is outside {low:g}..{MAX_COORD:g}; using {fixed:g}")
        return fixed
    return value


def _parse_bindings(
    raw: object, cls: type[Widget], where: str, msgs: list[str], *, robots: bool = False
) -> tuple[Binding, ...]:
    """A widget's bindings; with `robots` (version 2 on), a binding's ``"robot"`` is read too."""
    if not isinstance(raw, list):
        msgs.append(f"{where}: field 'bindings' must be a list, got {_kind(raw)}; widget left unbound")
        return ()
    out: list[Binding] = []
    for i, item in enumerate(raw):
        at = f"{where}: bindings[{i}]"
        if len(out) >= cls.max_bindings:
            msgs.append(f"{at}: a {cls.type_name} shows at most {cls.max_bindings} series; extra dropped")
            break
        if not isinstance(item, dict):
            msgs.append(f"{at}: expected an object, got {_kind(item)}; dropped")
            continue
        binding = _binding(item.get("topic"), item.get("field", ""), item.get("regex", ""), at, msgs)
        if binding is not None and item.get("transforms") is not None:
            binding = _with_transforms(binding, item["transforms"], at, msgs)
        if binding is not None and ("node" in item or "level" in item):
            binding = _with_log_filter(binding, item.get("node"), item.get("level"), at, msgs)
        if binding is not None and robots and "robot" in item:
            binding = _with_robot(binding, item["robot"], cls, at, msgs)
        if binding is not None:
            out.append(binding)
        for key in item:
            if key not in {"topic", "field", "regex", "transforms", "node", "level"} and (
                key != "robot" or not robots
            ):
                msgs.append(f"{at}: unknown field {_q(key)} ignored")
    return tuple(out)


def _with_robot(binding: Binding, robot: object, cls: type[Widget], at: str, msgs: list[str]) -> Binding:
    """A binding's ``"robot"``: the selected robot's namespace or every robot's, its topic relative to it.

    Anything else leaves the topic as written (in the root namespace), with a message; a widget of one
    series (or a control, which publishes to one topic) follows the selected robot instead of every robot.
    """
    if robot is None or robot == "":
        return binding
    if robot not in (SELECTED_ROBOT, EVERY_ROBOT):
        msgs.append(
            f"{at}: field 'robot' must be {SELECTED_ROBOT!r} or {EVERY_ROBOT!r}, got {_short(robot)}; "
            f"the topic {binding.topic!r} is used as written"
        )
        return binding
    if robot == EVERY_ROBOT and (cls.max_bindings < 2 or cls.publishes):
        what = "publishes to one topic" if cls.publishes else "shows one series"
        msgs.append(f"{at}: a {cls.type_name} {what}: it follows the selected robot instead of every robot")
        robot = SELECTED_ROBOT
    return replace(binding, robot=str(robot))


LOG_LEVELS = tuple(LEVELS)
"""The minimum levels a log binding may ask for (``"level"``), as in bridge rules."""


def _with_log_filter(binding: Binding, node: object, level: object, at: str, msgs: list[str]) -> Binding:
    """A log binding's node (exact or glob) and minimum level; a bad one is dropped with a message."""
    if node is None:
        node = ""
    if not isinstance(node, str):
        msgs.append(f"{at}: field 'node' must be a logger name, got {_short(node)}; every node is used")
        node = ""
    elif problem := text_problem(node):
        msgs.append(f"{at}: field 'node' {problem}; every node is used")
        node = ""
    elif len(node) > MAX_TOPIC:
        msgs.append(f"{at}: field 'node' is longer than {MAX_TOPIC} characters; every node is used")
        node = ""
    if level is None:
        level = ""
    if not isinstance(level, str) or level.strip().lower() not in ("", *LOG_LEVELS):
        names = ", ".join(LOG_LEVELS)
        msgs.append(f"{at}: field 'level' must be one of {names}, got {_short(level)}; every level is used")
        level = ""
    return replace(binding, node=node.strip(), level=level.strip().lower())


def _with_transforms(binding: Binding, raw: object, at: str, msgs: list[str]) -> Binding | None:
    """Checked here, before anything is evaluated. A rejected list is kept as written (the widget shows
    the error and saving gives it back); text that cannot be shown or saved drops the binding."""
    problem = _entry_problem([raw], 1, strings=True)
    if problem is not None:
        inner = problem.replace("field '[0]", "field 'transforms", 1)
        msgs.append(f"{at}: {inner}; binding dropped (it cannot be shown or saved)")
        return None
    transforms = transforms_or_invalid(raw)
    rejected = next((t for t in transforms if isinstance(t, Invalid)), None)
    if rejected is not None:
        problem = _cut(f"{at}: {rejected.reason}")
        msgs.append(f"{problem}; kept as written, the widget shows this error until it is fixed")
    return replace(binding, transforms=transforms)


def _binding(topic: object, fld: object, regex: object, at: str, msgs: list[str]) -> Binding | None:
    if not isinstance(topic, str) or not topic.strip():
        msgs.append(f"{at}: field 'topic' must be a topic name, got {_short(topic)}; dropped")
        return None
    if problem := text_problem(topic):
        msgs.append(f"{at}: field 'topic' {problem}; dropped")
        return None
    if len(topic) > MAX_TOPIC:
        msgs.append(f"{at}: field 'topic' is longer than {MAX_TOPIC} characters; dropped")
        return None
    topic = topic.strip()
    if not topic.startswith("/"):
        topic = "/" + topic
    if fld is None:
        fld = ""
    if not isinstance(fld, str):
        msgs.append(f"{at}: field 'field' must be a string, got {_short(fld)}; using the whole message")
        fld = ""
    elif problem := text_problem(fld):
        msgs.append(f"{at}: field 'field' {problem}; using the whole message")
        fld = ""
    elif len(fld) > MAX_FIELD:
        msgs.append(f"{at}: field 'field' is longer than {MAX_FIELD} characters; using the whole message")
        fld = ""
    if regex is None:
        regex = ""
    if not isinstance(regex, str):
        msgs.append(f"{at}: field 'regex' must be a string, got {_short(regex)}; no regex used")
        regex = ""
    elif problem := text_problem(regex, line=False):
        msgs.append(f"{at}: field 'regex' {problem}; no regex used")
        regex = ""
    elif len(regex) > MAX_REGEX:
        msgs.append(f"{at}: field 'regex' is longer than {MAX_REGEX} characters; no regex used")
        regex = ""
    if regex:
        try:
            compile_regex(regex)
        except RegexError as exc:
            # Kept as written: the widget shows the error until it is fixed, and saving gives it back.
            msgs.append(
                f"{at}: field 'regex' {_q(regex)} does not compile ({_cut(str(exc))}); kept as written, "
                "the widget shows this error until it is fixed"
            )
    return Binding(topic, fld.strip(), regex)


def _parse_properties(raw: object, cls: type[Widget], where: str, msgs: list[str]) -> dict[str, PropValue]:
    props = cls.default_properties()
    if not isinstance(raw, dict):
        msgs.append(f"{where}: field 'properties' must be an object, got {_kind(raw)}; defaults used")
        return props
    for key, value in raw.items():
        decl = cls.property_named(key)
        if decl is None:
            msgs.append(f"{where}: unknown property {_q(key)} for a {cls.type_name}; ignored")
            continue
        if isinstance(value, str) and (problem := text_problem(value, line=False)):
            msgs.append(f"{where}: property {key!r} {problem}; using the default {decl.default!r}")
            continue
        if isinstance(value, int) and not isinstance(value, bool) and _as_float(value) is None:
            msgs.append(
                f"{where}: property {key!r}: number {_short(value)} is out of range; using the default"
            )
            continue
        try:
            props[key] = decl.validate(value)
        except PropertyError as exc:
            msgs.append(f"{where}: {_cut(str(exc))}; using the default {decl.default!r}")
    return props


def _parse_legacy_widget(index: int, entry: object, lookup: TypeLookup, result: LoadResult) -> None:
    """Translate one entry of the original ROSDashboard format, then validate it as a current entry."""
    if not isinstance(entry, dict):
        result.messages.append(f"widget #{index + 1}: expected an object, got {_kind(entry)}; skipped")
        return
    where = _where(index, entry)
    if (problem := _entry_problem(entry, 3, strings=False)) is not None:
        _leave_out(where, problem, result)
        return
    legacy_type = entry.get("type")
    new_type = LEGACY_TYPES.get(legacy_type) if isinstance(legacy_type, str) else None
    cls = lookup(new_type) if new_type is not None else None
    if new_type is None or cls is None:
        reason = f"unknown ROSDashboard widget type {_short(legacy_type)}"
        _keep_raw(where, entry, reason, result, "kept as is and saved back unchanged")
        return
    converted: dict[str, Any] = {"type": new_type, "name": entry.get("name", legacy_type)}
    for old, new in (("posX", "x"), ("posY", "y"), ("width", "width"), ("height", "height")):
        if old in entry:
            converted[new] = entry[old]
    # ROSDashboard drew its widgets at a fixed size whatever the file said: grow small ones quietly.
    for key, low in (("width", cls.min_size[0]), ("height", cls.min_size[1])):
        value = converted.get(key)
        if isinstance(value, int | float) and not isinstance(value, bool) and 0 <= value < low:
            converted[key] = float(low)
    props, extra_binding = _legacy_properties(entry.get("properties"), where, result.messages)
    converted["properties"] = props
    converted["bindings"] = _legacy_bindings(entry.get("subscription"), extra_binding, where, result.messages)
    _parse_known(where, converted, new_type, cls, result)


def _legacy_properties(raw: object, where: str, msgs: list[str]) -> tuple[dict[str, Any], dict[str, Any]]:
    props: dict[str, Any] = {}
    binding: dict[str, Any] = {}
    if raw is None:
        return props, binding
    if not isinstance(raw, list):
        msgs.append(f"{where}: field 'properties' must be a list, got {_kind(raw)}; defaults used")
        return props, binding
    for i, item in enumerate(raw):
        at = f"{where}: properties[{i}]"
        if not isinstance(item, dict) or not isinstance(item.get("name"), str):
            msgs.append(f"{at}: expected an object with a 'name'; ignored")
            continue
        name, kind, value = item["name"], item.get("type"), item.get("value")
        if name in _LEGACY_BINDING_PROPS:
            binding["field" if name == "datafield" else "topic"] = value
            continue
        if kind == "numeric" and isinstance(value, str):
            text = value
            try:
                value = parse_number(text)
            except ValueError:
                msgs.append(f"{at}: {_q(name)} value {_q(text)} is not a number; ignored")
                continue
        props[_LEGACY_PROPS.get(name) or name] = value
    return props, binding


def _legacy_bindings(
    sub: object, fallback: dict[str, Any], where: str, msgs: list[str]
) -> list[dict[str, Any]]:
    if sub is None:
        sub = fallback or None
    if sub is None:
        return []
    if not isinstance(sub, dict):
        msgs.append(f"{where}: field 'subscription' must be an object, got {_kind(sub)}; widget left unbound")
        return []
    regex = sub.get("regex")
    if regex in (None, ".*", "^.*$", "(.*)"):
        regex = ""
    return [{"topic": sub.get("topic"), "field": sub.get("datafield", sub.get("field", "")), "regex": regex}]


def save_dashboard(dashboard: Dashboard, path: str | os.PathLike[str]) -> None:
    """Write `dashboard` atomically: a temp file in the same folder, fsync, keep a ``.bak``, then rename.

    A symbolic link is written through (its target is replaced, the link stays). The file keeps the
    previous file's permission bits; a new file gets the user's umask. Temporary files are named
    ``.NAME.dbglog-tmp-PID``; those left by a save that was killed are removed by the next save.
    A failure at any step leaves the previous file as it was.

    Raises:
        DashboardError: the file cannot be written; the message names the file and the reason.
    """
    given = Path(path)
    try:
        data = dumps(dashboard).encode("utf-8")
    except (TypeError, ValueError) as exc:  # UnicodeEncodeError is a ValueError
        raise DashboardError(f"{given}: cannot serialise the dashboard: {_cut(str(exc))}") from None
    target = Path(os.path.realpath(given))
    folder = target.parent
    with _SAVE_LOCK:  # one save at a time per process: a temp file with our pid is then a stale one
        _save_bytes(data, given, target, folder)


_SAVE_LOCK = threading.Lock()


def _save_bytes(data: bytes, given: Path, target: Path, folder: Path) -> None:
    tmp: Path | None = None
    try:
        _remove_stale_temps(folder, (target.name, target.name + ".bak"))
        try:
            mode = os.stat(target).st_mode
        except FileNotFoundError:
            previous = None
        else:
            if stat.S_ISDIR(mode):
                raise IsADirectoryError(errno.EISDIR, "is a directory", str(given))
            if not stat.S_ISREG(mode):  # never open a FIFO or a device to back it up
                kind = next((name for test, name in _FILE_KINDS if test(mode)), "not a regular file")
                raise DashboardError(f"{given}: cannot save: it is {kind}, not a regular file")
            previous = stat.S_IMODE(mode)
        tmp = _write_temp(folder, target.name, data, previous)
        if previous is not None:
            bak = target.with_name(target.name + ".bak")
            bak_tmp = _write_temp(folder, bak.name, target, previous)
            try:
                os.replace(bak_tmp, bak)
            finally:
                with contextlib.suppress(OSError):
                    os.unlink(bak_tmp)  # already gone after a successful replace
        os.replace(tmp, target)
        tmp = None
        _fsync_folder(folder)
    except OSError as exc:
        raise DashboardError(f"{given}: cannot save: {exc.strerror or exc}") from None
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def _temp_path(folder: Path, name: str, pid: int) -> Path:
    return folder / f".{name}{TEMP_MARK}{pid}"


def _write_temp(folder: Path, name: str, data: bytes | Path, mode: int | None) -> Path:
    """Write `data` (or a copy of that file) to a new ``.NAME.dbglog-tmp-PID`` file, synced.

    `mode` None: the umask's default.
    """
    tmp = _temp_path(folder, name, os.getpid())
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC | os.O_NOFOLLOW
    try:
        fd = os.open(tmp, flags, 0o666)  # the kernel applies the umask
    except FileExistsError:  # left by a killed process that had our pid
        os.unlink(tmp)
        fd = os.open(tmp, flags, 0o666)
    try:
        if isinstance(data, Path):
            with open(data, "rb") as src, open(fd, "wb", closefd=False) as dst:
                shutil.copyfileobj(src, dst)
        else:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view) :]
        if mode is not None:
            os.fchmod(fd, mode)
        os.fsync(fd)
    except BaseException:
        os.close(fd)
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    os.close(fd)
    return tmp


_TEMP_RE = re.compile(r"\.(?P<name>.+)" + re.escape(TEMP_MARK) + r"(?P<pid>[0-9]{1,10})")


def _remove_stale_temps(folder: Path, names: tuple[str, ...]) -> None:
    """Delete this file's temporary files whose saving process is gone (a save killed half-way)."""
    try:
        entries = os.listdir(folder)
    except OSError:
        return
    for entry in entries:
        found = _TEMP_RE.fullmatch(entry)
        if found is None or found["name"] not in names:
            continue
        pid = int(found["pid"])
        if pid != os.getpid() and not _alive(pid):
            with contextlib.suppress(OSError):
                os.unlink(folder / entry)


def _alive(pid: int) -> bool:
    if not 0 < pid < 1 << 22:
        return False
    try:
        os.kill(pid, 0)  # signal 0: only asks whether the process exists
    except ProcessLookupError:
        return False
    except OSError:
        return True  # exists, owned by someone else
    return True


def _fsync_folder(folder: Path) -> None:
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _kind(value: object) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, dict):
        return "an object"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, int | float):
        return "a number"
    return type(value).__name__


def _as_float(value: object) -> float | None:
    """Return a JSON number as a finite float, or None (not a number, a bool, too large)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


def _cut(text: str, limit: int = 300) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _q(text: str) -> str:
    """Quote a string from the file for a message: escaped (repr), cut to 60 characters."""
    return repr(text) if len(text) <= 60 else repr(text[:57]) + "..."


def _short(value: object) -> str:
    """Show a value from the file in a message: short, escaped where it is not plain text, never deep."""
    if isinstance(value, str):
        text = json.dumps(value[:61], ensure_ascii=text_problem(value[:61]) is not None)
    elif isinstance(value, float):
        text = repr(value)
    elif isinstance(value, int) and not isinstance(value, bool):
        digits = len(str(abs(value))) if abs(value) < 10**60 else 61
        text = str(value) if digits <= 60 else f"a {'negative ' if value < 0 else ''}number of over 60 digits"
    elif isinstance(value, dict | list):
        if len(value) > 8 or _entry_problem(value, MAX_DEPTH - 2, strings=False) is not None:
            return f"{_kind(value)} of {len(value)} items"
        text = json.dumps(value, ensure_ascii=True, default=repr)
    else:
        text = json.dumps(value, default=repr)
    return text if len(text) <= 60 else text[:57] + "..."
