"""Watches on real processes over real ROS: a script run by ``dbglog run``, an rclpy node with
``DBGLOG_WATCH=1``, the client API and the ``dbglog watch`` command."""

from __future__ import annotations

import functools
import itertools
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from dbglog.watch._protocol import ArmSpec
from dbglog.watch.client import Process, Sample, Watch, WatchClient, WatchError, WatchEvent, WatchSpec
from tests._children import stop_child
from tests._ros import wait_until
from tests._watch_targets import line_of

DATA = Path(__file__).resolve().parent / "data" / "watch"
LOOP, TALKER, SHORT = DATA / "loop.py", DATA / "talker.py", DATA / "short.py"
START_S = 60.0
"""How long a child may take to come up and be discovered on a loaded CI machine."""


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("DBGLOG_WATCH") and k != "DBGLOG"}
    env.update(extra)
    return env


class Child:
    """A watched program: its process, output file and stop file."""

    def __init__(self, argv: list[str], tmp: Path, name: str, env: dict[str, str]) -> None:
        self.out = tmp / f"{name}.out"
        self.stop = tmp / f"{name}.stop"
        self.proc = subprocess.Popen(
            [*argv, str(self.out), str(self.stop)] if name != "talker" else [*argv, str(self.stop)],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )

    def lines(self) -> list[dict[str, Any]]:
        """The JSON lines the program wrote so far."""
        if not self.out.exists():
            return []
        return [json.loads(line) for line in self.out.read_text().splitlines() if line.endswith("}")]

    def finish(self) -> tuple[int, str]:
        """Ask it to stop; return its exit status and stderr."""
        self.stop.touch()
        try:
            _out, err = self.proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            err = stop_child(self.proc, signal.SIGKILL)
        return self.proc.returncode, err


@pytest.fixture(scope="module")
def tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The module's folder."""
    return tmp_path_factory.mktemp("watch")


@pytest.fixture(scope="module")
def loop(tmp: Path) -> Iterator[Child]:
    """loop.py run by ``dbglog run`` for the whole module."""
    child = Child([sys.executable, "-m", "dbglog", "run", str(LOOP)], tmp, "loop", _env())
    yield child
    child.finish()


@pytest.fixture(scope="module")
def talker(tmp: Path) -> Iterator[Child]:
    """talker.py, an rclpy node that imports dbglog, with ``DBGLOG_WATCH=1``."""
    child = Child([sys.executable, str(TALKER)], tmp, "talker", _env(DBGLOG_WATCH="1"))
    yield child
    child.finish()


@pytest.fixture(scope="module")
def client(loop: Child, talker: Child) -> Iterator[WatchClient]:
    """A watcher that receives values, once both programs are watchable."""
    with WatchClient(values=True) as made:
        pids = {loop.proc.pid, talker.proc.pid}
        if not wait_until(lambda: pids <= {p.pid for p in made.processes()}, START_S):
            seen = made.processes()
            errs = {c.proc.pid: c.finish() for c in (loop, talker)}
            pytest.fail(f"not announced within {START_S:g} s: {seen}; the programs said {errs}")
        yield made


def _process(client: WatchClient, pid: int) -> Process:
    return next(p for p in client.processes() if p.pid == pid)


def _collect(
    watch: Watch, enough: int, timeout: float = 30.0, *, errors: int = 0
) -> tuple[list[Sample], list[WatchEvent]]:
    """Samples and events until `enough` samples and `errors` error events came (or `timeout`)."""
    samples: list[Sample] = []
    events: list[WatchEvent] = []

    def more() -> bool:
        samples.extend(watch.samples())
        events.extend(watch.events())
        return len(samples) >= enough and sum(e.kind == "error" for e in events) >= errors

    wait_until(more, timeout)
    return samples, events


def _wait_event(watch: Watch, found: Callable[[WatchEvent], bool], timeout: float = 30.0) -> list[WatchEvent]:
    """The watch's events until one is `found` (or `timeout`)."""
    events: list[WatchEvent] = []

    def seen() -> bool:
        events.extend(watch.events())
        return any(found(e) for e in events)

    wait_until(seen, timeout)
    return events


def _gone(event: WatchEvent, pid: int) -> bool:
    return event.state == "gone" and event.pid == pid


def _by_hit(samples: list[Sample]) -> list[dict[int, object]]:
    hits: dict[tuple[str, int], dict[int, object]] = {}
    for s in samples:
        hits.setdefault((s.agent, s.stamp_ns), {})[s.expr] = s.value if not s.key else {s.key: s.value}
    return [hits[k] for k in sorted(hits, key=lambda k: k[1])]


def _dbglog(*args: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    try:
        return subprocess.run(
            [sys.executable, "-m", "dbglog", *args],
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )
    except subprocess.TimeoutExpired as exc:
        raise AssertionError(f"dbglog {' '.join(args)} timed out: {exc.stdout!r} {exc.stderr!r}") from None


def test_processes_are_listed_with_their_nodes(client: WatchClient, loop: Child, talker: Child) -> None:
    """Both programs are listed: pid, host, program, the node's name; ``dbglog watch --list`` prints them."""
    script = _process(client, loop.proc.pid)
    node = _process(client, talker.proc.pid)
    assert script.program[0] == str(LOOP)
    assert wait_until(lambda: _process(client, talker.proc.pid).nodes == ("/watch_talker",), 10), node
    assert script.backend == ("sys.monitoring" if sys.version_info >= (3, 12) else "settrace")
    for _ in range(3):  # a fresh process discovers the two at its own pace on a loaded machine
        out = _dbglog("watch", "--list")
        assert out.returncode == 0, out.stderr
        if str(loop.proc.pid) in out.stdout and "/watch_talker" in out.stdout:
            break
    assert str(loop.proc.pid) in out.stdout
    assert "/watch_talker" in out.stdout


def test_source_names_and_files(client: WatchClient, loop: Child) -> None:
    """A process lists its user files, sends source lines around a line, and the names there."""
    proc = _process(client, loop.proc.pid)
    assert str(LOOP) in client.files(proc)
    assert not any("site-packages" in f for f in client.files(proc))
    src = client.source(proc, "loop.py", line_of("step", LOOP), context=2)
    assert src.path == str(LOOP)
    assert src.first == line_of("step", LOOP) - 2
    assert "# L:step" in src.lines[2]
    names = client.names(proc, "loop.py", line_of("step", LOOP))
    assert {"robot", "i", "out", "speed", "config", "ranges"} <= set(names.locals)
    assert {"Robot", "step", "json"} <= set(names.globals)
    with pytest.raises(WatchError, match="no file") as info:
        client.source(proc, "missing.py", 1)
    assert info.value.state == "no_file"


def test_values_equal_the_program_hit_for_hit(client: WatchClient, loop: Child) -> None:
    """Numbers, attributes and dicts arrive for every hit, equal to what the program wrote for that step."""
    spec = WatchSpec("loop.py", line_of("step", LOOP), ("i", "speed", "robot.speed", "config"))
    watch = client.arm(spec)
    try:
        samples, events = _collect(watch, 5 * 50)  # i, speed, robot.speed, config's 2 keys
    finally:
        watch.disarm()
    assert any(e.state == "armed" for e in events), events
    hits = [h for h in _by_hit(samples) if 0 in h]
    steps = [h[0] for h in hits]
    assert len(steps) >= 45
    assert steps == list(range(int(steps[0]), int(steps[0]) + len(steps)))  # type: ignore[call-overload]
    written = {line["i"]: line for line in loop.lines() if "i" in line}
    for hit in hits[:-1]:
        line = written[hit[0]]
        assert hit[1] == line["speed"]
        assert hit[2] == line["speed"]
    gains = [s for s in samples if s.expr == 3 and s.key == "gain"]
    assert {s.value for s in gains} <= set(written)
    assert {s.value for s in samples if s.expr == 3 and s.key == "mode"} == {"run"}


def test_arrays_arrive_on_their_tag(client: WatchClient, loop: Child) -> None:
    """A list of numbers is sent as an array on its own tag's topic, as the program had it."""
    watch = client.arm(WatchSpec("loop.py", line_of("step", LOOP), ("ranges",), label="loop_ranges"))
    try:
        samples, _events = _collect(watch, 5)
    finally:
        watch.disarm()
    assert len(samples) >= 5
    for sample in samples:
        value = sample.value
        assert isinstance(value, tuple)
        first, second = value
        assert second == first + 0.25


def test_properties_calls_and_imports_never_run(client: WatchClient, loop: Child, tmp: Path) -> None:
    """A property is refused at each hit, never read; calls and imports are refused before anything runs."""
    proc = _process(client, loop.proc.pid)
    watch = client.arm(WatchSpec("loop.py", line_of("step", LOOP), ("robot.costly", "robot.reads")))
    try:
        samples, events = _collect(watch, 20, errors=1)
    finally:
        watch.disarm()
    errors = [e.message for e in events if e.kind == "error"]
    assert errors == ["'robot.costly': Robot.costly is a property: reading it would run code"]
    assert {s.value for s in samples} == {0}
    marker = tmp / "ran"
    for text in (f"__import__('os').system('touch {marker}')", f"open('{marker}', 'w')", "robot.__class__"):
        with pytest.raises(WatchError, match="not allowed"):
            client.arm(WatchSpec("loop.py", 30, (text,)))
        fields = ArmSpec("loop.py", line_of("step", LOOP), (text,)).to_json()
        with pytest.raises(WatchError, match="not allowed") as info:  # past the client's own check
            client._ask(proc, "arm", {"watch": "raw", **fields}, 10.0)
        assert info.value.state == "expr_error"
    assert not marker.exists()


def test_a_threads_code_and_an_error_that_stays_armed(client: WatchClient, loop: Child) -> None:
    """A line of a thread's loop reports every pass; a name it lacks is said once, and the rest flows."""
    watch = client.arm(WatchSpec("loop.py", line_of("ticker", LOOP), ("ticks", "nope")))
    try:
        samples, events = _collect(watch, 20, errors=1)
    finally:
        watch.disarm()
    ticks = [s.value for s in samples]
    assert ticks == list(range(int(ticks[0]), int(ticks[0]) + len(ticks)))  # type: ignore[call-overload]
    assert [e.message for e in events if e.kind == "error"] == ["'nope': name 'nope' is not defined here"]


def test_two_watchers_on_one_line(client: WatchClient, loop: Child) -> None:
    """Two watchers of one line share one watch: each gets every hit once; one leaving keeps the other's."""
    spec = WatchSpec("loop.py", line_of("step", LOOP), ("i",))
    with WatchClient(values=True) as other:
        assert wait_until(lambda: loop.proc.pid in {p.pid for p in other.processes()}, START_S)
        first, second = client.arm(spec), other.arm(spec)
        try:
            a, _ = _collect(first, 40)
            b, _ = _collect(second, 40)
            assert first.tags() == second.tags()
            first.disarm()
            first_done = time.monotonic()
            later, _ = _collect(second, 30)
        finally:
            first.disarm()
            second.disarm()
    for got in (a, b, later):
        stamps = [s.stamp_ns for s in got]
        assert len(stamps) == len(set(stamps))  # no hit twice
        values = [s.value for s in got]
        assert values == list(range(int(values[0]), int(values[0]) + len(values)))  # type: ignore[call-overload]
    common = {s.stamp_ns for s in a} & {s.stamp_ns for s in b}
    assert len(common) >= 10
    assert time.monotonic() - first_done < 60


def test_the_cpu_rule_disarms_and_the_program_goes_on(client: WatchClient, loop: Child) -> None:
    """A watch on a hot inner loop over its CPU share disarms itself and says so; the program runs on."""
    watch = client.arm(WatchSpec("loop.py", line_of("hot", LOOP), ("acc",), max_cpu=0.001))
    try:
        events = _wait_event(watch, lambda e: e.state == "cpu")
    finally:
        watch.disarm()
    message = next(e.message for e in events if e.state == "cpu")
    assert "of a CPU" in message
    assert "disarmed" in message
    before = len(loop.lines())
    assert wait_until(lambda: len(loop.lines()) > before + 10, 10)


def test_a_hit_paused_by_a_loaded_machine_is_not_taken_for_cpu(monkeypatch: pytest.MonkeyPatch) -> None:
    """A hit that took 0.5 s of wall time (the OS ran other programs meanwhile) but next to no CPU leaves the
    watch armed, at the hit and at the window's end: the CPU rule counts at most the CPU the process spent
    (it said 1000% of a CPU and disarmed)."""
    import types

    from dbglog.watch import _agent

    start = time.perf_counter_ns()
    ticks = iter([start, start + 500_000_000])  # the hit's start, its end half a second later
    clock = types.SimpleNamespace(
        perf_counter_ns=lambda: next(ticks, start + 1_200_000_000),  # then the CPU window's end
        process_time_ns=time.process_time_ns,
        time_ns=time.time_ns,
    )
    stub = types.SimpleNamespace(backend=None, _queue=[], _pipe=None)
    spec = ArmSpec("x.py", 1, (), throttle=0)
    watch = _agent.Watch(stub, ("k",), spec, "x.py", (), [], None, [])  # type: ignore[arg-type]
    watch.window_start = start
    monkeypatch.setattr(_agent, "time", clock)
    assert watch.hit(sys._getframe())
    assert watch.active, watch.ended
    watch.check_cpu()
    assert watch.active, watch.ended
    assert watch.sent == 1


def test_a_node_timer_callback_by_node_name(client: WatchClient, loop: Child, talker: Child) -> None:
    """--node picks the rclpy node's process; its timer callback's attribute arrives, every tick."""
    watch = client.arm(WatchSpec("talker.py", line_of("tick", TALKER), ("self.count",), node="watch_talker"))
    try:
        samples, _ = _collect(watch, 30)
    finally:
        watch.disarm()
    assert {s.pid for s in samples} == {talker.proc.pid}
    counts = [s.value for s in samples]
    assert counts == list(range(int(counts[0]), int(counts[0]) + len(counts)))  # type: ignore[call-overload]
    assert set(watch.status()) == {_process(client, talker.proc.pid).agent}


def test_cli_prints_each_hit_and_removes_the_watch(client: WatchClient, loop: Child) -> None:
    """``dbglog watch FILE:LINE EXPR --count N`` prints N hits, one line per expression, then disarms."""
    target = f"loop.py:{line_of('step', LOOP)}"
    out = _dbglog("watch", target, "i", "speed", "--count", "3")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert [line.split(" = ")[0] for line in lines] == ["i", "speed"] * 3
    steps = [int(line.split(" = ")[1]) for line in lines[::2]]
    assert steps == [steps[0], steps[0] + 1, steps[0] + 2]
    assert [float(line.split(" = ")[1]) for line in lines[1::2]] == [s * 0.5 for s in steps]
    assert "armed in" in out.stderr
    assert wait_until(lambda: not _process(client, loop.proc.pid).watches, 10)
    when = _dbglog("watch", target, "i", "--when", "i % 7 == 0", "--count", "2")
    assert when.returncode == 0, when.stderr
    assert all(int(line.split(" = ")[1]) % 7 == 0 for line in when.stdout.splitlines())
    throttled = _dbglog("watch", target, "i", "--throttle", "0.2", "--count", "3", "--stamp")
    assert throttled.returncode == 0, throttled.stderr
    stamps = [float(line.split()[0]) for line in throttled.stdout.splitlines()]
    assert all(b - a >= 0.19 for a, b in itertools.pairwise(stamps))
    assert "over the rate limit (counted, not sent)" in throttled.stderr


def test_cli_ctrl_c_disarms(client: WatchClient, loop: Child) -> None:
    """Ctrl-C ends ``dbglog watch`` (status 130) and the watch is removed from the process."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "watch", f"loop.py:{line_of('step', LOOP)}", "i"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    first = proc.stdout.readline()
    assert first.startswith("i = ")
    assert _process(client, loop.proc.pid).watches
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=30)
    assert proc.returncode == 130
    assert wait_until(lambda: not _process(client, loop.proc.pid).watches, 10)


def test_a_process_that_did_not_opt_in_is_never_touched(client: WatchClient, loop: Child, tmp: Path) -> None:
    """A plain python process is not watchable: the watcher says so within seconds; the program runs on."""
    plain, stop = tmp / "plain.py", tmp / "plain.stop"
    shutil.copy(SHORT, plain)
    proc = subprocess.Popen(
        [sys.executable, str(plain), "60", str(stop)], stdout=subprocess.PIPE, text=True, env=_env()
    )
    try:
        started = time.monotonic()
        out = _dbglog("watch", f"plain.py:{line_of('short', SHORT)}", "n", "--timeout", "6")
        assert time.monotonic() - started < 30
        assert out.returncode == 1
        assert "no watchable process" in out.stderr  # "...has plain.py loaded", or none at all yet
        assert proc.pid not in {p.pid for p in client.processes()}
    finally:
        stop.touch()
        stdout, _ = proc.communicate(timeout=30)
    assert proc.returncode == 0
    assert stdout.strip() == "counted True"


def test_a_restarted_process_is_armed_again(client: WatchClient, tmp: Path) -> None:
    """The watch follows the program: gone when it exits, armed again in the new process when it restarts."""
    watch = client.arm(WatchSpec("short.py", line_of("short", SHORT), ("n",)))
    stop = tmp / "short.stop"
    pids = []
    try:
        for _ in range(2):
            stop.unlink(missing_ok=True)
            run = subprocess.Popen(
                [sys.executable, "-m", "dbglog", "run", str(SHORT), "60", str(stop)],
                stdout=subprocess.PIPE,
                env=_env(),
            )
            pids.append(run.pid)
            samples, seen = _collect(watch, 10, START_S)
            stop.touch()
            run.communicate(timeout=30)
            assert run.returncode == 0
            assert {s.pid for s in samples} == {run.pid}, (seen, watch.status())
            counts = [s.value for s in samples]
            assert counts == list(range(int(counts[0]), int(counts[0]) + len(counts)))  # type: ignore[call-overload]
            events = _wait_event(watch, functools.partial(_gone, pid=run.pid))
            assert any(_gone(e, run.pid) for e in events)
            watch.samples()
    finally:
        watch.disarm()
    assert pids[0] != pids[1]


@pytest.mark.parametrize("how", ["env", "ros-args"])
def test_a_robot_namespace_process(client: WatchClient, tmp: Path, how: str) -> None:
    """A process whose tags are in a robot namespace (DBGLOG_NAMESPACE, or ``--ros-args -r __ns:=`` as
    ros2 launch passes it) is watched on its robot's topics."""
    stop = tmp / f"robot-{how}.stop"
    extra = ["--ros-args", "-r", "__ns:=/robot8"] if how == "ros-args" else []
    env = _env(DBGLOG_NAMESPACE="robot8") if how == "env" else _env()
    run = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "run", str(SHORT), "60", str(stop), *extra],
        stdout=subprocess.PIPE,
        env=env,
    )
    watch = client.arm(WatchSpec("short.py", line_of("short", SHORT), ("n",)))
    try:
        samples, _ = _collect(watch, 10, START_S)
        assert _process(client, run.pid).robot == "/robot8"
    finally:
        watch.disarm()
        stop.touch()
        run.communicate(timeout=30)
    counts = [s.value for s in samples if s.pid == run.pid]
    assert len(counts) >= 10
    assert counts == list(range(int(counts[0]), int(counts[0]) + len(counts)))  # type: ignore[call-overload]


def test_a_process_of_this_host_whose_pid_ended_has_exited() -> None:
    """A killed process's node stays on the graph for the middleware's lease (20 s): one of this host whose
    pid no longer runs is known to have exited; a running one, or one of another host, is not."""
    import socket

    from dbglog.watch.client import _exited_here

    ended = subprocess.Popen([sys.executable, "-c", "pass"])
    ended.wait(30)

    def process(pid: int, host: str) -> Process:
        return Process("a", "dbglog_watch_1_a", pid, host, (), "", "", "", (), "", ())

    here = socket.gethostname()
    assert _exited_here(process(ended.pid, here))
    assert not _exited_here(process(os.getpid(), here))
    assert not _exited_here(process(1, here)), "pid 1 runs (as another user's process would)"
    assert not _exited_here(process(ended.pid, here + "-elsewhere"))


def test_values_that_arrive_before_the_arm_answer_are_given_to_the_watch(client: WatchClient) -> None:
    """A process's first hits go out on its batch topic, its arm answer on the answers topic: the batch can
    come first, when the process is still being asked and no watch claims it. The client keeps such
    batches a while and gives the watch its values once the process says it is armed (CI lost the first
    of 3 hits of ``dbglog watch --count 3`` this way); values from before the arming are not given."""
    from array import array

    from dbglog._ros._batch import SLOT_FORMATS, encode_batch, pack_values, type_code
    from dbglog.watch.client import WatchStatus, _Armed

    robot, tag, armed_at = "/early_robot", "watch/early", time.time_ns()
    stamps = [armed_at - 1_000_000, armed_at + 1_000_000, armed_at + 2_000_000]  # one from before arming
    code = type_code("Float64")
    raw = encode_batch(
        7,
        1,
        [(code, tag.encode())],
        array("H", [0, 0, 0]),
        array("q", stamps),
        pack_values(SLOT_FORMATS[code] * 3, [0.5, 1.5, 2.5]),
        [],
    )
    watch = Watch(client, WatchSpec("loop.py", 1, ("speed",)))
    armed = _Armed(WatchStatus("early_agent", 4242, "host", "asking"))
    with client._lock:
        watch._per["early_agent"] = armed
        client._watches[watch.id] = watch
    try:
        client._on_batch(bytes(raw), robot)  # before the answer: nobody claims it
        assert watch.samples() == []
        answer = {"state": "armed", "tags": [tag], "robot": robot, "writer": 7, "armed_at": armed_at}
        with client._lock:
            client._apply_arm(watch, armed, answer)
        got = watch.samples()
        assert [(s.value, s.stamp_ns, s.expr) for s in got] == [(1.5, stamps[1], 0), (2.5, stamps[2], 0)]
        with client._lock:
            client._apply_arm(watch, armed, answer)  # said again: nothing is given twice
        assert watch.samples() == []
    finally:
        with client._lock:
            client._watches.pop(watch.id, None)
