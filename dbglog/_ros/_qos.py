"""The QoS profiles dbglog uses: tag publishers (SDK and bridge), the batch topic, log-topic readers.

Each function imports rclpy, so call them only when ROS is wanted.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rclpy.qos import QoSProfile

__all__ = ["LOG_DEPTH", "TAG_HISTORY_DEPTH", "batch_qos", "log_qos", "subscription_qos", "tag_qos"]

TAG_HISTORY_DEPTH = 100
"""Enough to ride out bursts at sensor rates; a late viewer gets this much recent history."""
LOG_DEPTH = 1000
"""The history rcl's ``/rosout`` publishers keep (reliable, transient-local, depth 1000, 10 s lifespan),
all of which a reader started late is re-sent."""


def tag_qos() -> QoSProfile:
    """Return reliable + transient-local + keep-last QoS (imports rclpy, so call only when enabled).

    Reliable and transient-local publishers also match volatile and best-effort subscribers, and a
    viewer started after the node still receives each tag's latest values.
    """
    return subscription_qos(TAG_HISTORY_DEPTH, reliable=True, transient=True)


def batch_qos() -> QoSProfile:
    """Return the QoS of the batch topic: reliable, transient-local, keep-last `BATCH_DEPTH` batches.

    Deep enough that a viewer that falls behind for seconds still gets every batch, and a viewer
    started late gets the last seconds of every tag.
    """
    from dbglog._ros._batch import BATCH_DEPTH

    return subscription_qos(BATCH_DEPTH, reliable=True, transient=True)


def subscription_qos(depth: int, *, reliable: bool = True, transient: bool = False) -> QoSProfile:
    """Return keep-last QoS of `depth`: reliable or best-effort, transient-local or volatile."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if transient else DurabilityPolicy.VOLATILE,
    )


def log_qos(depth: int = LOG_DEPTH, *, durable: bool = True) -> QoSProfile:
    """Return the QoS of a log-line reader: reliable, keep-last `depth`.

    Args:
        depth: how many lines may wait to be taken (at least rcl's kept `LOG_DEPTH` for ``/rosout``).
        durable: transient-local (``/rosout``: its publishers are transient-local, so the lines they wrote
            before this subscription was discovered still arrive); volatile for String topics, whose
            publishers are usually volatile (a transient-local reader would not match them).
    """
    return subscription_qos(depth, reliable=True, transient=durable)
