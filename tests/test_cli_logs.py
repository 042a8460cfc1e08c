"""``dbglog logs`` as a real subprocess reading /rosout from real rclpy loggers in three other processes."""

from __future__ import annotations

import json
import os
import pty
import select
import signal
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

from dbglog.viewer._cli._cli_logs import LogLine, format_line
from tests._ros import RosPeer, wait_until

_LOGGER_SCRIPT = """
import json, sys
import rclpy
from rclpy.node import Node

rclpy.init()
nodes = {}
# One call site per level: rclpy refuses one call site logging at several severities.
LOG = {
    "debug": lambda lg, t: lg.debug(t),
    "info": lambda lg, t: lg.info(t),
    "warn": lambda lg, t: lg.warning(t),
    "error": lambda lg, t: lg.error(t),
    "fatal": lambda lg, t: lg.fatal(t),
}
for name in sys.argv[1:]:
    nodes[name] = Node(name)
    nodes[name].get_logger().set_level(10)
print("READY", flush=True)
for raw in sys.stdin:
    batch = json.loads(raw)
    for name, level, text in batch:
        LOG[level](nodes[name].get_logger(), text)
    print("LOGGED", len(batch), flush=True)
"""


class Logger:
    """A process with real rclpy nodes that log what they are told (their /rosout keeps it 10 s)."""

    def __init__(self, script: Path, *nodes: str) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, str(script), *nodes],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert self._reply(30.0) == "READY"

    def _reply(self, timeout: float) -> str:
        assert self.proc.stdout is not None
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if line:
                return line.strip()
            if self.proc.poll() is not None:
                break
        raise AssertionError(f"logger process gave no reply (exit {self.proc.poll()})")

    def log(self, *lines: tuple[str, str, str]) -> None:
        """Log `lines` (node, level, text) and wait until they are written."""
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps(lines) + "\n")
        self.proc.stdin.flush()
        assert self._reply(10.0) == f"LOGGED {len(lines)}"

    def close(self) -> None:
        """Stop the process."""
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        if self.proc.stdout is not None:
            self.proc.stdout.close()


@pytest.fixture(scope="module")
def loggers(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Logger, Logger, Logger]]:
    """Three logging processes: talker; planner_local and planner_global; driver."""
    script = tmp_path_factory.mktemp("logs") / "logger.py"
    script.write_text(_LOGGER_SCRIPT)
    started = [
        Logger(script, "talker"),
        Logger(script, "planner_local", "planner_global"),
        Logger(script, "driver"),
    ]
    try:
        yield started[0], started[1], started[2]
    finally:
        for logger in started:
            logger.close()


def _log_batch(loggers: tuple[Logger, Logger, Logger], token: str) -> None:
    """Every node logs a line at several levels, each marked with `token`."""
    talker, planners, driver = loggers
    talker.log(("talker", "debug", f"{token} t-debug"), ("talker", "info", f"{token} t-info speed=1.5"))
    planners.log(
        ("planner_local", "warn", f"{token} pl-warn speed=2.5"),
        ("planner_global", "info", f"{token} pg-info"),
        ("planner_global", "error", f"{token} pg-error"),
    )
    driver.log(("driver", "fatal", f"{token} d-fatal"), ("driver", "info", f"{token} d-info speed=9"))


def _logs(*args: str, timeout: float = 40.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "dbglog", "logs", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


@pytest.fixture(scope="module")
def watcher() -> Iterator[RosPeer]:
    """A ROS participant that watches the graph for `dbglog logs`' subscription."""
    with RosPeer("logs_watcher") as peer:
        yield peer


def _subscribed(peer: RosPeer) -> bool:
    infos = peer.node.get_subscriptions_info_by_topic("/rosout")
    return any(info.node_name == "dbglog_logs" for info in infos)


def _logs_then_batch(
    loggers: tuple[Logger, Logger, Logger],
    watcher: RosPeer,
    token: str,
    *args: str,
    stdout: int | None = None,
) -> tuple[int, str]:
    """Start `dbglog logs ARGS`, log a batch once it has subscribed, return its exit code and stdout.

    Logging after the subscription exists keeps these tests independent of how long the CLI takes to
    start (lines older than /rosout's 10 s lifespan would be gone).
    """
    proc = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "logs", *args],
        stdout=subprocess.PIPE if stdout is None else stdout,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert wait_until(lambda: _subscribed(watcher), timeout=40), "dbglog logs never subscribed to /rosout"
        _log_batch(loggers, token)
        out, err = proc.communicate(timeout=40)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    return proc.returncode, out or ""


def _messages(stdout: str, token: str) -> list[str]:
    return sorted(line.split(f"{token} ", 1)[1] for line in stdout.splitlines() if token in line)


def test_logs_prints_lines_logged_before_it_started_by_three_processes(
    loggers: tuple[Logger, Logger, Logger],
) -> None:
    """Lines written before `dbglog logs` started (still in /rosout's history) appear, from every process."""
    token = uuid.uuid4().hex[:8]
    _log_batch(loggers, token)
    done = _logs("--grep", token, "--count", "7")
    assert done.returncode == 0, done.stderr
    assert _messages(done.stdout, token) == sorted(
        [
            "t-debug",
            "t-info speed=1.5",
            "pl-warn speed=2.5",
            "pg-info",
            "pg-error",
            "d-fatal",
            "d-info speed=9",
        ]
    )
    lines = done.stdout.splitlines()
    assert "\x1b[" not in done.stdout  # piped: plain text
    assert any(" WARN  [planner_local] " in line for line in lines)
    assert any(" FATAL [driver] " in line for line in lines)


def test_logs_colours_lines_on_a_terminal(loggers: tuple[Logger, Logger, Logger], watcher: RosPeer) -> None:
    """On a terminal (a pseudo-terminal here) an error line is red; NO_COLOR turns colour off."""
    for no_color, expect_red in ((None, True), ("1", False)):
        token = uuid.uuid4().hex[:8]
        leader, follower = pty.openpty()
        saved = os.environ.pop("NO_COLOR", None)
        if no_color is not None:
            os.environ["NO_COLOR"] = no_color
        try:
            _logs_then_batch(
                loggers, watcher, token, "--grep", token, "--level", "error", "--count", "2", stdout=follower
            )
            os.close(follower)
            output = b""
            while select.select([leader], [], [], 0.2)[0]:
                try:
                    chunk = os.read(leader, 65536)
                except OSError:
                    break
                if not chunk:
                    break
                output += chunk
        finally:
            os.environ.pop("NO_COLOR", None)
            if saved is not None:
                os.environ["NO_COLOR"] = saved
            os.close(leader)
        text = output.decode()
        assert f"{token} pg-error" in text
        assert ("\x1b[31m" in text) is expect_red, text


def test_logs_filters_by_minimum_level(loggers: tuple[Logger, Logger, Logger], watcher: RosPeer) -> None:
    """--level warn shows warn, error and fatal lines only."""
    token = uuid.uuid4().hex[:8]
    _, out = _logs_then_batch(loggers, watcher, token, "--grep", token, "--level", "warn", "--count", "3")
    assert _messages(out, token) == ["d-fatal", "pg-error", "pl-warn speed=2.5"]


def test_logs_filters_by_node_glob(loggers: tuple[Logger, Logger, Logger], watcher: RosPeer) -> None:
    """--node 'planner*' shows both planners' lines and no other node's."""
    token = uuid.uuid4().hex[:8]
    _, out = _logs_then_batch(loggers, watcher, token, "--grep", token, "--node", "planner*", "--count", "3")
    assert _messages(out, token) == ["pg-error", "pg-info", "pl-warn speed=2.5"]


def test_logs_filters_by_re2_grep(loggers: tuple[Logger, Logger, Logger], watcher: RosPeer) -> None:
    """--grep keeps the lines whose message has a match of the RE2 pattern."""
    token = uuid.uuid4().hex[:8]
    _, out = _logs_then_batch(
        loggers, watcher, token, "--grep", rf"{token} .*speed=[0-9]+\.5", "--count", "2"
    )
    assert _messages(out, token) == ["pl-warn speed=2.5", "t-info speed=1.5"]


def test_logs_count_stops_after_n_lines(loggers: tuple[Logger, Logger, Logger], watcher: RosPeer) -> None:
    """--count 2 prints exactly two lines and exits 0."""
    token = uuid.uuid4().hex[:8]
    _, out = _logs_then_batch(loggers, watcher, token, "--grep", token, "--count", "2")
    assert len(out.splitlines()) == 2


def test_logs_since_zero_follows_new_lines_only(loggers: tuple[Logger, Logger, Logger]) -> None:
    """--since 0 skips the kept history and prints the lines logged after it started (following)."""
    token = uuid.uuid4().hex[:8]
    talker = loggers[0]
    talker.log(("talker", "info", f"{token} old"))
    proc = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "logs", "--grep", token, "--since", "0", "--count", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 40
        n = 0
        while proc.poll() is None and time.monotonic() < deadline:
            n += 1
            talker.log(("talker", "info", f"{token} new {n}"))
            time.sleep(0.3)
        out, err = proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    (message,) = _messages(out, token)
    assert message.startswith("new ")


def test_logs_follows_until_sigterm_and_exits_0(watcher: RosPeer) -> None:
    """Without --count it keeps following; SIGTERM stops it cleanly with exit 0."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "logs"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert wait_until(lambda: _subscribed(watcher), timeout=40)
        assert proc.poll() is None
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert err == ""


def test_logs_since_skips_lines_stamped_earlier() -> None:
    """--since 30 drops a kept line stamped two minutes ago but prints one stamped a second ago."""
    from rcl_interfaces.msg import Log
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    token = uuid.uuid4().hex[:8]
    qos = QoSProfile(
        depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
    )
    with RosPeer("stamped_writer") as peer:
        pub = peer.publisher("/rosout", Log, qos)
        now = time.time()
        for age, text in ((120.0, "two minutes ago"), (1.0, "a second ago")):
            msg = Log()
            stamp = now - age
            msg.stamp.sec, msg.stamp.nanosec = int(stamp), int((stamp % 1) * 1e9)
            msg.level, msg.name, msg.msg = 20, "stamped", f"{token} {text}"
            pub.publish(msg)
        done = _logs("--grep", token, "--since", "30", "--count", "1")
    assert done.returncode == 0, done.stderr
    assert _messages(done.stdout, token) == ["a second ago"]


def test_logs_bad_re2_is_a_clear_error() -> None:
    """A --grep RE2 cannot compile (or a lookaround) is exit 2 with RE2's reason."""
    done = _logs("--grep", "speed=(\\d+")
    assert done.returncode == 2
    assert "dbglog logs: --grep does not compile with RE2: missing ):" in done.stderr
    done = _logs("--grep", "(?=x)")
    assert done.returncode == 2
    assert "lookarounds are not supported" in done.stderr


def test_logs_bad_level_and_count_are_clear_errors() -> None:
    """An unknown --level or a negative --count is exit 2 naming the problem."""
    done = _logs("--level", "loud")
    assert done.returncode == 2
    assert "unknown level 'loud'" in done.stderr
    done = _logs("--count", "-1")
    assert done.returncode == 2
    assert "--count must be >= 0" in done.stderr


def test_format_line_colours_by_level_only_when_asked() -> None:
    """Warn is yellow, error red, fatal bold magenta; plain output has no escape codes."""
    line = LogLine(0.0, 40, "planner", "collision\nahead")
    assert format_line(line, colour=True).startswith("\x1b[31m")
    assert format_line(LogLine(0.0, 30, "p", "w"), colour=True).startswith("\x1b[33m")
    plain = format_line(line, colour=False)
    assert "\x1b" not in plain
    assert plain.endswith("ERROR [planner] collision\n    ahead")
