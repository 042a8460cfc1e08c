"""Close matches for a topic or tag nobody publishes, and the hint when the ROS graph is empty."""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from dbglog.viewer._data._model import TopicInfo

__all__ = [
    "DISCOVERY_HORIZON_S",
    "EMPTY_GRAPH_HINT",
    "close_matches",
    "graph_names",
    "sub_topics",
    "unpublished_reason",
]

DISCOVERY_HORIZON_S = 4.0
"""A running participant answers a newcomer's announcement once; when the newcomer misses that answer (a
Fast DDS race, docs/engine.md "Discovery"), it finds that participant at its next periodic announcement
(every 3 s): where the participants cannot be counted, the graph is complete only this long after start
(measured: up to 3.4 s on a loaded 2-core machine)."""

EMPTY_GRAPH_HINT = (
    "the ROS graph shows no topics at all: is the robot on the same ROS_DOMAIN_ID, and does "
    "ROS_AUTOMATIC_DISCOVERY_RANGE (LOCALHOST here unless you set it) reach it?"
)
"""What to say when discovery found nothing: the usual cause is a different domain or discovery range."""

_CUTOFF = 0.6


def close_matches(wanted: str, known: Iterable[str], *, limit: int = 3) -> list[str]:
    """Return up to `limit` names from `known` that look like `wanted`, best first.

    The namespaces both names share are set aside before comparing, so ``/rosdashboard/proximty``
    finds ``/rosdashboard/proximity`` but not ``/rosdashboard/motor/rpm``.
    """
    names = sorted(set(known) - {wanted})
    if not names or limit <= 0:
        return []
    scored: dict[str, float] = {}
    for name in names:
        score = difflib.SequenceMatcher(None, *_distinct_parts(wanted, name)).ratio()
        if score >= _CUTOFF:
            scored[name] = score
    return sorted(scored, key=lambda n: (-scored[n], n))[:limit]


def _distinct_parts(a: str, b: str) -> tuple[str, str]:
    """Return `a` and `b` without the leading ``/``-separated components they share."""
    pa, pb = a.split("/"), b.split("/")
    n = 0
    while n < min(len(pa), len(pb)) - 1 and pa[n] == pb[n]:
        n += 1
    return "/".join(pa[n:]), "/".join(pb[n:])


def sub_topics(parent: str, known: Iterable[str]) -> list[str]:
    """Return the topics below `parent` (a dict tag's keys: ``/rosdashboard/motor`` → ``.../motor/rpm``)."""
    prefix = parent.rstrip("/") + "/"
    return sorted(name for name in set(known) if name.startswith(prefix))


def unpublished_reason(wanted: str, known: Iterable[str]) -> str:
    """Say why `wanted` has no data yet: nothing on the graph at all, sub-topics, or close matches."""
    names = set(known)
    if not names:
        return EMPTY_GRAPH_HINT
    below = sub_topics(wanted, names)
    if below:
        shown = ", ".join(below[:6]) + (", ..." if len(below) > 6 else "")
        return f"nothing publishes {wanted} itself; it has sub-topics: {shown}"
    similar = close_matches(wanted, names)
    if similar:
        return f"nothing publishes {wanted}; did you mean {' or '.join(similar)}?"
    return f"nothing publishes {wanted} (not on the ROS graph yet)"


def graph_names(topics: list[TopicInfo]) -> set[str]:
    """Return the topics that some other participant publishes.

    The engine's own node publishes ``/parameter_events``: with one publisher that topic is ours
    alone, so a graph holding nothing else counts as empty.
    """
    return {t.name for t in topics if t.publishers > (1 if t.name == "/parameter_events" else 0)}
