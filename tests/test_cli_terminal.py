"""``dbglog tags`` and ``dbglog echo`` as real subprocesses against a real publishing node."""

from __future__ import annotations

import argparse
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from geometry_msgs.msg import Twist
from std_msgs.msg import Bool, Float64, String

from dbglog._ros._qos import tag_qos
from dbglog.viewer._cli._cli_echo import _backlog, format_line, split_target
from dbglog.viewer._cli._cli_tags import format_rate, format_table, format_value
from dbglog.viewer._cli._cli_view import duration_arg
from dbglog.viewer._data._engine import matched_reason
from dbglog.viewer._data._model import Binding, SeriesSnapshot, Status, ValueKind
from tests._ros import RosPeer

TIMEOUT = 60


class _Robot:
    """The module's publishing node, and what to say of it when an echo gets nothing."""

    def __init__(self, peer: RosPeer) -> None:
        self.publishers = {
            "/rosdashboard/cli_proximity": peer.publisher("/rosdashboard/cli_proximity", Float64, tag_qos()),
            "/rosdashboard/cli_state": peer.publisher("/rosdashboard/cli_state", String, tag_qos()),
            "/rosdashboard/cli_bumper": peer.publisher("/rosdashboard/cli_bumper", Bool, tag_qos()),
            "/cli_turtle/cmd_vel": peer.publisher("/cli_turtle/cmd_vel", Twist),
        }
        self.silent = peer.publisher("/cli_silent", Float64)
        """A publisher that never publishes."""
        self.rounds = 0
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._loop, daemon=True)
        self.stop = threading.Event()

    def _loop(self) -> None:
        prox, state, bumper, cmd = self.publishers.values()
        try:
            while not self.stop.is_set():
                i = self.rounds
                prox.publish(Float64(data=0.25 + i))
                state.publish(String(data=f"mode=run step {i}"))
                bumper.publish(Bool(data=i % 2 == 0))
                twist = Twist()
                twist.linear.x, twist.angular.z = 0.5, -1.0
                cmd.publish(twist)
                self.rounds += 1
                time.sleep(0.05)
        except BaseException as exc:
            self.error = exc
            raise

    def state(self) -> str:
        """The loop's rounds, whether it runs, and how many subscriptions each publisher is matched with."""
        matched = {topic: pub.get_subscription_count() for topic, pub in self.publishers.items()}
        alive = "running" if self.thread.is_alive() else f"stopped ({self.error!r})"
        return f"the robot's loop: {self.rounds} rounds, {alive}; matched subscriptions {matched}"


@pytest.fixture(scope="module")
def robot() -> Iterator[_Robot]:
    """A node publishing three tags and a Twist topic at 20 Hz until the module ends."""
    with RosPeer("cli_robot") as peer:
        node = _Robot(peer)
        node.thread.start()
        yield node
        node.stop.set()
        node.thread.join()


def _dbglog(*args: str, timeout: float = TIMEOUT) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "dbglog", *args], capture_output=True, text=True, timeout=timeout, check=False
    )


def test_tags_prints_a_table_once(robot: _Robot) -> None:
    """`dbglog tags` lists each tag with type, rate, last value and live status, then exits 0."""
    out = _dbglog("tags")
    assert out.returncode == 0, out.stderr + robot.state()
    lines = out.stdout.splitlines()
    assert lines[0].split() == ["tag", "type", "rate", "last", "value", "status"]
    rows = {line.split()[0]: line for line in lines[2:]}
    assert {"cli_proximity", "cli_state", "cli_bumper"} <= set(rows)
    assert "std_msgs/msg/Float64" in rows["cli_proximity"]
    assert rows["cli_proximity"].rstrip().endswith("live")
    assert "Hz" in rows["cli_proximity"]
    assert "mode=run step" in rows["cli_state"]
    assert "true" in rows["cli_bumper"] or "false" in rows["cli_bumper"]
    assert "/cli_turtle/cmd_vel" not in out.stdout


def test_tags_all_lists_every_topic(robot: _Robot) -> None:
    """`dbglog tags --all` lists plain topics too, by full name."""
    out = _dbglog("tags", "--all")
    assert out.returncode == 0, out.stderr + robot.state()
    assert "/cli_turtle/cmd_vel" in out.stdout
    assert "geometry_msgs/msg/Twist" in out.stdout
    assert "/rosdashboard/cli_proximity" in out.stdout


def test_tags_watch_refreshes_until_interrupted(robot: _Robot) -> None:
    """`dbglog tags --watch` prints the table again and again."""
    with subprocess.Popen(
        [sys.executable, "-m", "dbglog", "tags", "--watch", "--wait", "2", "--interval", "0.3"],
        stdout=subprocess.PIPE,
        text=True,
    ) as proc:
        assert proc.stdout is not None
        tables = 0
        try:
            deadline = time.monotonic() + TIMEOUT
            while tables < 3 and time.monotonic() < deadline:
                line = proc.stdout.readline()
                tables += line.startswith("tag ")
        finally:
            proc.terminate()
            proc.wait(10)
    assert tables >= 3


def test_echo_a_tag_prints_count_values(robot: _Robot) -> None:
    """`dbglog echo TAG --count 3` prints three numbers, one per line, and exits 0."""
    out = _dbglog("echo", "cli_proximity", "--count", "3", "--timeout", "20")
    assert out.returncode == 0, out.stderr + robot.state()
    values = [float(v) for v in out.stdout.split()]
    assert len(values) == 3
    assert all(v % 1 == 0.25 for v in values)


def test_echo_topic_field_and_rqt_style(robot: _Robot) -> None:
    """A topic with a dotted field path, or with slashes rqt-style, prints that field."""
    dotted = _dbglog("echo", "/cli_turtle/cmd_vel.linear.x", "-n", "2", "--timeout", "20")
    assert dotted.returncode == 0, dotted.stderr + robot.state()
    assert dotted.stdout.split() == ["0.5", "0.5"]
    slashed = _dbglog("echo", "/cli_turtle/cmd_vel/angular/z", "-n", "1", "--timeout", "20")
    assert slashed.returncode == 0, slashed.stderr + robot.state()
    assert slashed.stdout.split() == ["-1.0"]


def test_echo_regex_on_a_text_tag(robot: _Robot) -> None:
    """--regex turns a text tag's capture group into numbers."""
    out = _dbglog("echo", "cli_state", "--regex", r"step (\d+)", "-n", "2", "--timeout", "20")
    assert out.returncode == 0, out.stderr + robot.state()
    first, second = (float(v) for v in out.stdout.split())
    assert second >= first


def test_echo_missing_topic_times_out_saying_why(robot: _Robot) -> None:
    """A topic that does not exist makes --timeout exit 1 with the reason on stderr."""
    out = _dbglog("echo", "/cli_no_such_topic", "--timeout", "2")
    assert out.returncode == 1
    assert out.stdout == ""
    assert "/cli_no_such_topic does not exist on the ROS graph" in out.stderr


def test_echo_of_a_silent_publisher_says_it_is_matched(robot: _Robot) -> None:
    """A topic whose publisher never publishes: echo times out saying DDS matched it with that publisher,
    so the silence is the publisher's (not discovery's, nor an incompatible QoS)."""
    out = _dbglog("echo", "/cli_silent", "--timeout", "15")
    assert out.returncode == 1
    assert out.stdout == ""
    assert "subscribed and matched with its publisher; no message yet" in out.stderr, out.stderr


def test_echo_bad_field_exits_with_the_reason(robot: _Robot) -> None:
    """A field that is not in the type exits 1 naming the fields that exist."""
    out = _dbglog("echo", "/cli_turtle/cmd_vel.linear.w", "--timeout", "20")
    assert out.returncode == 1
    assert "'w' is not in geometry_msgs/msg/Vector3" in out.stderr


def test_split_target_rules() -> None:
    """Tags map to their topics (escaped, in a robot's namespace); a dot in a tag or slashes in a topic
    need the graph to tell where the topic ends."""
    assert split_target("proximity", set()) == ("/rosdashboard/proximity", "")
    assert split_target("pose.x", set()) is None  # the tag 'pose.x', or 'pose' and its field x?
    assert split_target("pose.x", {"/rosdashboard/pose"}) == ("/rosdashboard/pose", "x")
    assert split_target("v1.2", {"/rosdashboard/v1__2e_2"}) == ("/rosdashboard/v1__2e_2", "")
    assert split_target("速度", set()) == ("/rosdashboard/__901f___5ea6_", "")
    assert split_target("robot1:speed", set()) == ("/robot1/rosdashboard/speed", "")
    assert split_target("/robot1:pose.x", {"/robot1/rosdashboard/pose"}) == ("/robot1/rosdashboard/pose", "x")
    assert split_target(":a:b", set()) == ("/rosdashboard/a__3a_b", "")
    assert split_target("/scan.ranges[3]", set()) == ("/scan", "ranges[3]")
    assert split_target("/scan", {"/scan"}) == ("/scan", "")
    assert split_target("/turtle1/pose/x", set()) is None
    assert split_target("/turtle1/pose/x", {"/turtle1/pose"}) == ("/turtle1/pose", "x")
    assert split_target("/a/b/c/d", {"/a/b"}) == ("/a/b", "c.d")


def test_history_durations_take_days() -> None:
    """--history reads days as it reads hours; beyond 7 days it says the limit, not 'not a duration'."""
    assert duration_arg("2d") == 2 * 86400
    assert duration_arg("1d12h") == 1.5 * 86400
    assert duration_arg("7d") == 7 * 86400
    assert duration_arg("1h30m") == 5400
    with pytest.raises(argparse.ArgumentTypeError, match=r"outside 1 s\.\.7 days"):
        duration_arg("9d")
    with pytest.raises(argparse.ArgumentTypeError, match="not a duration"):
        duration_arg("2w")


def test_rates_show_three_significant_digits_alike() -> None:
    """Every rate has three significant digits, so 10 Hz never shows as both '10 Hz' and '10.0 Hz'."""
    assert [format_rate(r) for r in (9.996, 10.0, 10.04)] == ["10.0 Hz"] * 3
    assert [format_rate(r) for r in (0.5, 2.0, 19.84, 250.2, 1000.4, None)] == [
        "0.500 Hz",
        "2.00 Hz",
        "19.8 Hz",
        "250 Hz",
        "1000 Hz",
        "-",
    ]


def _arrived(times: list[float]) -> SeriesSnapshot:
    """A number series that received values with these source times (values 0, 1, ...)."""
    stamps = np.asarray(times, dtype=np.float64)
    values = np.arange(len(times), dtype=np.float64)
    return SeriesSnapshot(
        Binding("/rosdashboard/t"),
        Status.LIVE,
        kind=ValueKind.NUMBER,
        times=stamps,
        values=values,
        count=len(times),
    )


def test_echo_started_before_the_publisher_prints_every_value_from_its_first_call() -> None:
    """Echo waiting before the node starts prints every value that arrives late (discovery), not only the
    newest; a node already running gives the newest kept value, then what follows; --history gives all."""
    started = 1000.0
    # The node started 0.1 s after echo; discovery delivered its first 1.4 s at once, at 1001.5.
    late = _arrived([1000.1 + 0.001 * k for k in range(1400)])
    assert _backlog(late, since=1001.45, started=started, history=False) == 1400
    # A node already running: its kept history (before echo started), then values published since.
    kept = _arrived([990.0, 995.0, 999.5, 1000.2, 1001.0, 1001.46, 1001.47])
    assert _backlog(kept, since=1001.45, started=started, history=False) == 3  # 1001.0, then what followed
    assert _backlog(kept, since=1001.45, started=started, history=True) == 7
    assert _backlog(_arrived([]), since=1001.45, started=started, history=False) == 0


def test_matched_reason_says_how_far_discovery_got() -> None:
    """The waiting reason of a subscribed topic names how many of its publishers DDS matched."""
    assert "not matched with its publisher yet" in matched_reason(0, 1)
    assert "incompatible" in matched_reason(0, 2)
    assert matched_reason(1, 3) == "subscribed; no message yet (matched with 1 of its 3 publishers)"
    assert matched_reason(1, 1) == "subscribed and matched with its publisher; no message yet"
    assert matched_reason(3, 3) == "subscribed and matched with all 3 of its publishers; no message yet"


def test_formatting_helpers() -> None:
    """Values render compactly for tables and exactly for echo lines."""
    assert format_value(0.1 + 0.2) == "0.3"
    assert format_value(True) == "true"
    assert format_value(tuple(float(i) for i in range(10))) == "[0, 1, 2, 3, … (10 values)]"
    assert format_value("x" * 100, width=10) == "x" * 9 + "…"
    assert format_line(0.5) == "0.5"
    assert format_line(False, 12.5) == "12.500000 false"
    assert format_table(["a", "bb"], [["xyz", "1"]]).splitlines() == ["a    bb", "---  --", "xyz  1"]


def test_docs_show_dbglog_echo_not_ros2_topic() -> None:
    """The docs show `dbglog echo`/`dbglog tags`, never a `ros2 topic` command a PyPI install lacks."""
    root = Path(__file__).resolve().parent.parent
    for doc in [root / "README.md", *sorted((root / "docs").glob("*.md"))]:
        for number, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1):
            where = f"{doc.name}:{number}: {line}"
            assert not line.lstrip().startswith(("$ ros2 ", "ros2 ")), where
            if "ros2 topic" in line:
                assert "dbglog echo" in line or "needs a full ROS 2 install" in line, where


def test_tags_waits_for_discovery_only_as_long_as_the_census_needs(monkeypatch: pytest.MonkeyPatch) -> None:
    """Where discovery reaches this host only and the census counts every participant, `dbglog tags` gives
    discovery no least wait (it used to wait the 4 s horizon); it waits the horizon where it cannot count
    them (another host may answer), and always what --settle says. Settled needs every participant found
    (or the horizon passed), quiet polls, and a poll well after the discovery sockets last dropped data."""
    from dbglog._ros._census import Census
    from dbglog.viewer._cli._cli_tags import _Graph, _least_wait
    from dbglog.viewer._data._suggest import DISCOVERY_HORIZON_S

    default, settle = argparse.Namespace(settle=None), argparse.Namespace(settle=4.0)
    complete, missing = Census(local=3, found=3, dropped=0), Census(local=3, found=2, dropped=0)
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    assert _least_wait(default, complete) == 0.0
    assert _least_wait(default, missing) == 0.0  # found or not: `settled` waits for the missing one
    assert _least_wait(default, None) == DISCOVERY_HORIZON_S  # not Fast DDS, or no /proc
    assert _least_wait(settle, complete) == 4.0
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET")
    assert _least_wait(default, complete) == DISCOVERY_HORIZON_S
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

    graph = _Graph(started=0.0)
    topics: list[Any] = []
    for poll, now in enumerate((0.1, 0.35, 0.6, 0.85)):
        graph.watch(topics, complete, poll, now)
    assert graph.settled(default, complete, 0.85)  # quiet for 3 polls over 0.75 s, all found
    assert not graph.settled(default, missing, 0.85)  # one participant of this host not found yet
    assert graph.settled(default, missing, DISCOVERY_HORIZON_S)  # ... until the horizon
    assert not graph.settled(settle, complete, 0.85)  # --settle 4
    graph.watch(topics, Census(local=3, found=3, dropped=5), 4, 1.1)  # a socket dropped discovery data
    assert not graph.settled(default, complete, 1.1)
