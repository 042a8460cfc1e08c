"""The QoS every dbglog tag publisher uses (the SDK and the regex bridge alike)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rclpy.qos import QoSProfile

__all__ = ["TAG_HISTORY_DEPTH", "batch_qos", "tag_qos"]

TAG_HISTORY_DEPTH = 100
"""Enough to ride out bursts at sensor rates; a late viewer gets this much recent history."""


def tag_qos() -> QoSProfile:
    """Return reliable + transient-local + keep-last QoS (imports rclpy, so call only when enabled).

    Reliable and transient-local publishers also match volatile and best-effort subscribers, and a
    viewer started after the node still receives each tag's latest values.
    """
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=TAG_HISTORY_DEPTH,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )


def batch_qos() -> QoSProfile:
    """Return the QoS of the batch topic: reliable, transient-local, keep-last `BATCH_DEPTH` batches.

    Deep enough that a viewer that falls behind for seconds still gets every batch, and a viewer
    started late gets the last seconds of every tag.
    """
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    from dbglog._ros._batch import BATCH_DEPTH

    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=BATCH_DEPTH,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )
