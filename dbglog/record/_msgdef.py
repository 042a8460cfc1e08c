"""ROS 2 message definitions as MCAP's ``ros2msg`` schema text: the ``.msg`` file and its dependencies."""

from __future__ import annotations

import os
import sys
from pathlib import Path

__all__ = ["message_definition"]

_PRIMITIVES = frozenset(
    {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32"}
    | {"int64", "uint64", "string", "wstring"}
)
_SEPARATOR = "=" * 80


def _prefixes() -> list[Path]:
    """Where installed ROS packages live: the ament index, this interpreter's prefix, /opt/ros."""
    found: list[Path] = []
    for entry in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if entry:
            found.append(Path(entry))
    found += [Path(sys.prefix), Path(sys.base_prefix)]
    opt = Path("/opt/ros")
    if opt.is_dir():
        found += sorted(opt.iterdir())
    return found


def _msg_file(package: str, name: str) -> Path | None:
    for prefix in _prefixes():
        path = prefix / "share" / package / "msg" / f"{name}.msg"
        if path.is_file():
            return path
    return None


def _dependencies(text: str, package: str) -> list[str]:
    """The complex field types of a ``.msg`` text, as ``pkg/msg/Name``, in order of first use."""
    out: list[str] = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        field_type = line.split()[0]
        base = field_type.split("[", 1)[0].split("<=", 1)[0]
        if base in _PRIMITIVES:
            continue
        pkg, _, short = base.rpartition("/")
        full = f"{pkg or package}/msg/{short}"
        if full not in out:
            out.append(full)
    return out


def message_definition(msg_type: str) -> str | None:
    """Return the full ``ros2msg`` definition of `msg_type` (``pkg/msg/Name``), None when not installed.

    The text is the type's ``.msg`` file followed by each type it uses, each after a line of 80 ``=``
    and ``MSG: pkg/Name``, as rosbag2 and the MCAP ROS 2 profile expect.
    """
    parts = msg_type.split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    if len(parts) != 3 or parts[1] != "msg":
        return None
    root = _msg_file(parts[0], parts[2])
    if root is None:
        return None
    text = root.read_text(encoding="utf-8")
    sections = [text.rstrip("\n")]
    seen = {f"{parts[0]}/msg/{parts[2]}"}
    queue = _dependencies(text, parts[0])
    while queue:
        dep = queue.pop(0)
        if dep in seen:
            continue
        seen.add(dep)
        pkg, _, name = dep.split("/")
        path = _msg_file(pkg, name)
        if path is None:
            return None
        dep_text = path.read_text(encoding="utf-8")
        sections.append(f"{_SEPARATOR}\nMSG: {pkg}/{name}\n{dep_text.rstrip(chr(10))}")
        queue += _dependencies(dep_text, pkg)
    return "\n".join(sections) + "\n"
