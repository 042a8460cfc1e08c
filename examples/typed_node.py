"""An rclpy node that logs typed values with dbglog from a timer callback.

Run: ``.venv/bin/python examples/typed_node.py [--duration S] [--rate HZ]`` (Ctrl-C to stop), then watch
with ``dbglog echo proximity`` or the dbglog viewer. It uses only dbglog's public API and
plain rclpy; to keep DDS discovery on this machine, set ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

import dbglog


class TypedNode:
    """A pretend robot: a proximity sensor, a wheel counter, a bumper and a mode string."""

    def __init__(self, rate_hz: float) -> None:
        self.node = Node("typed_example")
        self._t0 = time.monotonic()
        self._ticks = 0
        self.node.create_timer(1.0 / rate_hz, self._tick)

    def _tick(self) -> None:
        t = time.monotonic() - self._t0
        self._ticks += 1
        proximity = 1.0 + 0.8 * math.sin(t)
        dbglog.logfloat("proximity", proximity)
        dbglog.logint("wheel/ticks", self._ticks)
        dbglog.logbool("bumper", proximity < 0.3)
        dbglog.logstring("mode", "cruise" if proximity > 0.5 else "careful", throttle=1.0)
        dbglog.log("pose", {"x": math.cos(t), "y": math.sin(t), "heading_deg": math.degrees(t) % 360})
        if dbglog.enabled:  # only compute what is only logged when it will be published
            dbglog.log("scan", [proximity * (1 + 0.1 * math.sin(i + t)) for i in range(8)])
        dbglog.logstring("status", "started", once=True)


def main(argv: list[str] | None = None) -> int:
    """Spin the node until Ctrl-C or --duration seconds."""
    parser = argparse.ArgumentParser(description="rclpy node logging typed values with dbglog")
    parser.add_argument("--duration", type=float, default=None, help="stop after this many seconds")
    parser.add_argument("--rate", type=float, default=10.0, help="timer rate in Hz (default 10)")
    args = parser.parse_args(argv)
    if args.rate <= 0:
        parser.error("--rate must be > 0")
    rclpy.init()
    node = TypedNode(args.rate).node
    dbglog.init(node=node)  # optional: publish from this node instead of dbglog's own
    deadline = None if args.duration is None else time.monotonic() + args.duration
    try:
        while rclpy.ok() and (deadline is None or time.monotonic() < deadline):
            rclpy.spin_once(node, timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        dbglog.flush(1.0)
        stats = dbglog.stats()
        dbglog.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    print(f"published {stats.published} values on {stats.tags} tags, dropped {stats.dropped}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
