"""dbglog: typed debug logging for ROS 2 robots, a regex bridge for log lines, and a live viewer.

``dbglog.logfloat("proximity", d)`` publishes ``d`` on ``/rosdashboard/proximity`` as
``std_msgs/msg/Float64``. ``DBGLOG=off`` (and ``python -O``) binds every function to a no-op at import.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from dbglog._config import load_config as _load_config
from dbglog.api._errors import DbglogError, DbglogWarning, Stats

__version__ = "0.1.0"

_config = _load_config()

enabled: bool = _config.enabled
"""True when dbglog publishes; use it to skip computing values that are only logged."""

if TYPE_CHECKING or enabled:
    from dbglog.api._public import (
        flush,
        init,
        log,
        logbool,
        logdata,
        logfloat,
        logint,
        logstring,
        shutdown,
        stats,
    )

    if enabled:
        from dbglog.api import _public

        _public.REPORTER.strict = _config.strict
        _public.RUNTIME.env_robot = _config.namespace
        _public.RUNTIME.exit_wait = _config.exit_wait
        if _config.watch:  # docs/watch.md: the program's variables become readable on the ROS domain
            from dbglog.watch import _agent as _watch_agent

            _watch_agent.start()
else:
    from dbglog.api._disabled import (
        flush,
        init,
        log,
        logbool,
        logdata,
        logfloat,
        logint,
        logstring,
        shutdown,
        stats,
    )

__all__ = [
    "DbglogError",
    "DbglogWarning",
    "Stats",
    "__version__",
    "enabled",
    "flush",
    "init",
    "log",
    "logbool",
    "logdata",
    "logfloat",
    "logint",
    "logstring",
    "shutdown",
    "stats",
]
