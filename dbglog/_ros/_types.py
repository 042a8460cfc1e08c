"""The one gate from a message type name to its class, and the one table of ROS primitive types.

Allow-list rule: a type name is ``pkg/msg/Type`` (or ``pkg/Type``), ``pkg`` a ROS package name
(``[a-z][a-z0-9_]*``) and ``Type`` a message name (``[A-Z][A-Za-z0-9]*``). ``pkg.msg`` is imported only
when it is already loaded or ``pkg`` is an installed interface package: a ``pkg/msg/__init__.py`` on
the Python path (the PyPI wheels, a sourced workspace) or a ``rosidl_interfaces`` entry of the ament
index. So no string (a dashboard file, a topic type on the graph, a caller's ``msg_type``) can make
the process import an arbitrary module. Callers turn `TypeGateError` into their own words.
No import of rclpy at module level.
"""

from __future__ import annotations

import functools
import importlib
import re
import sys
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final, Literal

__all__ = [
    "PRIMITIVES",
    "Primitive",
    "PrimitiveKind",
    "TypeGateError",
    "installed_types",
    "is_message_class",
    "message_class",
    "normalize_type",
    "primitive",
    "type_name",
]

_TYPE: Final = re.compile(r"([a-z][a-z0-9_]*)/(?:msg/)?([A-Z][A-Za-z0-9]*)")
_PACKAGE: Final = re.compile(r"[a-z][a-z0-9_]*")
_IMPORT: Final = re.compile(r"^from\s+[\w.]+\._\w+\s+import\s+(\w+)", re.MULTILINE)

GateReason = Literal["malformed", "not_installed", "not_a_message"]
PrimitiveKind = Literal["bool", "int", "float", "string"]


class TypeGateError(ValueError):
    """A type name the gate refuses; `reason` says why (malformed, not installed, not a message)."""

    def __init__(self, reason: GateReason, message: str) -> None:
        super().__init__(message)
        self.reason: GateReason = reason


@dataclass(frozen=True, slots=True)
class Primitive:
    """A ROS primitive field type: its value kind, range, and fixed CDR size and numpy dtype."""

    kind: PrimitiveKind
    low: float | None = None
    high: float | None = None
    size: int | None = None
    """Bytes in CDR (also its alignment); None when the viewer does not decode it at a fixed offset."""
    dtype: str = ""
    """numpy dtype of the little-endian CDR value ('' without `size`)."""


def _int(bits: int, signed: bool, dtype: str = "") -> Primitive:
    low, high = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if signed else (0, 2**bits - 1)
    return Primitive("int", low, high, bits // 8 if dtype else None, dtype)


_FLOAT32_MAX: Final = 3.4028234663852886e38
_UINT8: Final = _int(8, False, "u1")
_FLOAT32: Final = Primitive("float", -_FLOAT32_MAX, _FLOAT32_MAX, 4, "<f4")
_FLOAT64: Final = Primitive("float", None, None, 8, "<f8")
PRIMITIVES: Final[dict[str, Primitive]] = {
    "boolean": Primitive("bool", size=1, dtype="?"),
    "octet": _UINT8,
    "byte": _UINT8,
    "char": _UINT8,
    "uint8": _UINT8,
    "int8": _int(8, True, "i1"),
    "int16": _int(16, True, "<i2"),
    "uint16": _int(16, False, "<u2"),
    "int32": _int(32, True, "<i4"),
    "uint32": _int(32, False, "<u4"),
    "int64": _int(64, True, "<i8"),
    "uint64": _int(64, False, "<u8"),
    "wchar": _int(16, False),
    "short": _int(16, True),
    "unsigned short": _int(16, False),
    "long": _int(32, True),
    "unsigned long": _int(32, False),
    "long long": _int(64, True),
    "unsigned long long": _int(64, False),
    "float": _FLOAT32,
    "float32": _FLOAT32,
    "double": _FLOAT64,
    "float64": _FLOAT64,
    "long double": Primitive("float"),
    "string": Primitive("string"),
    "wstring": Primitive("string"),
}
"""Every primitive type name rosidl uses (IDL names, ``.msg`` names and aliases), one entry each."""


def primitive(type_str: str) -> Primitive | None:
    """Return the primitive of a field type string (``double``, ``string<8>``), or None for anything else."""
    found = PRIMITIVES.get(type_str)
    if found is None and type_str.startswith(("string<", "wstring<")) and type_str.endswith(">"):
        return PRIMITIVES["string"]
    return found


def normalize_type(name: str) -> str:
    """Return ``pkg/msg/Type`` for ``pkg/Type`` or ``pkg/msg/Type``.

    Raises:
        TypeGateError: (``malformed``) the text is not a message type name.
    """
    match = _TYPE.fullmatch(name.strip()) if isinstance(name, str) else None
    if match is None:
        raise TypeGateError(
            "malformed",
            f"{name!r} is not a message type name (expected pkg/msg/Name, e.g. std_msgs/msg/Bool)",
        )
    return f"{match.group(1)}/msg/{match.group(2)}"


def _is_interface_package(package: str) -> bool:
    """True when `package` is loaded already, or installed as an interface package (see the module doc)."""
    if f"{package}.msg" in sys.modules:
        return True
    for entry in sys.path:
        try:
            if Path(entry or ".", package, "msg", "__init__.py").is_file():
                return True
        except (OSError, ValueError):
            continue
    try:
        from ament_index_python import has_resource
    except ImportError:
        return False
    try:
        return bool(has_resource("rosidl_interfaces", package))
    except (OSError, LookupError, ValueError):  # no ROS prefix sourced, or a broken index entry
        return False


def is_message_class(cls: object) -> bool:
    """True when `cls` is a generated ROS 2 message class."""
    return isinstance(cls, type) and hasattr(cls, "get_fields_and_field_types") and hasattr(cls, "__slots__")


def type_name(cls: type) -> str:
    """Return ``pkg/msg/Type`` for a generated ROS message class."""
    return f"{cls.__module__.split('.')[0]}/msg/{cls.__name__}"


@functools.lru_cache(maxsize=1024)
def message_class(name: str) -> Any:
    """Return the message class of `name`, importing only an installed interface package's ``msg``.

    Raises:
        TypeGateError: the name is malformed (``malformed``), no installed interface package provides
            it (``not_installed``), or it names something that is not a message (``not_a_message``).
    """
    full = normalize_type(name)
    package, _, type_ = full.split("/")
    if not _is_interface_package(package):
        raise TypeGateError("not_installed", f"message type {full} is not installed on this machine")
    try:
        cls = getattr(importlib.import_module(f"{package}.msg"), type_)
    except (ImportError, AttributeError) as exc:
        detail = "" if isinstance(exc, AttributeError) else f" ({exc})"
        raise TypeGateError(
            "not_installed", f"message type {full} is not installed on this machine{detail}"
        ) from None
    if not is_message_class(cls):
        raise TypeGateError("not_a_message", f"{full} is not a ROS message type")
    return cls


def _scan_python_path(paths: Iterable[str]) -> set[str]:
    found: set[str] = set()
    for entry in paths:
        try:
            root = Path(entry)
            if not root.is_dir():
                continue
            for init in root.glob("*/msg/__init__.py"):
                package = init.parent.parent.name
                if not _PACKAGE.fullmatch(package):
                    continue
                try:
                    text = init.read_text(encoding="utf-8", errors="replace")[:200_000]
                except OSError:
                    continue
                found.update(f"{package}/msg/{n}" for n in _IMPORT.findall(text) if n[:1].isupper())
        except OSError:
            continue
    return found


def _scan_ament_index() -> set[str]:
    try:
        from ament_index_python import get_resource, get_resources
    except ImportError:
        return set()
    found: set[str] = set()
    try:
        for package in get_resources("rosidl_interfaces"):
            content, _ = get_resource("rosidl_interfaces", package)
            for line in content.splitlines():
                if line.startswith("msg/") and line.endswith(".msg"):
                    found.add(f"{package}/msg/{line[4:-4]}")
    except (OSError, LookupError, ValueError):  # no ROS prefix sourced, or a broken index entry
        return set()
    return found


@functools.cache
def installed_types() -> tuple[str, ...]:
    """Return every installed message type as ``pkg/msg/Type``, sorted (scanned once, nothing imported)."""
    return tuple(sorted(_scan_python_path(sys.path) | _scan_ament_index()))
