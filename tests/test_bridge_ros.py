"""The bridge on real ROS 2: nodes log lines, typed values arrive on /rosdashboard topics (object and CLI)."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from functools import partial
from pathlib import Path
from typing import Any

import pytest
from rcl_interfaces.msg import Log
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool, Float64, Int64, String

from dbglog.regex_bridge import parse_rules
from dbglog.regex_bridge._node import DEDUP_WINDOW, Bridge, _Published
from dbglog.regex_bridge._rules import ROSOUT
from tests._ros import Collector, RosPeer, wait_until

RULES = r"""
rules:
  - tag: t/probe
    type: int
    pattern: 'probe=(\d+)'
  - tag: t/speed
    node: 'robot*'
    pattern: 'speed (\S+) m/s'
  - tag: t/alarm
    node: robot_arm
    level: warn
    type: int
    pattern: 'alarm (\d+)'
  - tag: t/pose
    node: robot_arm
    pattern: 'pose x=(?P<x>\S+) y=(?P<y>\S+)'
  - tag: t/ok
    type: bool
    source_topic: /t_chatter
    pattern: 'ok=(\w+)'
  - tag: t/echo
    type: int
    pattern: 'not published.*; (\d+) so far'
"""

LATCHED = QoSProfile(
    depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
TIMEOUT = 20.0


@pytest.fixture
def peers() -> Iterator[tuple[RosPeer, RosPeer, RosPeer]]:
    """A robot node (`robot_arm`), another node (`camera`) and an independent viewer."""
    with RosPeer("robot_arm") as robot, RosPeer("camera") as camera, RosPeer("viewer") as viewer:
        yield robot, camera, viewer


def _has_type(peer: RosPeer, topic: str, type_name: str) -> bool:
    return peer.topic_types(topic) == [type_name]


def _probe(robot: RosPeer, probes: Collector, value: int) -> None:
    """Log `probe=<value>` until the bridge's value for it reaches the viewer (discovery done)."""
    for _ in range(int(TIMEOUT / 0.2)):
        robot.node.get_logger().info(f"probe={value}")
        if wait_until(lambda: value in probes.values(), timeout=0.2):
            return
    raise AssertionError(f"probe {value} never came through the bridge")


def test_bridge_turns_logged_lines_into_typed_topics(peers: tuple[RosPeer, RosPeer, RosPeer]) -> None:
    """Info/warning lines of an unmodified node arrive as Float64/Int64/Bool; node and level filters hold."""
    robot, camera, viewer = peers
    with Bridge(parse_rules(RULES), node_name="bridge_under_test", warn_every=0.0) as bridge:
        # Every output exists before the first match, with its type.
        for topic, type_name in [
            ("/rosdashboard/t/speed", "std_msgs/msg/Float64"),
            ("/rosdashboard/t/alarm", "std_msgs/msg/Int64"),
            ("/rosdashboard/t/pose/x", "std_msgs/msg/Float64"),
            ("/rosdashboard/t/ok", "std_msgs/msg/Bool"),
        ]:
            assert wait_until(partial(_has_type, viewer, topic, type_name), TIMEOUT), topic
        assert bridge.stats.values == 0

        probes = viewer.subscribe("/rosdashboard/t/probe", Int64, LATCHED)
        speed = viewer.subscribe("/rosdashboard/t/speed", Float64, LATCHED)
        alarm = viewer.subscribe("/rosdashboard/t/alarm", Int64, LATCHED)
        pose_y = viewer.subscribe("/rosdashboard/t/pose/y", Float64, LATCHED)
        echo = viewer.subscribe("/rosdashboard/t/echo", Int64, LATCHED)
        warnings = viewer.subscribe("/rosout", Log)
        _probe(robot, probes, 1)
        _probe(camera, probes, 2)

        camera.node.get_logger().info("speed 9.9 m/s")  # node filter: camera is not robot*
        robot.node.get_logger().info("alarm 5")  # level filter: info < warn
        robot.node.get_logger().info("speed 0.5 m/s")
        robot.node.get_logger().warning("alarm 7")
        robot.node.get_logger().error("alarm 8")
        robot.node.get_logger().info("speed 1,5 m/s")  # unparseable: counted, warned, not published
        robot.node.get_logger().info("pose x=1.25 y=-3.5")
        robot.node.get_logger().info("speed 2.5 m/s")

        assert speed.wait_for(2, TIMEOUT)
        assert alarm.wait_for(2, TIMEOUT)
        assert pose_y.wait_for(1, TIMEOUT)
        # The bridge warns about the unparseable capture on /rosout, and never matches its own lines.
        assert wait_until(
            lambda: any(
                m.name == "bridge_under_test" and "could not be parsed" in m.msg for m in warnings.messages
            ),
            TIMEOUT,
        )
        _probe(camera, probes, 3)
        _probe(robot, probes, 4)
        assert speed.values() == [0.5, 2.5]
        assert alarm.values() == [7, 8]
        assert pose_y.values() == [-3.5]
        assert echo.values() == []
        stats = bridge.stats
        assert (stats.values, stats.unparseable, stats.errors) == (4 + 2 + 2 + 2, 1, 0)


def test_string_topics_and_bad_messages_never_stop_the_bridge(
    peers: tuple[RosPeer, RosPeer, RosPeer],
) -> None:
    """Lines from a std_msgs/String topic are matched too; an unreadable message is counted and skipped."""
    robot, _camera, viewer = peers
    with Bridge(parse_rules(RULES), node_name="bridge_strings") as bridge:
        ok = viewer.subscribe("/rosdashboard/t/ok", Bool, LATCHED)
        chatter = robot.publisher("/t_chatter", String)
        assert robot.wait_for_subscribers(chatter, timeout=TIMEOUT)
        chatter.publish(b"\x00\x01\x00\x00\xff\xff\xff\x7f")  # a length field pointing far past the end
        chatter.publish(String(data="ok=true"))
        chatter.publish(String(data="ok=perhaps"))
        chatter.publish(String(data="ok=OFF"))
        assert ok.wait_for(2, TIMEOUT)
        assert ok.values() == [True, False]
        assert wait_until(lambda: bridge.stats.errors == 1 and bridge.stats.unparseable == 1, TIMEOUT)


class _Process:
    """A ``dbglog bridge`` subprocess whose output lines are collected by a thread."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "dbglog", "bridge", *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line)

    def output(self) -> str:
        return "".join(self.lines)

    def stop(self, signum: int) -> int:
        self.proc.send_signal(signum)
        try:
            code = self.proc.wait(timeout=TIMEOUT)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait(timeout=TIMEOUT)
            self._reader.join(timeout=5)
            assert self.proc.stdout is not None
            self.proc.stdout.close()
        return code


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_cli_bridge_runs_until_signalled_and_exits_cleanly(
    tmp_path: Path, peers: tuple[RosPeer, RosPeer, RosPeer], signum: int
) -> None:
    """`dbglog bridge RULES.yaml` publishes typed values from real /rosout and exits 0 on SIGINT/SIGTERM."""
    robot, _camera, viewer = peers
    rules = tmp_path / "rules.yaml"
    rules.write_text(RULES, encoding="utf-8")
    bridge = _Process(str(rules), "--name", "cli_bridge", "--state-dir", str(tmp_path / "state"))
    try:
        assert wait_until(lambda: "bridge: running" in bridge.output(), TIMEOUT), bridge.output()
        probes = viewer.subscribe("/rosdashboard/t/probe", Int64, LATCHED)
        speed = viewer.subscribe("/rosdashboard/t/speed", Float64, LATCHED)
        x = viewer.subscribe("/rosdashboard/t/pose/x", Float64, LATCHED)
        _probe(robot, probes, 10)
        robot.node.get_logger().info("speed 0.75 m/s")
        robot.node.get_logger().warning("pose x=4 y=5")
        assert speed.wait_for(1, TIMEOUT)
        assert x.wait_for(1, TIMEOUT)
        assert speed.values() == [0.75]
        assert x.values() == [4.0]
    finally:
        code = bridge.stop(signum)
    assert code == 0, bridge.output()
    assert "stopped after" in bridge.output()
    assert "Traceback" not in bridge.output()


def test_cli_check_accepts_a_good_file_and_lists_its_topics(tmp_path: Path) -> None:
    """`--check` on a valid file exits 0 and names every output topic with its type."""
    rules = tmp_path / "rules.yaml"
    rules.write_text(RULES, encoding="utf-8")
    done = _run_check(rules)
    assert done.returncode == 0, done.stderr
    assert "OK, 6 rules, 7 topics" in done.stdout
    assert "/rosdashboard/t/pose/y (float)" in done.stdout
    assert "/rosdashboard/t/ok (bool)" in done.stdout


def test_cli_check_lists_topics_in_the_bridges_namespace(tmp_path: Path) -> None:
    """`--namespace robot1` puts the topics in /robot1 ('namespace: node' ones say so); a bad one exits 2."""
    rules = tmp_path / "rules.yaml"
    rules.write_text(ROBOT_RULES, encoding="utf-8")
    done = _run_check(rules, "--namespace", "robot1")
    assert done.returncode == 0, done.stderr
    assert "  /robot1/rosdashboard/rb/fixed (int)" in done.stdout
    assert "  /robot7/rosdashboard/rb/here (int)" in done.stdout
    assert "  <the line's node namespace>/rosdashboard/__901f___5ea6_ (float)" in done.stdout
    bad = _run_check(rules, "--namespace", "9lives")
    assert bad.returncode == 2
    assert "--namespace: robot namespace '9lives'" in bad.stderr


def test_cli_check_rejects_a_bad_file_printing_every_problem(tmp_path: Path) -> None:
    """`--check` on a broken file exits non-zero and prints each problem with its line and tag."""
    rules = tmp_path / "bad.yaml"
    rules.write_text(
        "rules:\n"
        "  - tag: a\n"
        "    pattern: '(a)\\1'\n"
        "  - tag: b\n"
        "    pattern: 'x=(\\d+)'\n"
        "    level: loud\n"
        "  - tag: c\n"
        "    pattern: '(\\d+) (\\d+)'\n",
        encoding="utf-8",
    )
    done = _run_check(rules)
    assert done.returncode == 2
    assert "3 problems" in done.stderr
    assert "bad.yaml:3: rule #1, tag 'a': pattern '(a)\\1' does not compile" in done.stderr
    assert "bad.yaml:6: rule #2, tag 'b': unknown level 'loud'" in done.stderr
    assert "bad.yaml:8: rule #3, tag 'c':" in done.stderr
    assert "unnamed" in done.stderr
    assert "Traceback" not in done.stderr


def test_cli_check_reports_a_duplicate_topic_next_to_the_rules_other_problems(tmp_path: Path) -> None:
    """`--check` lists a rule's duplicate topic even when the rule has other errors, and all of those."""
    rules = tmp_path / "dup.yaml"
    rules.write_text(
        "rules:\n"
        "  - tag: power\n"
        "    pattern: 'battery=(?P<percent>\\d+)% (?P<volts>\\S+) V'\n"
        "    type: {percent: int, volts: float}\n"
        "  - tag: power/percent\n"
        "    level: loud\n"
        "    pattern: 'pct=(\\d+)'\n"
        "    type: decimal\n",
        encoding="utf-8",
    )
    done = _run_check(rules)
    assert done.returncode == 2, done.stdout
    assert "3 problems" in done.stderr, done.stderr
    assert "dup.yaml:5: rule #2, tag 'power/percent': publishes to /rosdashboard/power/percent" in done.stderr
    assert "dup.yaml:6: rule #2, tag 'power/percent': unknown level 'loud'" in done.stderr
    assert "dup.yaml:8: rule #2, tag 'power/percent': unknown type 'decimal'" in done.stderr
    # With the second rule gone the file is valid, each group with its own type.
    rules.write_text("\n".join(rules.read_text(encoding="utf-8").splitlines()[:4]) + "\n", encoding="utf-8")
    done = _run_check(rules)
    assert done.returncode == 0, done.stderr
    assert "/rosdashboard/power/percent (int)" in done.stdout
    assert "/rosdashboard/power/volts (float)" in done.stdout


def test_cli_error_for_a_100_kb_pattern_is_short(tmp_path: Path) -> None:
    """A broken 100 KB pattern is quoted by its start and length: the whole error stays under 1 KB."""
    rules = tmp_path / "huge.yaml"
    rules.write_text("rules:\n  - tag: huge\n    pattern: '(" + "a" * 100_000 + "'\n", encoding="utf-8")
    done = _run_check(rules)
    assert done.returncode == 2
    assert len(done.stderr) < 1_000, done.stderr[:2_000]
    assert "huge.yaml:3: rule #1, tag 'huge': pattern '(aaaa" in done.stderr
    assert "… (100001 chars) does not compile with RE2: missing ): (aaaa" in done.stderr


def _run_check(path: Path, *options: str) -> subprocess.CompletedProcess[Any]:
    return subprocess.run(
        [sys.executable, "-m", "dbglog", "bridge", "--check", str(path), *options],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


# ------------------------------------------------------------- lines written before the bridge hears them

HISTORY_RULES = r"""
rules:
  - tag: boot/seq
    type: int
    pattern: 'boot seq=(\d+)'
  - tag: boot/power
    pattern: 'battery=(?P<percent>\d+)% (?P<volts>\S+) V'
    type: {percent: int}
"""

# A node as users write them: rclpy's own logger, lines logged right after the node exists (so before any
# subscriber can have discovered its /rosout writer); then one line per line of stdin; alive until EOF.
NODE_SCRIPT = r"""
import sys

import rclpy
from rclpy.node import Node

rclpy.init()
node = Node(sys.argv[1])
log = node.get_logger()
for line in sys.argv[2:]:
    log.info(line)
print("logged", flush=True)
for line in sys.stdin:
    log.info(line.rstrip("\n"))
    print("logged", flush=True)
node.destroy_node()
rclpy.shutdown()
"""

DEEP_LATCHED = QoSProfile(
    depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)


class _Node:
    """A separate process running an rclpy node that logs the given lines at once, then what it is sent."""

    def __init__(self, name: str, lines: list[str]) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-c", NODE_SCRIPT, name, *lines],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )

    def wait_logged(self) -> None:
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        assert line == "logged\n", f"the node process said {line!r} (exit code {self.proc.poll()})"

    def log(self, line: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        self.wait_logged()

    def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        try:
            self.proc.wait(timeout=TIMEOUT)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait(timeout=TIMEOUT)
            if self.proc.stdout is not None:
                self.proc.stdout.close()


def _boot_lines(base: int, count: int) -> list[str]:
    return [f"boot seq={base + i}" for i in range(count)]


def _settled(collector: Collector, want: int) -> list[Any]:
    """Wait for `want` values, then a little longer (any duplicate would come now); return them all."""
    assert collector.wait_for(want, TIMEOUT), f"{len(collector.values())} of {want} values arrived"
    wait_until(lambda: len(collector.values()) > want, timeout=1.5)
    return collector.values()


def test_bridge_already_running_gets_every_first_line_of_nodes_starting_together(tmp_path: Path) -> None:
    """Eight nodes start together and log 30 lines each at once: a running bridge publishes all, once each."""
    rules = tmp_path / "rules.yaml"
    rules.write_text(HISTORY_RULES, encoding="utf-8")
    with RosPeer("viewer") as viewer:
        seqs = viewer.subscribe("/rosdashboard/boot/seq", Int64, DEEP_LATCHED)
        bridge = _Process(str(rules), "--name", "bridge_first_lines", "--state-dir", str(tmp_path / "state"))
        nodes: list[_Node] = []
        try:
            assert wait_until(lambda: "bridge: running" in bridge.output(), TIMEOUT), bridge.output()
            assert wait_until(lambda: viewer.node.count_publishers("/rosdashboard/boot/seq") == 1, TIMEOUT)
            nodes = [_Node(f"starting_node_{k}", _boot_lines(1000 * k, 30)) for k in range(8)]
            for node in nodes:
                node.wait_logged()
            values = _settled(seqs, 240)
        finally:
            for node in nodes:
                node.close()
            code = bridge.stop(signal.SIGINT)
    assert sorted(values) == [1000 * k + i for k in range(8) for i in range(30)]
    assert code == 0, bridge.output()
    assert "0 duplicates skipped, 0 errors" in bridge.output()


def test_bridge_started_late_gets_the_startup_lines_and_a_restart_does_not_repeat_them(
    tmp_path: Path,
) -> None:
    """A bridge started 2 s late gets all 20 startup lines; restarted, it skips what it already published."""
    rules = tmp_path / "rules.yaml"
    rules.write_text(HISTORY_RULES, encoding="utf-8")
    state = ["--name", "bridge_late", "--state-dir", str(tmp_path / "state")]
    with RosPeer("viewer") as viewer:
        seqs = viewer.subscribe("/rosdashboard/boot/seq", Int64, DEEP_LATCHED)
        percent = viewer.subscribe("/rosdashboard/boot/power/percent", Int64, DEEP_LATCHED)
        volts = viewer.subscribe("/rosdashboard/boot/power/volts", Float64, DEEP_LATCHED)
        node = _Node("early_node", [*_boot_lines(0, 20), "battery=87% 12.5 V"])
        bridges: list[_Process] = []
        try:
            node.wait_logged()
            time.sleep(2.0)  # the scenario itself: the bridge starts 2 s after the node's lines
            bridges.append(_Process(str(rules), *state))
            assert _settled(seqs, 20) == list(range(20))
            assert percent.wait_for(1, TIMEOUT)
            assert volts.wait_for(1, TIMEOUT)
            assert (percent.values(), volts.values()) == ([87], [12.5])
            for line in _boot_lines(20, 5):  # fresh lines: in /rosout's history for the next 10 s
                node.log(line)
            assert _settled(seqs, 25) == list(range(25))
            assert bridges[0].stop(signal.SIGINT) == 0, bridges[0].output()
            assert "27 values published, 0 unparseable, 0 duplicates skipped" in bridges[0].output()

            # Restarted at once, within the history's 10 s: what comes again is skipped, the rest published.
            bridges.append(_Process(str(rules), *state))
            assert wait_until(lambda: "bridge: running" in bridges[1].output(), TIMEOUT), bridges[1].output()
            for line in _boot_lines(25, 5):
                node.log(line)
            assert _settled(seqs, 30) == list(range(30))
            assert percent.values() == [87]
            assert bridges[1].stop(signal.SIGINT) == 0, bridges[1].output()
            assert _summary(bridges[1])[0] == 5, bridges[1].output()
            assert _summary(bridges[1])[1] >= 5, bridges[1].output()  # at least seq 20-24 came again

            # Without the state file, the same restart publishes the history a second time.
            bridges.append(_Process(str(rules), "--name", "bridge_late", "--no-state"))
            assert wait_until(lambda: "bridge: running" in bridges[2].output(), TIMEOUT), bridges[2].output()
            node.log("boot seq=30")
            assert wait_until(lambda: 30 in seqs.values(), TIMEOUT)
            again = seqs.values()[30:]
            assert again[-1] == 30
            assert set(range(25, 30)) <= set(again), again
        finally:
            node.close()
            for bridge in bridges:
                if bridge.proc.poll() is None:
                    bridge.stop(signal.SIGINT)
    assert all("Traceback" not in b.output() for b in bridges)


def _summary(bridge: _Process) -> tuple[int, int]:
    """The values published and duplicates skipped of a stopped bridge's summary line."""
    found = re.search(r"(\d+) values published, \d+ unparseable, (\d+) duplicates skipped", bridge.output())
    assert found is not None, bridge.output()
    return int(found.group(1)), int(found.group(2))


def test_a_log_line_delivered_twice_is_published_once(peers: tuple[RosPeer, RosPeer, RosPeer]) -> None:
    """The same Log (logger, stamp, text) from two /rosout writers, e.g. a relay, gives one value."""
    robot, camera, viewer = peers
    with Bridge(parse_rules(HISTORY_RULES), node_name="bridge_dedup") as bridge:
        seqs = viewer.subscribe("/rosdashboard/boot/seq", Int64, DEEP_LATCHED)
        writers = [peer.publisher("/rosout", Log, DEEP_LATCHED) for peer in (robot, camera)]
        for writer in writers:
            assert robot.wait_for_subscribers(writer, timeout=TIMEOUT)
        stamp = robot.node.get_clock().now().to_msg()
        for seq in range(5):
            line = Log(stamp=stamp, level=Log.INFO, name="relayed", msg=f"boot seq={seq}")
            for writer in writers:
                writer.publish(line)
        # A line that differs only in its stamp is another line: published.
        line = Log(level=Log.INFO, name="relayed", msg="boot seq=4")
        line.stamp.sec, line.stamp.nanosec = stamp.sec + 1, stamp.nanosec
        writers[0].publish(line)
        assert _settled(seqs, 6) == [0, 1, 2, 3, 4, 4]
        assert wait_until(lambda: bridge.stats.duplicates == 5, TIMEOUT), bridge.stats
        assert bridge.stats.values == 6


ROBOT_RULES = r"""
rules:
  - tag: 速度
    namespace: node
    pattern: 'rbspeed (\S+)'
  - tag: rb/fixed
    type: int
    pattern: 'rbfixed=(\d+)'
  - tag: rb/here
    namespace: /robot7
    type: int
    pattern: 'rbhere=(\d+)'
"""


def test_bridge_in_a_namespace_and_rules_that_follow_the_lines_node() -> None:
    """--namespace puts the bridge and its topics in /lab; 'namespace: node' publishes each robot's line
    under that robot's namespace (an escaped tag too; a child logger's under its node's; a logger of no
    node on the graph by its dotted name); a rule's own namespace wins."""
    with (
        RosPeer("ctrl", "/robot1") as one,
        RosPeer("ctrl", "/robot2") as two,
        RosPeer("rb_viewer") as viewer,
        Bridge(parse_rules(ROBOT_RULES, namespace="/lab"), node_name="bridge_rb", namespace="/lab") as bridge,
    ):
        assert wait_until(
            lambda: ("bridge_rb", "/lab") in viewer.node.get_node_names_and_namespaces(), TIMEOUT
        )
        fixed = viewer.subscribe("/lab/rosdashboard/rb/fixed", Int64, LATCHED)
        here = viewer.subscribe("/robot7/rosdashboard/rb/here", Int64, LATCHED)
        speeds = {
            ns: viewer.subscribe(f"{ns}/rosdashboard/__901f___5ea6_", Float64, LATCHED)
            for ns in ("/robot1", "/robot2")
        }
        for _ in range(int(TIMEOUT / 0.2)):  # until discovery is done both ways
            one.node.get_logger().info("rbfixed=1")
            if wait_until(lambda: bool(fixed.values()), timeout=0.2):
                break
        one.node.get_logger().info("rbhere=7")
        for _ in range(int(TIMEOUT / 0.5)):
            one.node.get_logger().info("rbspeed 1.5")
            two.node.get_logger().info("rbspeed 2.5")
            two.node.get_logger().get_child("sub").info("rbspeed 2.5")  # a child logger: its node's namespace
            if wait_until(lambda: all(c.values() for c in speeds.values()), timeout=0.5):
                break
        # A logger no node on the graph has: after a moment's wait for discovery, its dotted name decides.
        ghost = viewer.subscribe("/robot3/rosdashboard/__901f___5ea6_", Float64, LATCHED)
        lines = viewer.publisher(ROSOUT, Log, LATCHED)
        lines.publish(Log(name="robot3.ghost", level=Log.INFO, msg="rbspeed 3.5"))
        assert ghost.wait_for(1, TIMEOUT)
        assert ghost.values() == [3.5]
        assert here.wait_for(1, TIMEOUT)
        assert set(speeds["/robot1"].values()) == {1.5}
        assert set(speeds["/robot2"].values()) == {2.5}
        assert set(fixed.values()) == {1}
        assert "/lab/rosdashboard/__901f___5ea6_" not in bridge.topics
        assert not [n for n in bridge.topics if n.startswith("/robot2/ctrl")]


def test_state_file_round_trips_and_stale_or_broken_files_are_refused(tmp_path: Path) -> None:
    """What a bridge saves is read back while young; an old file is ignored, a broken one named as such."""
    saved = _Published(DEDUP_WINDOW)
    saved.now.add((b"a" * 16, "/rosdashboard/x"))
    saved.before.add((b"b" * 16, "/rosdashboard/y"))
    path = tmp_path / "deep" / "state.json"
    saved.save(path)
    assert path.parent.stat().st_mode & 0o777 == 0o700
    loaded = _Published(DEDUP_WINDOW)
    assert loaded.load(path) == 2
    assert loaded.before == saved.now | saved.before
    assert _Published(DEDUP_WINDOW).load(tmp_path / "missing.json") == 0

    doc = json.loads(path.read_text(encoding="utf-8"))
    doc["saved"] -= DEDUP_WINDOW + 1  # older than /rosout's history: nothing in it can come back
    path.write_text(json.dumps(doc), encoding="utf-8")
    assert _Published(DEDUP_WINDOW).load(path) == 0

    for text, reason in [
        ("{", "not JSON"),
        ('{"format": "x"}', "not a bridge state file"),
        ('{"format": "dbglog-bridge-published", "version": 9}', "version 9"),
        ('{"format": "dbglog-bridge-published", "version": 1, "saved": 1e18, "topics": {}}', ""),
        (json.dumps({**doc, "saved": time.time(), "topics": {"/t": "%%%"}}), "not base64"),
        (json.dumps({**doc, "saved": time.time(), "topics": {"/t": "YWJj"}}), "16-byte digests"),
    ]:
        path.write_text(text, encoding="utf-8")
        if not reason:  # saved in the future (clock change): ignored, like a stale file
            assert _Published(DEDUP_WINDOW).load(path) == 0
            continue
        with pytest.raises(ValueError, match=reason):
            _Published(DEDUP_WINDOW).load(path)


def test_bridge_with_a_broken_state_file_warns_runs_and_rewrites_it(
    tmp_path: Path, peers: tuple[RosPeer, RosPeer, RosPeer]
) -> None:
    """A state file that cannot be read is named in a warning on /rosout; the bridge runs and saves anew."""
    robot, _camera, viewer = peers
    warnings = viewer.subscribe("/rosout", Log, DEEP_LATCHED)
    with Bridge(parse_rules(RULES), node_name="bridge_state", state_dir=tmp_path) as bridge:
        path = bridge.state_file
    assert path is not None
    assert path.name.startswith("bridge_state-domain")
    assert json.loads(path.read_text(encoding="utf-8"))["format"] == "dbglog-bridge-published"
    path.write_bytes(b"\xff not a state file")
    with Bridge(parse_rules(RULES), node_name="bridge_state", state_dir=tmp_path) as bridge:
        probes = viewer.subscribe("/rosdashboard/t/probe", Int64, LATCHED)
        _probe(robot, probes, 7)
        assert wait_until(
            lambda: any(
                m.name == "bridge_state" and f"ignoring the state file {path} (not UTF-8" in m.msg
                for m in warnings.messages
            ),
            TIMEOUT,
        )
    assert json.loads(path.read_text(encoding="utf-8"))["topics"]["/rosdashboard/t/probe"]


def test_a_reader_waiting_for_a_bridged_tag_gets_every_value_from_the_first_line(tmp_path: Path) -> None:
    """Echo waits on a bridged tag; a node logs 300 lines as the bridge starts: echo prints all 300."""
    tag = f"first_{os.getpid()}/seq"
    rules = tmp_path / "rules.yaml"
    rules.write_text(f"rules:\n  - tag: {tag}\n    type: int\n    pattern: 'first seq=(\\d+)'\n", "utf-8")
    echo_cmd = [sys.executable, "-m", "dbglog", "echo", tag, "--count", "300", "--timeout", "30"]
    with subprocess.Popen(echo_cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as echo:
        node: _Node | None = None
        bridge: _Process | None = None
        try:
            with RosPeer("first_watch") as watch:  # echo is up before the node and the bridge start
                assert wait_until(lambda: "dbglog_echo" in watch.node.get_node_names(), TIMEOUT), (
                    watch.node.get_node_names()
                )
            node = _Node("first_lines", [f"first seq={k}" for k in range(300)])
            bridge = _Process(str(rules), "--name", "bridge_first_reader", "--no-state")
            node.wait_logged()
            printed, err = echo.communicate(timeout=60)
        finally:
            if echo.poll() is None:
                echo.kill()
            if node is not None:
                node.close()
            if bridge is not None:
                bridge.stop(signal.SIGINT)
    assert echo.returncode == 0, err
    assert [int(v) for v in printed.split()] == list(range(300))
