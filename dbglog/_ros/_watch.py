"""The watch transport's names and QoS: hidden topics between watchable processes and their watchers.

Written once here, so that putting them under a robot namespace later is a change to `watch_topics` only.
Each message is one JSON object in a ``std_msgs/msg/String`` (docs/watch.md, *Protocol*). No import of
rclpy at module level.
"""

from __future__ import annotations

import os
import re
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    from rclpy.qos import QoSProfile

__all__ = [
    "PROTOCOL_VERSION",
    "WATCH_TYPE",
    "WatchTopics",
    "agent_node_name",
    "agents_qos",
    "is_agent_node",
    "is_watcher_node",
    "message_qos",
    "watch_topics",
    "watcher_node_name",
]

PROTOCOL_VERSION = 1
"""The ``v`` of every message; a process or watcher that reads another version says so and ignores it."""
WATCH_TYPE = "std_msgs/msg/String"

_AGENT = re.compile(r"dbglog_watch_[0-9]+_[0-9a-f]{6}")
_WATCHER = re.compile(r"dbglog_watcher_[0-9]+_[0-9a-f]{6}")


class WatchTopics(NamedTuple):
    """The three hidden topics of the watch transport."""

    agents: str
    """Each watchable process's announcement (transient-local, its latest one): who it is, its watches."""
    requests: str
    """Watcher -> process: one request, addressed to one process."""
    answers: str
    """Process -> watchers: answers to requests, and events of armed watches (status, counts)."""


def watch_topics() -> WatchTopics:
    """Return the watch transport's topics (the one place that names them)."""
    return WatchTopics("/_dbglog/watch/agents", "/_dbglog/watch/requests", "/_dbglog/watch/answers")


def agent_node_name(pid: int | None = None) -> str:
    """Return a fresh node name for the watch agent of process `pid` (random suffix: hosts share pids)."""
    return f"dbglog_watch_{os.getpid() if pid is None else pid}_{os.urandom(3).hex()}"


def watcher_node_name(pid: int | None = None) -> str:
    """Return a fresh node name for a watcher (``dbglog watch``, the viewer) in process `pid`."""
    return f"dbglog_watcher_{os.getpid() if pid is None else pid}_{os.urandom(3).hex()}"


def is_agent_node(name: str) -> bool:
    """True for a node named by `agent_node_name`."""
    return _AGENT.fullmatch(name) is not None


def is_watcher_node(name: str) -> bool:
    """True for a node named by `watcher_node_name`."""
    return _WATCHER.fullmatch(name) is not None


def agents_qos() -> QoSProfile:
    """Reliable, transient-local, the latest announcement of each process: a late watcher sees them all."""
    from dbglog._ros._qos import subscription_qos

    return subscription_qos(1, reliable=True, transient=True)


def message_qos() -> QoSProfile:
    """Reliable and volatile, deep enough for bursts of answers and events (requests are retried)."""
    from dbglog._ros._qos import subscription_qos

    return subscription_qos(1000, reliable=True, transient=False)
