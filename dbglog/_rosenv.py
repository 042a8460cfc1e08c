"""Keep DDS discovery on this machine for demos, tests and benchmarks unless the user chose otherwise."""

from __future__ import annotations

import os
from collections.abc import MutableMapping

__all__ = ["localhost_discovery"]


def localhost_discovery(environ: MutableMapping[str, str] | None = None) -> None:
    """Set ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` unless it is already set.

    Call before rclpy is initialised (the middleware reads it when the context starts).
    """
    env = os.environ if environ is None else environ
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
