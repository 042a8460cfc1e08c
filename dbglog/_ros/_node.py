"""A private ROS node: its own rclpy Context and Node, a wait set over raw subscriptions, clean teardown.

The viewer's engine, its publishing service and the regex bridge each own one. The context is
initialised with ``args=[]``, so rclpy never parses the process's command line (a file name that is
not UTF-8 cannot stop ROS from starting), and without signal handlers (the owner decides). Every live
private node is listed in `own_nodes`: the process's own endpoints are recognised by node identity,
never by a name prefix. No import of rclpy at module level.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Iterable
from typing import Any, NamedTuple

from dbglog._ros._profile import first_participant

__all__ = ["NodeIdentity", "PrivateNode", "WaitSet", "no_callback", "own_nodes", "take_batch"]

_log = logging.getLogger("dbglog.ros")
_OWN: dict[int, NodeIdentity] = {}
_OWN_LOCK = threading.Lock()


class NodeIdentity(NamedTuple):
    """A node on the graph, as ``get_*_info_by_topic`` names it."""

    namespace: str
    name: str


def own_nodes() -> frozenset[NodeIdentity]:
    """Return the identities of this process's live private nodes."""
    with _OWN_LOCK:
        return frozenset(_OWN.values())


class PrivateNode:
    """An rclpy Context + Node of one owner; `close` destroys the node and shuts the context down.

    Args:
        name: the node name.
        rosout: whether the node's log lines go to ``/rosout``.
        namespace: the node's namespace (``""``: the root).

    Raises:
        Exception: whatever rclpy raises when ROS cannot start (the owner words it).

    Example:
        >>> ros = PrivateNode("dbglog_viewer")
        >>> sub = ros.node.create_subscription(Float64, "/x", lambda _m: None, 10, raw=True)
        >>> ros.close()
    """

    def __init__(self, name: str, *, rosout: bool = False, namespace: str = "") -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.node import Node
        from rclpy.signals import SignalHandlerOptions

        self.context: Any = Context()
        with first_participant():  # a `dbglog` command's first participant: docs/engine.md "Discovery"
            rclpy.init(args=[], context=self.context, signal_handler_options=SignalHandlerOptions.NO)
            try:
                self.node: Any = Node(
                    name,
                    namespace=namespace,
                    context=self.context,
                    start_parameter_services=False,
                    enable_rosout=rosout,
                )
            except Exception:
                rclpy.shutdown(context=self.context)
                raise
        self.identity = NodeIdentity(self.node.get_namespace(), self.node.get_name())
        self._closed = False
        with _OWN_LOCK:
            _OWN[id(self)] = self.identity

    def ok(self) -> bool:
        """True while the context is up."""
        return bool(self.context.ok())

    def guard(self) -> Any:
        """Return a new guard condition of this context (to wake a wait set from another thread)."""
        from rclpy.guard_condition import GuardCondition

        return GuardCondition(None, None, context=self.context)

    def close(self, destroy: Iterable[Callable[[], object]] = ()) -> None:
        """Run the `destroy` calls (errors logged), destroy the node, shut the context down (idempotent)."""
        if self._closed:
            return
        self._closed = True
        with _OWN_LOCK:
            _OWN.pop(id(self), None)
        for call in destroy:
            try:
                call()
            except Exception:  # the context may already be gone at interpreter exit
                _log.debug("destroying a ROS entity failed", exc_info=True)
        try:
            self.node.destroy_node()
        finally:
            if self.context.ok():
                import rclpy

                rclpy.shutdown(context=self.context)


class WaitSet:
    """The raw rcl wait set over subscriptions and one guard condition, rebuilt only when they change."""

    def __init__(self, ros: PrivateNode, guard: Any) -> None:
        self._ros = ros
        self._guard = guard
        self._handles: list[Any] = []
        self._wait_set: Any = None

    def wait(self, subscriptions: list[Any], timeout_ns: int) -> set[int]:
        """Wait up to `timeout_ns` for `subscriptions` or the guard; return the ready handles' pointers."""
        from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

        handles = [sub.handle for sub in subscriptions]
        if self._wait_set is None or handles != self._handles:
            self._handles = handles
            self._wait_set = _rclpy.WaitSet(len(handles), 1, 0, 0, 0, 0, self._ros.context.handle)
        wait_set = self._wait_set
        wait_set.clear_entities()
        for handle in handles:
            wait_set.add_subscription(handle)
        wait_set.add_guard_condition(self._guard.handle)
        wait_set.wait(timeout_ns)
        return set(wait_set.get_ready_entities("subscription"))

    def reset(self) -> None:
        """Forget the rcl wait set (after an error): the next `wait` builds a new one."""
        self._wait_set = None


def take_batch(
    take: Callable[[Any, bool], Any], cls: Any, raw: bool, limit: int
) -> tuple[list[Any], list[int]]:
    """Take up to `limit` ready messages (CDR bytes when `raw`) and their source stamps (ns).

    Args:
        take: a subscription handle's ``take_message``.
        cls: the subscription's message class.
        raw: take CDR bytes instead of messages.
        limit: the most messages taken in one call (other subscriptions get their turn).
    """
    items: list[Any] = []
    stamps: list[int] = []
    for _ in range(limit):
        got = take(cls, raw)
        if got is None:
            break
        items.append(got[0])
        stamps.append(got[1]["source_timestamp"])
    return items, stamps


def no_callback(_msg: object) -> None:
    """Subscription callback that never runs: the owner takes messages itself through a `WaitSet`."""
