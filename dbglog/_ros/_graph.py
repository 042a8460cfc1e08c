"""A reader's view of the ROS graph: its topics and each one's endpoints, at a cost that grows with its nodes.

rmw answers every per-topic question (``count_publishers``, ``get_publishers_info_by_topic``) by scanning
every endpoint it knows, so counting each topic of a graph costs its topics times its endpoints: about
100 ms for 2,000 topics. `GraphView` counts them from each node's lists instead (two questions a node,
whatever its topics), reads the node list at every poll (tens of µs: a node that comes or goes is seen at
once) and the topic list as often as it stays cheap. Runs on its owner's ROS thread; no import of rclpy.
"""

from __future__ import annotations

import logging
import math
import time
from collections import defaultdict
from collections.abc import Collection
from dataclasses import dataclass
from typing import Any

__all__ = ["LIST_SHARE", "RECOUNT_S", "SETTLE_S", "Endpoints", "GraphView"]

RECOUNT_S = 2.0
"""While the graph's nodes, topic names and types stay the same, every topic's endpoints are counted this
often: what waits for it is only an endpoint added to or removed from a node that stays (a node that comes
or goes, or a topic that comes, goes or changes type, is counted at once)."""
SETTLE_S = 1.0
"""After the graph's nodes, names or types change, every topic is counted at once and once more this much
later: rmw learns a node and its endpoints in separate discovery messages, so a count right after the node
list changed can miss the endpoints that follow it (or still hold those of a node that left)."""
LIST_SHARE = 0.005
"""The topic list is read at most this share of the time (a 5 ms read every second at most), and at least
every `RECOUNT_S`: on every poll of a small graph, less often as it grows (1,000s of topics)."""

Node = tuple[str, str]
"""(namespace, name) of a node on the graph."""
_log = logging.getLogger("dbglog.ros")


@dataclass(frozen=True, slots=True)
class Endpoints:
    """One topic's endpoints, as last counted."""

    publishers: int
    subscribers: int
    """Subscriptions other than the reader's own."""
    by: tuple[Node, ...] | None
    """The nodes that publish it (sorted; a node with two publishers on it once), or None when no node rmw
    knows has it (an endpoint whose node rmw has not learnt yet, a bare DDS program): counted by topic."""


class GraphView:
    """The graph's nodes, topics and endpoint counts, each read only as often as it is worth.

    Args:
        own: the reader's own node (namespace, name): its subscriptions are not counted.

    Example:
        >>> graph = GraphView(("", "dbglog_viewer"))
        >>> listed, counted = graph.look(node, time.monotonic(), period=0.25)
        >>> graph.counts["/chatter"].publishers
    """

    def __init__(self, own: Node | None = None) -> None:
        self.own = own
        self.nodes: list[tuple[str, str]] = []
        """(name, namespace) of every node, as ``get_node_names_and_namespaces`` gives them, sorted."""
        self.topics: list[tuple[str, list[str]]] = []
        """Every topic name and its types (``get_topic_names_and_types``), as last read."""
        self.counts: dict[str, Endpoints] = {}
        """Each listed topic's endpoints, as last counted."""
        self.version = 0
        """Goes up whenever `topics` or `counts` changed."""
        self.queries = 0
        """Questions asked of rmw so far."""
        self.lists = 0
        """Reads of the topic list so far."""
        self.recounts = 0
        """Counts of every topic's endpoints so far."""
        self.list_period = 0.0
        """Seconds between two reads of the topic list while nothing changes (see `LIST_SHARE`)."""
        self._changed_at = 0.0
        self._listed_at = -math.inf
        self._counted_at = -math.inf

    def look(
        self, node: Any, now: float, *, period: float, eager: bool = False, own_subs: Collection[str] = ()
    ) -> tuple[bool, bool]:
        """Read the node list, then the topic list and the endpoints if due; return (listed, counted).

        Args:
            node: the reader's rclpy node.
            now: monotonic seconds.
            period: the reader's poll period: the topic list is read no more often.
            eager: read the topic list now whatever it costs (a decision waits on it).
            own_subs: the topics the reader subscribes to itself: its node's subscriptions are not asked
                for (beside 2,000 held tags they are the longest answer), nor counted.
        """
        nodes = sorted(node.get_node_names_and_namespaces())
        self.queries += 1
        if nodes != self.nodes:
            self.nodes, self._changed_at = nodes, now
        listed = eager or self._due(self._listed_at, max(period, self.list_period), now)
        if listed:
            started = time.thread_time()
            topics = node.get_topic_names_and_types()
            self.queries += 1
            self.lists += 1
            self._listed_at = now
            if topics != self.topics:
                self.topics, self._changed_at = topics, now
                self.version += 1
            self.took(time.thread_time() - started)
        counted = self._due(self._counted_at, RECOUNT_S, now)
        if counted:
            self._counted_at = now
            self.recounts += 1
            counts = self._count(node, own_subs)
            if counts != self.counts:
                self.counts = counts
                self.version += 1
        return listed, counted

    def took(self, seconds: float) -> None:
        """Say that reading the topic list (and what its reader does with it) took `seconds` of CPU: the
        list is read again no sooner than `LIST_SHARE` allows, and at least every `RECOUNT_S`."""
        self.list_period = min(RECOUNT_S, seconds / LIST_SHARE)

    def _due(self, last: float, period: float, now: float) -> bool:
        """True when a read last done at `last` is due: the graph changed since, it has settled since the
        change, or `period` has passed."""
        changed = self._changed_at
        return last < changed or last < changed + SETTLE_S <= now or now - last >= period

    def _count(self, node: Any, own_subs: Collection[str]) -> dict[str, Endpoints]:
        """Count every listed topic's endpoints: from each node's publishers and subscriptions (two questions
        a node), and by topic for a topic that no node rmw knows has (its node not learnt yet, bare DDS)."""
        publishers: dict[str, list[Node]] = defaultdict(list)
        subscribers: dict[str, int] = defaultdict(int)
        known = set(own_subs)
        asked: set[Node] = set()
        for name, namespace in self.nodes:
            key = (namespace, name)
            if key in asked:  # two nodes of one name: rmw answers for one of them (the others' topics alone
                continue  # are counted by topic below)
            asked.add(key)
            own = key == self.own
            try:
                self.queries += 1 if own else 2
                pubs = node.get_publisher_names_and_types_by_node(name, namespace)
                subs = [] if own else node.get_subscriber_names_and_types_by_node(name, namespace)
            except Exception:  # gone since the node list (the next poll sees it), or a name rcl refuses:
                _log.debug("graph: cannot list the endpoints of %s", key, exc_info=True)
                continue  # its topics are counted by topic
            for topic, _types in pubs:
                publishers[topic].append(key)
                known.add(topic)
            for topic, _types in subs:
                subscribers[topic] += 1
                known.add(topic)
        counts = {}
        for topic, _types in self.topics:
            if topic in known:
                by = publishers.get(topic, [])
                counts[topic] = Endpoints(len(by), subscribers.get(topic, 0), tuple(sorted(by)))
                continue
            self.queries += 2
            counts[topic] = Endpoints(node.count_publishers(topic), node.count_subscribers(topic), None)
        return counts
