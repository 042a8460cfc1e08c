"""Configuration read from the environment: once, in one place, with typed switches."""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping
from dataclasses import dataclass

__all__ = ["Config", "ConfigError", "env_bool", "env_float", "env_namespace", "has_display", "load_config"]

_TRUE = frozenset({"1", "true", "yes", "on"})
_FALSE = frozenset({"0", "false", "no", "off"})


class ConfigError(ValueError):
    """An environment variable that dbglog reads holds a value it does not accept."""


def env_bool(key: str, default: bool, *, environ: Mapping[str, str] | None = None) -> bool:
    """Read a boolean switch: 1/true/yes/on or 0/false/no/off, any case; unset or empty is `default`.

    Args:
        key: the variable's name, e.g. ``"DBGLOG"``.
        default: the value when the variable is unset or empty.
        environ: where to read from (``os.environ`` when omitted).

    Raises:
        ConfigError: the value is none of the accepted words; the message names the variable.
    """
    env = os.environ if environ is None else environ
    raw = env.get(key)
    if raw is None or not raw.strip():
        return default
    word = raw.strip().lower()
    if word in _TRUE:
        return True
    if word in _FALSE:
        return False
    raise ConfigError(
        f"environment variable {key}={raw!r} is not a valid switch: "
        "use on/1/true/yes to enable or off/0/false/no to disable"
    )


def env_float(
    key: str, default: float, *, minimum: float = 0.0, environ: Mapping[str, str] | None = None
) -> float:
    """Read a finite number >= `minimum`; unset or empty is `default`.

    Raises:
        ConfigError: the value is not a number or is out of range; the message names the variable.
    """
    env = os.environ if environ is None else environ
    raw = env.get(key)
    if raw is None or not raw.strip():
        return default
    try:
        value = float(raw.strip())
    except ValueError:
        raise ConfigError(f"environment variable {key}={raw!r} is not a number") from None
    if not (value >= minimum and value != float("inf")):
        raise ConfigError(f"environment variable {key}={raw!r} must be a finite number >= {minimum}")
    return value


def has_display(environ: Mapping[str, str] | None = None) -> bool:
    """Whether a graphical display is available (``DISPLAY`` or ``WAYLAND_DISPLAY`` is set)."""
    env = os.environ if environ is None else environ
    return bool(env.get("DISPLAY", "").strip() or env.get("WAYLAND_DISPLAY", "").strip())


@dataclass(frozen=True, slots=True)
class Config:
    """The settings dbglog takes from the environment at import time."""

    enabled: bool
    """``DBGLOG``: on unless switched off; off by default under ``python -O``."""
    strict: bool
    """``DBGLOG_STRICT``: logging calls raise instead of warning (for tests)."""
    namespace: str = ""
    """``DBGLOG_NAMESPACE``: the robot namespace of the SDK's topics when neither the node given to
    ``dbglog.init`` nor the process's ``--ros-args`` names one (``""``: the root; ``/robot1``)."""
    watch: bool = False
    """``DBGLOG_WATCH``: the process can be watched (``dbglog watch``, docs/watch.md); off by default."""
    exit_wait: float = 2.0
    """``DBGLOG_EXIT_WAIT``: the most seconds a young process waits at exit for dbglog's readers on the graph
    to match it (0: not at all; docs/api.md)."""


def load_config(environ: Mapping[str, str] | None = None) -> Config:
    """Read every dbglog setting from the environment.

    Raises:
        ConfigError: a variable holds a value that is not accepted.
    """
    optimized = sys.flags.optimize > 0
    return Config(
        enabled=env_bool("DBGLOG", not optimized, environ=environ),
        strict=env_bool("DBGLOG_STRICT", False, environ=environ),
        namespace=env_namespace("DBGLOG_NAMESPACE", environ=environ),
        watch=env_bool("DBGLOG_WATCH", False, environ=environ),
        exit_wait=env_float("DBGLOG_EXIT_WAIT", 2.0, environ=environ),
    )


def env_namespace(key: str, *, environ: Mapping[str, str] | None = None) -> str:
    """Read a robot namespace (``robot1`` or ``/robot1``, held as ``/robot1``); unset or ``/`` is ``""``.

    Raises:
        ConfigError: not a namespace dbglog's topics can be in; the message names the variable.
    """
    from dbglog._ros._tags import TagError, normalize_robot

    env = os.environ if environ is None else environ
    raw = env.get(key, "")
    try:
        return normalize_robot(raw)
    except TagError as exc:
        raise ConfigError(f"environment variable {key}={raw!r} is not a robot namespace: {exc}") from None
