"""A real ROS 2 peer for tests: its own context, node and spinning thread; no mocks anywhere."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from types import TracebackType
from typing import Any, Self

import rclpy
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

__all__ = ["RELIABLE_VOLATILE", "RosPeer", "first_line", "own_output", "wait_quiet", "wait_until"]

RELIABLE_VOLATILE = QoSProfile(
    depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE
)


def first_line(stream: Any) -> str:
    """The first line a child process printed, stripped, past the middleware's own log lines.

    Fast DDS prints its errors on stdout (``[RTPS_TRANSPORT_SHM Error] Failed init_port ...`` when a
    killed process left its shared-memory port locked; it goes on over UDP): they are not the child's.
    """
    while True:
        line = stream.readline()
        if not line:
            return ""
        if _middleware_line(line):
            continue
        return str(line).strip()


def own_output(text: str) -> str:
    """A child's captured output without the middleware's own log lines (see `first_line`), stripped."""
    return "\n".join(line for line in text.splitlines() if not _middleware_line(line)).strip()


def _middleware_line(line: str) -> bool:
    """Whether a line of a child's stdout is Fast DDS's own log (coloured, ``[RTPS_...]``)."""
    return "RTPS_" in line or line.startswith("\x1b[")


def wait_until(predicate: Callable[[], bool], timeout: float = 10.0, interval: float = 0.01) -> bool:
    """Poll `predicate` until it is true or `timeout` seconds pass; return its last value."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(interval)
    return predicate()


def wait_quiet(
    read: Callable[[], object], quiet: float, timeout: float = 30.0, interval: float = 0.02
) -> bool:
    """Poll `read` until its value has not changed for `quiet` seconds (messages still in flight have
    arrived, however loaded the machine) or `timeout` seconds pass; return whether it went quiet."""
    deadline = time.monotonic() + timeout
    last, since = read(), time.monotonic()
    while time.monotonic() < deadline:
        time.sleep(interval)
        now, value = time.monotonic(), read()
        if value != last:
            last, since = value, now
        elif now - since >= quiet:
            return True
    return False


class Collector:
    """Messages received on one subscription, in arrival order."""

    def __init__(self) -> None:
        self.messages: list[Any] = []
        self._lock = threading.Lock()

    def __call__(self, msg: Any) -> None:
        with self._lock:
            self.messages.append(msg)

    def values(self, attr: str = "data") -> list[Any]:
        """Return `attr` of every message received so far."""
        with self._lock:
            return [getattr(m, attr) for m in self.messages]

    def wait_for(self, n: int, timeout: float = 10.0) -> bool:
        """Wait until at least `n` messages have arrived."""
        return wait_until(lambda: len(self.messages) >= n, timeout)


class RosPeer:
    """An independent ROS 2 participant (own context and node) spinning in a background thread."""

    def __init__(self, name: str = "test_peer", namespace: str = "") -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node(name, namespace=namespace, context=self.context)
        self._executor = SingleThreadedExecutor(context=self.context)
        self._executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name=f"{name}-spin", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            while not self._stop.is_set() and self.context.ok():
                self._executor.spin_once(timeout_sec=0.05)
        except ExternalShutdownException:
            pass
        except Exception:
            if self.context.ok():  # (a context shut down under the wait set is the end, not a failure)
                raise

    def subscribe(self, topic: str, msg_type: Any, qos: QoSProfile | int = RELIABLE_VOLATILE) -> Collector:
        """Subscribe to `topic` and return the collector that fills with its messages."""
        collector = Collector()
        self.node.create_subscription(msg_type, topic, collector, qos)
        return collector

    def publisher(self, topic: str, msg_type: Any, qos: QoSProfile | int = RELIABLE_VOLATILE) -> Publisher:
        """Create a publisher on `topic`."""
        return self.node.create_publisher(msg_type, topic, qos)

    def wait_for_subscribers(self, pub: Publisher, n: int = 1, timeout: float = 10.0) -> bool:
        """Wait until `pub` is matched with at least `n` subscriptions."""
        return wait_until(lambda: pub.get_subscription_count() >= n, timeout)

    def topic_types(self, topic: str) -> list[str]:
        """Return the types the graph reports for `topic` (empty when unknown)."""
        return next((t for name, t in self.node.get_topic_names_and_types() if name == topic), [])

    def close(self) -> None:
        """Stop and join the spinning thread, then shut the context down."""
        self._stop.set()
        self._thread.join(timeout=5)
        if self.context.ok():
            rclpy.shutdown(context=self.context)
        self._executor.shutdown(timeout_sec=1)
        self.node.destroy_node()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
