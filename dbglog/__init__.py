"""dbglog: typed debug logging for ROS 2 robots, a regex bridge for log lines, and a live viewer."""

from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["__version__"]
