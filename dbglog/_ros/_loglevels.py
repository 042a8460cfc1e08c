"""rcl_interfaces/msg/Log's levels (numbers, names) and logger-name matching: the console, CLI and bridge's.

Pure Python; imports no feature package.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Mapping
from typing import Final

__all__ = [
    "DEBUG",
    "ERROR",
    "FATAL",
    "INFO",
    "LEVELS",
    "LEVEL_NAMES",
    "WARN",
    "is_glob",
    "level_name",
    "level_of",
    "node_matches",
]

DEBUG: Final = 10
INFO: Final = 20
WARN: Final = 30
ERROR: Final = 40
FATAL: Final = 50
LEVEL_NAMES: Final[Mapping[int, str]] = {
    DEBUG: "DEBUG",
    INFO: "INFO",
    WARN: "WARN",
    ERROR: "ERROR",
    FATAL: "FATAL",
}
"""rcl_interfaces/msg/Log's level constants and the names lines are shown with."""
LEVELS: Final[Mapping[str, int]] = {name.lower(): number for number, name in LEVEL_NAMES.items()}
"""Minimum-level names as written in options, rules and dashboards (lower case), and their values."""
_GLOB_CHARS: Final = frozenset("*?[")


def level_of(name: str) -> int:
    """Return the level number of a name (``warn``, ``WARNING``, any case); ``""`` is 0 (every line).

    Raises:
        ValueError: not a level name.
    """
    key = name.strip().lower()
    if not key:
        return 0
    number = LEVELS.get("warn" if key == "warning" else key)
    if number is None:
        raise ValueError(f"unknown level {name!r} (one of: {', '.join(LEVELS)})")
    return number


def level_name(level: int) -> str:
    """Return the name shown for a level number: ``WARN``; ``""`` for a line without one (a String)."""
    if level <= 0:
        return ""
    return LEVEL_NAMES.get(level, str(level))


def is_glob(pattern: str) -> bool:
    """Whether a logger-name pattern is an fnmatch glob (``planner*``) rather than an exact name."""
    return not _GLOB_CHARS.isdisjoint(pattern)


def node_matches(logger: str, pattern: str) -> bool:
    """Whether `logger` matches `pattern`: an exact name, or an fnmatch glob (case-sensitive)."""
    if not is_glob(pattern):
        return logger == pattern
    return fnmatch.fnmatchcase(logger, pattern)
