"""The QoS every dbglog tag publisher uses (the SDK and the regex bridge alike)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rclpy.qos import QoSProfile

__all__ = ["TAG_HISTORY_DEPTH", "tag_qos"]

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
