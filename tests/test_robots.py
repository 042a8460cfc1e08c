"""Robots plural: identical robot processes, each in its namespace (from a node, --ros-args or
DBGLOG_NAMESPACE), never mix; the viewer's engine, echo, tags and record find each robot's tags, and a
tag with non-ASCII text is echoed and listed as written."""

from __future__ import annotations

import functools
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from std_msgs.msg import Float64

from dbglog._ros._qos import tag_qos
from dbglog.record._inspect import tag_series
from dbglog.record._reader import read_recording
from dbglog.viewer._data._engine import Engine
from dbglog.viewer._data._model import Binding
from tests._children import ROOT, run_dbglog
from tests._ros import RosPeer, first_line, wait_until

TIMEOUT = 90
TAG = "rb/speed"
TEXT = "速度"

# One robot: the same program everywhere, told its namespace by `source` (as a lab would start it).
_ROBOT = """
import sys, time
import dbglog
source, namespace, value = sys.argv[1], sys.argv[2], float(sys.argv[3])
if source == "node":
    from rclpy.context import Context
    from rclpy.node import Node
    context = Context()
    context.init([])
    dbglog.init(node=Node("ctrl", namespace=namespace, context=context))
i = 0
while True:
    dbglog.logfloat("rb/speed", value)
    dbglog.logfloat("速度", value * 10)
    if i == 0:
        print("publishing", flush=True)
    i += 1
    time.sleep(0.05)
"""


def _start(source: str, namespace: str, value: float) -> subprocess.Popen[str]:
    """Start one robot whose namespace comes from `source`: node, args (--ros-args), env or none."""
    env = {k: v for k, v in os.environ.items() if k not in ("DBGLOG", "DBGLOG_STRICT", "DBGLOG_NAMESPACE")}
    env["PYTHONPATH"] = str(ROOT)
    argv = [sys.executable, "-c", _ROBOT, source, namespace, str(value)]
    if source == "args":
        argv += ["--ros-args", "-r", f"__ns:={namespace}"]
    elif source == "env":
        env["DBGLOG_NAMESPACE"] = namespace.lstrip("/")  # without its slash: normalized by dbglog
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    assert first_line(proc.stdout) == "publishing", "the robot process did not start"
    return proc


def _stop(procs: list[subprocess.Popen[str]]) -> None:
    for proc in procs:
        if proc.poll() is None:
            proc.send_signal(signal.SIGKILL)
        proc.wait(10)
        if proc.stdout is not None:
            proc.stdout.close()


@pytest.fixture
def robots() -> Iterator[Callable[[str, str, float], subprocess.Popen[str]]]:
    """Start robot processes on demand; kill them afterwards."""
    started: list[subprocess.Popen[str]] = []

    def start(source: str, namespace: str, value: float) -> subprocess.Popen[str]:
        started.append(_start(source, namespace, value))
        return started[-1]

    yield start
    _stop(started)


@pytest.mark.parametrize("source", ["node", "args", "env"])
def test_two_robots_publish_under_their_own_namespaces(
    source: str, robots: Callable[[str, str, float], subprocess.Popen[str]]
) -> None:
    """Two processes of one program, namespaces from `source`: each robot's tag, batch topic and (own)
    node are in its namespace; neither publishes on the root's /rosdashboard/rb/speed."""
    first, second = f"/rb_{source}_1", f"/rb_{source}_2"
    robots(source, first, 1.0)
    robots(source, second, 2.0)
    with RosPeer("robots_peer") as peer:
        got = {ns: peer.subscribe(f"{ns}/rosdashboard/{TAG}", Float64, tag_qos()) for ns in (first, second)}
        assert wait_until(lambda: all(len(c.messages) >= 5 for c in got.values()), 30)
        assert set(got[first].values()) == {1.0}
        assert set(got[second].values()) == {2.0}
        node = peer.node

        def namespaces(topic: str) -> list[str]:
            return [w.node_namespace for w in node.get_publishers_info_by_topic(topic)]

        for ns in (first, second):
            # A writer's node shows as _NODE_NAMESPACE_UNKNOWN_ until its participant's node list arrives.
            for topic in (f"{ns}/_dbglog/samples", f"{ns}/rosdashboard/{TAG}"):
                wait_until(
                    functools.partial(lambda t: "_NODE_NAMESPACE_UNKNOWN_" not in namespaces(t), topic), 10
                )
                assert namespaces(topic) == [ns], topic
        assert node.get_publishers_info_by_topic(f"/rosdashboard/{TAG}") == []


# --- a fleet for the tools: robot1 (DBGLOG_NAMESPACE), robot2 (--ros-args), and a robot in the root ---


@pytest.fixture(scope="module")
def fleet() -> Iterator[None]:
    """Three robots running the same program: /robot1 publishes 1.0, /robot2 2.0, the root 3.0."""
    procs = [_start("env", "/robot1", 1.0), _start("args", "/robot2", 2.0), _start("none", "", 3.0)]
    try:
        with RosPeer("fleet_probe") as peer:
            topics = [
                "/robot1/rosdashboard/rb/speed",
                "/robot2/rosdashboard/rb/speed",
                "/rosdashboard/rb/speed",
            ]
            got = [peer.subscribe(t, Float64, tag_qos()) for t in topics]
            assert wait_until(lambda: all(c.messages for c in got), 30), "the fleet is not up"
        yield
    finally:
        _stop(procs)


def _dbglog(*args: str) -> subprocess.CompletedProcess[str]:
    return run_dbglog(*args, timeout=TIMEOUT)


def test_the_engine_reads_each_robots_batches_apart(fleet: None) -> None:
    """The viewer's engine feeds each robot's tag from that robot's batch topic; no value crosses over."""
    bindings = {
        Binding("/robot1/rosdashboard/rb/speed"): 1.0,
        Binding("/robot2/rosdashboard/rb/speed"): 2.0,
        Binding("/rosdashboard/rb/speed"): 3.0,
        Binding("/robot1/rosdashboard/__901f___5ea6_"): 10.0,
    }
    with Engine(node_name="robots_engine") as engine:
        for binding in bindings:
            engine.bind(binding)
        assert wait_until(lambda: all(engine.snapshot(b).count >= 5 for b in bindings), 30)
        for binding, value in bindings.items():
            assert set(engine.snapshot(binding).values.tolist()) == {value}, binding
        covered = engine.batch_stats().covered
        assert {b.topic for b in bindings} <= set(covered)
        listed = {t.name: t for t in engine.topics()}
        robot2 = listed["/robot2/rosdashboard/rb/speed"]
        assert (robot2.robot, robot2.tag) == ("/robot2", "robot2:rb/speed")
        assert listed["/rosdashboard/__901f___5ea6_"].tag == TEXT


def _values(out: subprocess.CompletedProcess[str]) -> list[str]:
    assert out.returncode == 0, out.stderr
    return out.stdout.split()


def test_echo_takes_robot_and_non_ascii_tags(fleet: None) -> None:
    """echo robot2:rb/speed prints robot2's values only; echo 速度 and robot1:速度 find the escaped topics."""
    assert _values(_dbglog("echo", "robot2:rb/speed", "-n", "3", "--timeout", "30")) == ["2.0"] * 3
    assert _values(_dbglog("echo", "/robot1:rb/speed", "-n", "2", "--timeout", "30")) == ["1.0"] * 2
    assert _values(_dbglog("echo", TEXT, "-n", "2", "--timeout", "30")) == ["30.0"] * 2
    assert _values(_dbglog("echo", f"robot1:{TEXT}", "-n", "1", "--timeout", "30")) == ["10.0"]


def _rows(stdout: str) -> dict[tuple[str, str], list[str]]:
    """A `dbglog tags` table with a robot column as {(robot, tag): [type, ...]}."""
    lines = stdout.splitlines()
    assert lines[0].split()[:3] == ["robot", "tag", "type"], stdout
    return {(c[0], c[1]): c[2:] for c in (line.split() for line in lines[2:])}


def test_tags_lists_each_robot_and_the_text_as_logged(fleet: None) -> None:
    """dbglog tags shows a robot column and the tags as logged (速度), every robot's and the root's."""
    rows = _rows(_values_text(_dbglog("tags", "--wait", "20")))
    for key in [
        ("-", TAG),
        ("-", TEXT),
        ("robot1", TAG),
        ("robot1", TEXT),
        ("robot2", TAG),
        ("robot2", TEXT),
    ]:
        assert key in rows, (key, rows)
        assert rows[key][0] == "std_msgs/msg/Float64"
    assert rows[("robot2", TAG)][3] == "2"  # last value


def _values_text(out: subprocess.CompletedProcess[str]) -> str:
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_record_takes_one_robots_tag(fleet: None, tmp_path: Path) -> None:
    """record robot1:rb/speed writes robot1's tag (from its batches) and nothing of the other robots;
    tags FILE and echo --file read it back by the same name."""
    path = tmp_path / "robot1.mcap"
    out = _dbglog("record", "robot1:rb/speed", "-o", str(path), "--duration", "3")
    assert out.returncode == 0, out.stderr
    series = tag_series(read_recording(path))
    assert "robot1:rb/speed" in series
    assert all(tag.startswith("robot1:") for tag in series)  # robot1's batch topic holds its other tags too
    assert series["robot1:rb/speed"].topic == "/robot1/rosdashboard/rb/speed"
    values: Any = series["robot1:rb/speed"].values
    assert len(values) >= 10
    assert set(values.tolist()) == {1.0}
    assert "robot1:rb/speed" in _values_text(_dbglog("tags", str(path)))
    assert _values(_dbglog("echo", "robot1:rb/speed", "--file", str(path), "-n", "2")) == ["1.0"] * 2


def test_a_robot_starts_and_is_seen_within_seconds(fleet: None) -> None:
    """A robot added to a running fleet is listed by its namespace (the engine finds its batch topic)."""
    proc = _start("env", "/robot9", 9.0)
    try:
        with Engine(node_name="robots_late") as engine:
            binding = Binding("/robot9/rosdashboard/rb/speed")
            engine.bind(binding)
            started = time.monotonic()
            assert wait_until(lambda: engine.snapshot(binding).count >= 3, 30)
            assert time.monotonic() - started < 30
            assert set(engine.snapshot(binding).values.tolist()) == {9.0}
            assert binding.topic in engine.batch_stats().covered
    finally:
        _stop([proc])
