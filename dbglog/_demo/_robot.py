"""The demo robot's ROS 2 nodes: a turtle in a walled arena and a NAO-like sound-source localizer.

They debug the way a robot developer would with dbglog: a few ``dbglog.log*`` calls for typed values,
plus ordinary log lines (``get_logger().info``) that the bundled bridge rules turn into numbers.
Run with ``python -m dbglog._demo._robot [--duration S]``.
"""

from __future__ import annotations

import argparse
import collections
import math
import signal
import threading
import time
from collections.abc import Sequence
from typing import Any

import dbglog
from dbglog._demo._sim import SoundScene, Turtle

__all__ = ["main"]

TELEOP_HOLD_S = 3.0
"""After a velocity command from someone else (a dashboard slider, teleop), the autopilot waits this long."""


def _make_turtle_node(context: Any) -> Any:
    from geometry_msgs.msg import Pose2D, Twist
    from rclpy.node import Node
    from std_msgs.msg import Bool

    class TurtleNode(Node):  # type: ignore[misc]
        """Drives the turtle: autopilot unless teleoperated; publishes cmd_vel and pose."""

        def __init__(self) -> None:
            super().__init__("demo_turtle", context=context)
            self.turtle = Turtle()
            self.autopilot_on = True
            self.teleop: tuple[float, float] | None = None
            self.teleop_until = 0.0
            self.t0 = time.monotonic()
            self.last_odom = 0.0
            self.cmd_pub = self.create_publisher(Twist, "/turtle1/cmd_vel", 10)
            self.pose_pub = self.create_publisher(Pose2D, "/turtle1/pose", 10)
            # Our own autopilot commands come back on this topic too; only others' (teleop) count.
            self.sent: collections.deque[tuple[float, float]] = collections.deque(maxlen=50)
            self.create_subscription(Twist, "/turtle1/cmd_vel", self._on_teleop, 10)
            self.create_subscription(Bool, "/turtle1/autopilot", self._on_autopilot, 10)
            self.create_timer(0.02, self._tick)

        def _on_teleop(self, msg: Any) -> None:
            command = (float(msg.linear.x), float(msg.angular.z))
            if command in self.sent:
                return
            self.teleop = command
            self.teleop_until = time.monotonic() + TELEOP_HOLD_S

        def _on_autopilot(self, msg: Any) -> None:
            self.autopilot_on = bool(msg.data)
            self.get_logger().info(f"autopilot {'on' if self.autopilot_on else 'off'}")

        def _tick(self) -> None:
            now = time.monotonic()
            t = now - self.t0
            if self.teleop is not None and now < self.teleop_until:
                linear, angular = self.teleop
                mode = "teleop"
            elif self.autopilot_on:
                linear, angular = self.turtle.autopilot(t)
                mode = "autopilot"
                cmd = Twist()
                cmd.linear.x, cmd.angular.z = float(linear), float(angular)
                self.sent.append((cmd.linear.x, cmd.angular.z))
                self.cmd_pub.publish(cmd)
            else:
                linear, angular, mode = 0.0, 0.0, "stopped"
            hit = self.turtle.step(0.02, linear, angular)
            tt = self.turtle
            self.pose_pub.publish(Pose2D(x=tt.x, y=tt.y, theta=tt.theta))

            # Typed values, one line each: this is all a developer adds to see them live.
            dbglog.logfloat("turtle/x", tt.x)
            dbglog.logfloat("turtle/y", tt.y)
            dbglog.logfloat("turtle/wall_distance", tt.wall_distance())
            dbglog.logbool("turtle/near_wall", tt.wall_distance() < 1.0)
            dbglog.logstring("turtle/mode", mode, throttle=0.5)

            # Plain log lines, as nodes already write them: the bridge rules turn these into numbers.
            if hit is not None:
                self.get_logger().warning(
                    f"bumped into the {hit.wall} wall (hit #{hit.count}) at x={hit.x:.2f} y={hit.y:.2f}"
                )
            if now - self.last_odom >= 0.5:
                self.last_odom = now
                self.get_logger().info(
                    f"odometry: speed {tt.linear:.2f} m/s, heading {math.degrees(tt.theta):.1f} deg"
                )

    return TurtleNode()


def _make_sound_node(context: Any) -> Any:
    from rclpy.node import Node

    class SoundLocalizerNode(Node):  # type: ignore[misc]
        """Localizes sound sources relative to a head that turns toward confident sounds."""

        def __init__(self) -> None:
            super().__init__("demo_sound_localizer", context=context)
            self.scene = SoundScene()
            self.t0 = time.monotonic()
            self.create_timer(0.1, self._tick)

        def _tick(self) -> None:
            reading = self.scene.step(time.monotonic() - self.t0, 0.1)
            dbglog.logfloat("head/yaw", self.scene.head_yaw)
            dbglog.logbool("head/turning", self.scene.turning)
            if reading is None:
                return
            # A dict becomes one tag per key: /rosdashboard/sound/azimuth, .../elevation, .../confidence.
            dbglog.log(
                "sound",
                {
                    "azimuth": reading.azimuth,
                    "elevation": reading.elevation,
                    "confidence": reading.confidence,
                },
            )
            self.get_logger().info(
                f"sound source: azimuth={reading.azimuth:.3f} rad "
                f"elevation={reading.elevation:.3f} rad confidence={reading.confidence:.2f}"
            )

    return SoundLocalizerNode()


def run(duration: float | None = None, stop: threading.Event | None = None) -> None:
    """Run both demo nodes until `duration` seconds pass, `stop` is set, or SIGINT/SIGTERM."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

    stop = stop or threading.Event()
    context = Context()
    rclpy.init(context=context)
    nodes = [_make_turtle_node(context), _make_sound_node(context)]
    executor = SingleThreadedExecutor(context=context)
    for node in nodes:
        executor.add_node(node)
    deadline = None if duration is None else time.monotonic() + duration
    try:
        while context.ok() and not stop.is_set():
            if deadline is not None and time.monotonic() >= deadline:
                break
            executor.spin_once(timeout_sec=0.05)
    except ExternalShutdownException:
        pass
    finally:
        executor.shutdown(timeout_sec=1.0)
        for node in nodes:
            node.destroy_node()
        if context.ok():
            rclpy.shutdown(context=context)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo robot from the command line."""
    parser = argparse.ArgumentParser(description="dbglog demo robot: turtle arena + sound localizer")
    parser.add_argument("--duration", type=float, default=None, help="stop after this many seconds")
    args = parser.parse_args(argv)
    from dbglog._rosenv import localhost_discovery

    localhost_discovery()
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    run(args.duration, stop)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
