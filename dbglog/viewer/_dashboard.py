"""Dashboard files: the versioned JSON schema, validation with clear messages, atomic saves, legacy import.

A dashboard loads as far as it can: a widget of an unknown type, or a bad field, gives a message naming
the widget and the field while the rest still loads; unknown-type entries are kept verbatim and saved
back unchanged. Only a file that is not a dashboard at all raises `DashboardError`. Files from the
original ROSDashboard (``DragDial`` ... with ``posX``/``posY`` and ``subscription``) open too; saving
always writes the current format. Loading never writes.
"""

from __future__ import annotations

import contextlib
import copy
import json
import math
import os
import shutil
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from dbglog.regex_bridge._regex import RegexError, compile_regex, parse_number
from dbglog.viewer._model import Binding, binding_transforms, canonical_transforms
from dbglog.viewer._transforms import TransformChain, TransformError
from dbglog.viewer.widget_api import PropertyError, PropValue, Widget

__all__ = [
    "FORMAT",
    "LEGACY_TYPES",
    "MAX_STALE_AFTER",
    "VERSION",
    "Dashboard",
    "DashboardError",
    "LoadResult",
    "RawWidget",
    "WidgetConfig",
    "check_stale_after",
    "dumps",
    "load_dashboard",
    "parse_dashboard",
    "save_dashboard",
]

FORMAT = "dbglog-dashboard"
VERSION = 1
MAX_FILE_BYTES = 16 << 20
MAX_COORD = 100_000.0

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
        return out


def _binding_dict(b: Binding) -> dict[str, Any]:
    out: dict[str, Any] = {"topic": b.topic, "field": b.field, "regex": b.regex}
    if b.transform:
        out["transforms"] = binding_transforms(b)
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
            value = self.data.get(key, self.data.get(legacy))
            ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
            out.append(min(MAX_COORD, max(0.0, float(value))) if ok else default)
        return out[0], out[1], max(out[2], 80.0), max(out[3], 60.0)

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
        """Return the JSON form (current format)."""
        return {
            "format": FORMAT,
            "version": VERSION,
            "grid": {"size": self.grid_size, "snap": self.snap},
            "widgets": [w.to_dict() for w in self.widgets],
        }


@dataclass
class LoadResult:
    """A loaded dashboard with the messages about what could not be taken as it was."""

    dashboard: Dashboard
    messages: list[str] = field(default_factory=list)
    legacy: bool = False
    """True when the file was in the original ROSDashboard format."""


def dumps(dashboard: Dashboard) -> str:
    """Serialise a dashboard to JSON text (current format)."""
    return json.dumps(dashboard.to_dict(), indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def load_dashboard(path: str | os.PathLike[str], lookup: TypeLookup) -> LoadResult:
    """Read and validate a dashboard file (never writes to it).

    Args:
        path: the file.
        lookup: returns the widget class for a type name (None when unknown).

    Raises:
        DashboardError: the file cannot be read, is not JSON, or is not a dashboard; the message
            names the file.
    """
    p = Path(path)
    try:
        size = p.stat().st_size
        if size > MAX_FILE_BYTES:
            raise DashboardError(f"{p}: file is too large ({size} bytes; a dashboard is at most 16 MiB)")
        raw = p.read_bytes()
    except DashboardError:
        raise
    except FileNotFoundError:
        raise DashboardError(f"{p}: no such file") from None
    except IsADirectoryError:
        raise DashboardError(f"{p}: is a directory, not a dashboard file") from None
    except OSError as exc:
        raise DashboardError(f"{p}: cannot read: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DashboardError(f"{p}: not UTF-8 text (byte {exc.start})") from None
    try:
        data = json.loads(text, parse_constant=_reject_constant, parse_float=_finite_float)
    except json.JSONDecodeError as exc:
        raise DashboardError(
            f"{p}: not valid JSON: {exc.msg} at line {exc.lineno} column {exc.colno}"
        ) from None
    except (ValueError, RecursionError) as exc:
        raise DashboardError(f"{p}: not valid JSON: {exc}") from None
    try:
        return parse_dashboard(data, lookup)
    except DashboardError as exc:
        raise DashboardError(f"{p}: {exc}") from None


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"number {text[:30]} is out of range")
    return value


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not allowed in a dashboard file")


def parse_dashboard(data: object, lookup: TypeLookup) -> LoadResult:
    """Validate decoded JSON as a dashboard (current or legacy format).

    Raises:
        DashboardError: `data` is not a dashboard at all (not an object, no widget list, a newer version).
    """
    if not isinstance(data, dict):
        raise DashboardError(f"expected a JSON object at the top, got {_kind(data)}")
    widgets = data.get("widgets")
    if "format" not in data:
        if not isinstance(widgets, list):
            raise DashboardError("not a dashboard: no 'format' key and no 'widgets' list")
        return _parse_legacy(widgets, lookup)
    if data["format"] != FORMAT:
        raise DashboardError(f"'format' is {data['format']!r}, expected {FORMAT!r}")
    version = data.get("version")
    if isinstance(version, bool) or not isinstance(version, int):
        raise DashboardError(f"'version' must be an integer, got {_kind(version)}")
    if version > VERSION:
        raise DashboardError(f"version {version} is newer than this viewer understands (up to {VERSION})")
    if version < 1:
        raise DashboardError(f"version {version} is not a valid version")
    if not isinstance(widgets, list):
        raise DashboardError(f"'widgets' must be a list, got {_kind(widgets)}")
    result = LoadResult(Dashboard())
    _parse_grid(data.get("grid"), result)
    for key in data:
        if key not in {"format", "version", "grid", "widgets"}:
            result.messages.append(f"top level: unknown key {key!r} ignored")
    for index, entry in enumerate(widgets):
        _parse_widget(index, entry, lookup, result)
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


def _parse_widget(index: int, entry: object, lookup: TypeLookup, result: LoadResult) -> None:
    where = f"widget #{index + 1}"
    if not isinstance(entry, dict):
        result.messages.append(f"{where}: expected an object, got {_kind(entry)}; skipped")
        return
    name_value = entry.get("name")
    if isinstance(name_value, str) and name_value:
        where = f"{where} {name_value!r}"
    type_name = entry.get("type")
    if not isinstance(type_name, str) or not type_name:
        reason = f"field 'type' must be a widget type name, got {_short(type_name)}"
        result.messages.append(f"{where}: {reason}; kept as is")
        result.dashboard.widgets.append(RawWidget(copy.deepcopy(entry), reason))
        return
    cls = lookup(type_name)
    if cls is None:
        reason = f"unknown widget type {type_name!r} (not installed?)"
        result.messages.append(f"{where}: {reason}; kept as is and saved back unchanged")
        result.dashboard.widgets.append(RawWidget(copy.deepcopy(entry), reason))
        return
    msgs = result.messages
    name = name_value if isinstance(name_value, str) and name_value else cls.label
    if not (isinstance(name_value, str) and name_value):
        msgs.append(
            f"{where}: field 'name' must be a non-empty string, got {_short(name_value)}; using {name!r}"
        )
    elif len(name) > 200:
        msgs.append(f"{where}: field 'name' is longer than 200 characters; cut")
        name = name[:200]
    dw, dh = cls.default_size
    mw, mh = cls.min_size
    x = _coord(entry, "x", 0.0, 0.0, where, msgs)
    y = _coord(entry, "y", 0.0, 0.0, where, msgs)
    width = _coord(entry, "width", float(dw), float(mw), where, msgs)
    height = _coord(entry, "height", float(dh), float(mh), where, msgs)
    bindings = _parse_bindings(entry.get("bindings", []), cls, where, msgs)
    props = _parse_properties(entry.get("properties", {}), cls, where, msgs)
    stale_after = _stale_after(entry, where, msgs)
    for key in entry:
        if key not in _WIDGET_KEYS:
            msgs.append(f"{where}: unknown field {key!r} ignored")
    result.dashboard.widgets.append(
        WidgetConfig(type_name, name, x, y, width, height, bindings, props, stale_after)
    )


_WIDGET_KEYS = frozenset(
    {"type", "name", "x", "y", "width", "height", "bindings", "properties", "stale_after"}
)
MAX_STALE_AFTER = 86_400.0
"""A widget's own stale time is at most a day."""


def check_stale_after(value: object) -> float:
    """Return a valid per-widget stale time in seconds or raise ValueError saying what is wrong."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"must be a number of seconds, got {_short(value)}")
    if not 0 < value <= MAX_STALE_AFTER:
        raise ValueError(f"must be more than 0 and at most {MAX_STALE_AFTER:g} seconds, got {value:g}")
    return float(value)


def _stale_after(entry: Mapping[str, Any], where: str, msgs: list[str]) -> float | None:
    if "stale_after" not in entry or entry["stale_after"] is None:
        return None
    try:
        return check_stale_after(entry["stale_after"])
    except ValueError as exc:
        msgs.append(f"{where}: field 'stale_after' {exc}; using the viewer's stale time")
        return None


def _coord(
    entry: Mapping[str, Any], key: str, default: float, low: float, where: str, msgs: list[str]
) -> float:
    if key not in entry:
        msgs.append(f"{where}: field {key!r} is missing; using {default:g}")
        return default
    value = entry[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        msgs.append(f"{where}: field {key!r} must be a number, got {_short(value)}; using {default:g}")
        return default
    if not low <= value <= MAX_COORD:
        fixed = min(MAX_COORD, max(low, float(value)))
        msgs.append(f"{where}: field {key!r} = {value:g} is outside {low:g}..{MAX_COORD:g}; using {fixed:g}")
        return fixed
    return float(value)


def _parse_bindings(raw: object, cls: type[Widget], where: str, msgs: list[str]) -> tuple[Binding, ...]:
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
            # Checked here, before anything is evaluated: a bad formula drops this binding only.
            try:
                chain = TransformChain.from_json(item["transforms"], where=at)
            except TransformError as exc:
                msgs.append(f"{exc}; binding rejected")
                binding = None
            else:
                binding = replace(binding, transform=canonical_transforms(chain.to_json()))
        if binding is not None:
            out.append(binding)
        for key in item:
            if key not in {"topic", "field", "regex", "transforms"}:
                msgs.append(f"{at}: unknown field {key!r} ignored")
    return tuple(out)


def _binding(topic: object, fld: object, regex: object, at: str, msgs: list[str]) -> Binding | None:
    if not isinstance(topic, str) or not topic.strip():
        msgs.append(f"{at}: field 'topic' must be a topic name, got {_short(topic)}; dropped")
        return None
    topic = topic.strip()
    if not topic.startswith("/"):
        topic = "/" + topic
    if fld is None:
        fld = ""
    if not isinstance(fld, str):
        msgs.append(f"{at}: field 'field' must be a string, got {_short(fld)}; using the whole message")
        fld = ""
    if regex is None:
        regex = ""
    if not isinstance(regex, str):
        msgs.append(f"{at}: field 'regex' must be a string, got {_short(regex)}; no regex used")
        regex = ""
    if regex:
        try:
            compile_regex(regex)
        except RegexError as exc:
            msgs.append(f"{at}: field 'regex' {regex!r} does not compile ({exc}); no regex used")
            regex = ""
    return Binding(topic, fld.strip(), regex)


def _parse_properties(raw: object, cls: type[Widget], where: str, msgs: list[str]) -> dict[str, PropValue]:
    props = cls.default_properties()
    if not isinstance(raw, dict):
        msgs.append(f"{where}: field 'properties' must be an object, got {_kind(raw)}; defaults used")
        return props
    for key, value in raw.items():
        decl = cls.property_named(key)
        if decl is None:
            msgs.append(f"{where}: unknown property {key!r} for a {cls.type_name}; ignored")
            continue
        try:
            props[key] = decl.validate(value)
        except PropertyError as exc:
            msgs.append(f"{where}: {exc}; using the default {decl.default!r}")
    return props


def _parse_legacy(widgets: list[Any], lookup: TypeLookup) -> LoadResult:
    """Translate the original ROSDashboard format entry by entry, then validate as current entries."""
    result = LoadResult(Dashboard(), legacy=True)
    result.dashboard.snap = False
    for index, entry in enumerate(widgets):
        where = f"widget #{index + 1}"
        if not isinstance(entry, dict):
            result.messages.append(f"{where}: expected an object, got {_kind(entry)}; skipped")
            continue
        if isinstance(entry.get("name"), str) and entry["name"]:
            where = f"{where} {entry['name']!r}"
        legacy_type = entry.get("type")
        new_type = LEGACY_TYPES.get(legacy_type) if isinstance(legacy_type, str) else None
        if new_type is None or lookup(new_type) is None:
            reason = f"unknown ROSDashboard widget type {_short(legacy_type)}"
            result.messages.append(f"{where}: {reason}; kept as is and saved back unchanged")
            result.dashboard.widgets.append(RawWidget(copy.deepcopy(entry), reason))
            continue
        converted: dict[str, Any] = {"type": new_type, "name": entry.get("name", legacy_type)}
        for old, new in (("posX", "x"), ("posY", "y"), ("width", "width"), ("height", "height")):
            if old in entry:
                converted[new] = entry[old]
        cls = lookup(new_type)
        assert cls is not None
        # ROSDashboard drew its widgets at a fixed size whatever the file said: grow small ones quietly.
        for key, low in (("width", cls.min_size[0]), ("height", cls.min_size[1])):
            value = converted.get(key)
            if isinstance(value, int | float) and not isinstance(value, bool) and 0 <= value < low:
                converted[key] = float(low)
        props, extra_binding = _legacy_properties(entry.get("properties"), where, result.messages)
        converted["properties"] = props
        converted["bindings"] = _legacy_bindings(
            entry.get("subscription"), extra_binding, where, result.messages
        )
        _parse_widget(index, converted, lookup, result)
    return result


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
            try:
                value = parse_number(value)
            except ValueError:
                msgs.append(f"{at}: {name!r} value {value!r} is not a number; ignored")
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

    A failure at any step leaves the previous file as it was.

    Raises:
        DashboardError: the file cannot be written; the message names the file and the reason.
    """
    target = Path(path)
    try:
        text = dumps(dashboard)
    except (TypeError, ValueError) as exc:
        raise DashboardError(f"{target}: cannot serialise the dashboard: {exc}") from None
    folder = target.parent if str(target.parent) else Path(".")
    tmp_name: str | None = None
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        if target.is_dir():
            raise IsADirectoryError(21, "is a directory", str(target))
        if target.exists():
            bak = target.with_name(target.name + ".bak")
            bak_fd, bak_tmp = tempfile.mkstemp(prefix=f".{bak.name}.", suffix=".tmp", dir=folder)
            os.close(bak_fd)
            try:
                shutil.copyfile(target, bak_tmp)
                os.replace(bak_tmp, bak)
            finally:
                with contextlib.suppress(OSError):
                    os.unlink(bak_tmp)  # already gone after a successful replace
        os.replace(tmp_name, target)
        tmp_name = None
    except OSError as exc:
        raise DashboardError(f"{target}: cannot save: {exc.strerror or exc}") from None
    finally:
        if tmp_name is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp_name)


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


def _short(value: object) -> str:
    text = (
        json.dumps(value, ensure_ascii=False, default=repr) if not isinstance(value, float) else repr(value)
    )
    return text if len(text) <= 60 else text[:57] + "..."
