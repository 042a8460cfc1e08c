"""Two hosts in network namespaces: a robot publishes, a laptop runs the engine over a private veth link.

DDS runs UDPv4 only (``FASTDDS_BUILTIN_TRANSPORTS=UDPv4``: shared memory would bypass the link,
as both namespaces share /dev/shm) and discovers by multicast on the veth subnet
(``ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET`` plus a multicast route); the namespaces have no other
interface, so no packet can leave them.
"""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from tests._ros import wait_until

pytestmark = pytest.mark.netns

ROOT = Path(__file__).resolve().parent.parent
TOPIC = "/rosdashboard/netns_speed"

ROBOT = """
import sys, time, rclpy
from rclpy.context import Context
from rclpy.node import Node
from std_msgs.msg import Float64
ctx = Context(); rclpy.init(context=ctx)
node = Node("robot", context=ctx)
pub = node.create_publisher(Float64, sys.argv[1], 10)
i = 0
while True:
    pub.publish(Float64(data=float(i))); i += 1
    time.sleep(0.05)
"""

LAPTOP = """
import json, sys, time
from dbglog.viewer._data._engine import Engine
from dbglog.viewer._data._model import Binding
binding = Binding(sys.argv[1])
with Engine(stale_after=1.0) as engine:
    engine.bind(binding)
    while True:
        s = engine.snapshot(binding)
        print(json.dumps({"status": str(s.status), "count": s.count, "last": s.last}), flush=True)
        time.sleep(0.1)
"""


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=30)


@dataclass
class Link:
    """The two namespaces and the veth ends joining them."""

    robot: str
    laptop: str
    robot_if: str
    laptop_if: str

    def set_up(self, up: bool) -> None:
        """Bring the robot's end of the link up or down (the cable pulled / plugged back)."""
        _ip("-n", self.robot, "link", "set", self.robot_if, "up" if up else "down")

    def run(self, ns: str, code: str) -> subprocess.Popen[str]:
        """Start Python `code` inside namespace `ns` with DDS kept on the veth link."""
        env = dict(os.environ)
        env.update(
            ROS_AUTOMATIC_DISCOVERY_RANGE="SUBNET",
            FASTDDS_BUILTIN_TRANSPORTS="UDPv4",
            PYTHONPATH=str(ROOT),
        )
        env.pop("ROS_STATIC_PEERS", None)
        return subprocess.Popen(
            ["ip", "netns", "exec", ns, sys.executable, "-c", code, TOPIC],
            env=env,
            stdout=subprocess.PIPE,
            text=True,
        )


@pytest.fixture
def link() -> Iterator[Link]:
    """Build robot and laptop namespaces joined by a veth pair on 10.213.x.0/24; always remove them."""
    tag = f"{os.getpid() % 10000}{random.randrange(100)}"
    subnet = f"10.213.{random.randrange(1, 255)}"
    lk = Link(f"dbglog_robot_{tag}", f"dbglog_laptop_{tag}", f"vr{tag}", f"vl{tag}")
    try:
        _ip("netns", "add", lk.robot)
        _ip("netns", "add", lk.laptop)
        _ip("link", "add", lk.robot_if, "type", "veth", "peer", "name", lk.laptop_if)
        for ns, ifname, host in ((lk.robot, lk.robot_if, 1), (lk.laptop, lk.laptop_if, 2)):
            _ip("link", "set", ifname, "netns", ns)
            _ip("-n", ns, "addr", "add", f"{subnet}.{host}/24", "dev", ifname)
            _ip("-n", ns, "link", "set", "lo", "up")
            _ip("-n", ns, "link", "set", ifname, "up")
            _ip("-n", ns, "route", "add", "224.0.0.0/4", "dev", ifname)  # DDS discovery multicast
        yield lk
    finally:
        for ns in (lk.robot, lk.laptop):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=30, check=False)


class Lines:
    """The laptop's JSON status lines, collected by a background thread."""

    def __init__(self, proc: subprocess.Popen[str]) -> None:
        self.items: list[dict[str, Any]] = []
        self._proc = proc
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self._proc.stdout is not None
        for line in self._proc.stdout:
            self.items.append(json.loads(line))

    def wait(self, predicate: Callable[[dict[str, Any]], bool], timeout: float = 30.0) -> dict[str, Any]:
        """Wait for a new line that satisfies `predicate`; return it."""
        start = len(self.items)
        found: list[dict[str, Any]] = []

        def check() -> bool:
            found[:] = [x for x in self.items[start:] if predicate(x)][:1]
            return bool(found)

        assert wait_until(check, timeout, 0.05), f"never seen; last lines {self.items[-3:]}"
        return found[0]


def test_data_crosses_hosts_and_status_follows_the_link(link: Link) -> None:
    """The laptop sees the robot's tag live, stale when the link is cut, live again when it returns."""
    robot = link.run(link.robot, ROBOT)
    laptop = link.run(link.laptop, LAPTOP)
    try:
        lines = Lines(laptop)
        live = lines.wait(lambda x: x["status"] == "live" and x["count"] > 5)
        link.set_up(False)
        stale = lines.wait(lambda x: x["status"] == "stale")
        assert stale["count"] >= live["count"]
        frozen = stale["count"]
        time.sleep(0.5)
        assert lines.items[-1]["count"] == frozen  # nothing arrives while the cable is out
        link.set_up(True)
        back = lines.wait(lambda x: x["status"] == "live" and x["count"] > frozen)
        assert back["last"] > stale["last"]
    finally:
        for proc in (robot, laptop):
            proc.kill()
            proc.wait(10)
            if proc.stdout is not None:
                proc.stdout.close()
