"""A dbglog widget plugin: a polar laser-scan view for ``sensor_msgs/msg/LaserScan``.

The viewer finds `LaserScanWidget` through the entry point ``laserscan`` in the group
``dbglog.widgets`` declared in this package's ``pyproject.toml``.
"""

from __future__ import annotations

from dbglog_laserscan._widget import LaserScanWidget

__all__ = ["LaserScanWidget"]
