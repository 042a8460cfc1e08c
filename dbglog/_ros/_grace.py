"""Whether a tag topic's publishers can be told to send batches yet: a new SDK node, rmw's unknown node.

The viewer's engine and ``dbglog record`` read a tag that only SDK nodes publish from their batches, and
subscribe to any other tag itself. Discovery tells the graph in pieces, so a graph poll can see a tag's
publisher before it can say whose it is: both readers ask `PublisherGrace` before deciding, and decide at
a later poll while it says wait. No import of rclpy.
"""

from __future__ import annotations

import time
from collections.abc import Collection, Iterable
from typing import Any

from dbglog._ros._batch import SCALAR_TYPES, is_sdk_node

__all__ = ["GRACE_S", "UNKNOWN_GAP_S", "UNKNOWN_NODE", "PublisherGrace"]

GRACE_S = 0.75
"""How long a publisher that cannot be told yet is waited for (per topic).

dbglog's own node (``dbglog_<pid>``) seen this recently publishing a scalar tag may not show its batch
publisher yet (discovery announces a node's endpoints in any order), and a publisher whose node rmw does not
know (`UNKNOWN_NODE`) may be an SDK's: a reader that subscribed to the tag then would read it apart from
its batches for good, and miss the samples before its subscription matched."""
UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"
"""The node name rmw gives an endpoint whose node it does not know. DDS announces an endpoint and rmw its
node (``ros_discovery_info``) in separate messages, so a new publisher shows under this name for 1-80 ms,
and a publisher of a node that is going away can show under it before it goes."""
UNKNOWN_GAP_S = 0.5
"""A topic's publisher seen under `UNKNOWN_NODE` again after this long is a new stretch (its own grace)."""
_SCALAR_TYPE_NAMES = frozenset(f"std_msgs/msg/{name}" for name in SCALAR_TYPES)

Node = tuple[str, str]
"""(namespace, name) of a node on the graph."""


class PublisherGrace:
    """Remembers when each SDK node and each topic's unknown publisher was first seen (one reader's graph).

    Example:
        >>> grace = PublisherGrace()
        >>> if grace.should_wait(topic, node.get_publishers_info_by_topic(topic), writers):
        ...     pass  # decide at the next graph poll
    """

    def __init__(self) -> None:
        self._first_seen: dict[Node, float] = {}
        """When each SDK node was first seen publishing."""
        self._unknown: dict[str, tuple[float, float]] = {}
        """Per topic, when a publisher under `UNKNOWN_NODE` was first and last seen in the current stretch."""

    def should_wait(self, name: str, infos: list[Any], writers: Iterable[Collection[Node]]) -> bool:
        """True while topic `name` has a publisher too new (or too unknown) to tell whether it sends batches.

        Args:
            name: the tag topic.
            infos: its publishers (``get_publishers_info_by_topic``).
            writers: the nodes seen writing batches, one collection per batch topic.

        A ``dbglog_<pid>`` node seen publishing a scalar topic less than `GRACE_S` ago and not yet seen
        writing batches; or a publisher whose node rmw does not know (`UNKNOWN_NODE`) since less than that.
        """
        now = time.monotonic()
        wait = False
        if any(i.node_name == UNKNOWN_NODE for i in infos):
            first, last = self._unknown.get(name, (now, now))
            if now - last > UNKNOWN_GAP_S:
                first = now
            self._unknown[name] = (first, now)
            wait = now - first < GRACE_S
        writing: set[Node] | None = None
        for i in infos:
            if not is_sdk_node(i.node_name):
                continue
            key = (i.node_namespace, i.node_name)
            fresh = now - self._first_seen.setdefault(key, now) < GRACE_S
            if not fresh or i.topic_type not in _SCALAR_TYPE_NAMES:
                continue
            if writing is None:
                writing = {node for nodes in writers for node in nodes}
            if key not in writing:
                wait = True
        return wait
