"""The viewer's watch service: a watch's states summed up for its widget, and the service against a real
program (loop.py run by ``dbglog run``) over real ROS: queries answered later, watches armed, their state,
a dict's keys, disarming, a client that cannot start."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from concurrent.futures import Future
from pathlib import Path
from typing import TypeVar

import pytest

from dbglog.viewer._data._model import Status
from dbglog.viewer._publishing._watches import WatchReport, WatchService, summarize
from dbglog.watch.client import Process, WatchClient, WatchError, WatchSpec, WatchStatus
from tests._children import stop_child
from tests._ros import wait_until
from tests._watch_targets import line_of

LOOP = Path(__file__).resolve().parent / "data" / "watch" / "loop.py"
STEP = line_of("step", LOOP)
START_S = 60.0
T = TypeVar("T")

SPEC = WatchSpec("/ws/loop.py", 31, ("speed",))


def _status(agent: str, state: str, message: str = "", pid: int = 0) -> WatchStatus:
    return WatchStatus(agent, pid or int(agent[1:]), "", state, message)


def test_summary_prefers_armed_then_errors_then_gone_then_waiting() -> None:
    """Armed anywhere wins; then a refused expression, no line, the CPU rule; then a process gone; then
    processes still answering, without the file, or none at all."""
    names = {"a1": "loop.py (pid 1)", "a2": "other (pid 2)"}
    report = summarize(SPEC, [_status("a1", "armed", "in step"), _status("a2", "no_file")], names=names)
    assert report == WatchReport("armed", "watch armed at loop.py:31 in step in loop.py (pid 1)")
    report = summarize(SPEC, [_status("a1", "no_line", "line 31 holds no code"), _status("a2", "gone")])
    assert report.state == "no_line"
    assert report.message == "line 31 holds no code (in pid 1)"
    assert summarize(SPEC, [_status("a1", "cpu", "took 7%"), _status("a2", "gone")]).state == "cpu"
    gone = summarize(SPEC, [_status("a1", "gone"), _status("a2", "no_file")], names=names)
    assert gone.state == "gone"
    assert gone.message.startswith("loop.py (pid 1) exited: the watch is armed again")
    assert summarize(SPEC, [_status("a1", "gone"), _status("a2", "asking")]).state == "gone"
    assert summarize(SPEC, [_status("a2", "asking"), _status("a1", "no_file")]).state == "asking"
    assert summarize(SPEC, [_status("a1", "no_file")]).state == "no_file"
    none = summarize(WatchSpec("loop.py", 3, ("x",), node="/ctl"), [])
    assert none.state == "none"
    assert "no watchable process with the node /ctl yet" in none.message
    assert "dbglog run" in none.message


def test_summary_of_an_expression_that_never_gives_a_value() -> None:
    """Armed but failing at every hit is an expression error; values at other hits keep it armed, noted."""
    armed = [_status("a1", "armed", "in step")]
    failing = summarize(SPEC, armed, failing={"a1": "expression error: 'x': name 'x' is not defined here"})
    assert failing.state == "expr_error"
    assert failing.message == "expression error: 'x': name 'x' is not defined here (in pid 1)"
    both = [*armed, _status("a2", "armed", "in step")]
    mixed = summarize(SPEC, both, failing={"a1": "expression error: ..."}, noted={"a2": "'d[k]': KeyError"})
    assert mixed.state == "armed"
    assert mixed.message == "watch armed at loop.py:31 in step in pid 2\nat some hits: 'd[k]': KeyError"


def test_report_over_the_series_status() -> None:
    """Armed, the series tell (``armed`` until a value came); else the watch's state colours the pill."""
    armed = WatchReport("armed", "watch armed at loop.py:31")
    assert armed.over(Status.WAITING, "no message yet") == (
        Status.WAITING,
        "armed",
        "watch armed at loop.py:31\nno hit yet",
    )
    assert armed.over(Status.LIVE, "") == (Status.LIVE, "live", "watch armed at loop.py:31")
    assert armed.over(Status.STALE, "no message for 3 s")[:2] == (Status.STALE, "stale")
    assert WatchReport("gone", "pid 1 exited").over(Status.LIVE, "") == (Status.STALE, "gone", "pid 1 exited")
    assert WatchReport("no_line", "m").over(Status.LIVE, "")[:2] == (Status.ERROR, "no line")
    assert WatchReport("expr_error", "m").over(Status.WAITING, "")[:2] == (Status.ERROR, "expr error")
    assert WatchReport("cpu", "m").over(Status.LIVE, "")[:2] == (Status.ERROR, "cpu limit")
    assert WatchReport("none", "m").over(Status.WAITING, "")[:2] == (Status.WAITING, "no process")
    off = WatchReport("off", "not armed: a recording is shown")
    assert off.over(Status.LIVE, "") == (Status.LIVE, "live", "not armed: a recording is shown")


# -- against a real program -------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def loop(tmp_path_factory: pytest.TempPathFactory) -> Iterator[subprocess.Popen[str]]:
    """loop.py run by ``dbglog run`` for the whole module."""
    tmp = tmp_path_factory.mktemp("loop")
    env = {k: v for k, v in os.environ.items() if not k.startswith("DBGLOG_WATCH") and k != "DBGLOG"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "run", str(LOOP), str(tmp / "out"), str(tmp / "stop")],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    yield proc
    (tmp / "stop").touch()
    try:
        proc.wait(20)
    except subprocess.TimeoutExpired:
        stop_child(proc, signal.SIGKILL)


@pytest.fixture(scope="module")
def service(loop: subprocess.Popen[str]) -> Iterator[WatchService[str]]:
    """One service for the module, once the program is watchable."""
    made: WatchService[str] = WatchService(poll_s=0.05)
    made.start()
    assert wait_until(lambda: any(p.pid == loop.pid for p in made.processes()), START_S), made.failure
    yield made
    made.close()


def _process(service: WatchService[str], pid: int) -> Process:
    return next(p for p in service.processes() if p.pid == pid)


def _answer(future: Future[T]) -> T:
    return future.result(timeout=30)


def _report(service: WatchService[str], key: str, state: str) -> WatchReport:
    wait_until(lambda: service.report(key).state == state, 30)
    return service.report(key)


def test_queries_are_answered_later_off_the_caller(
    service: WatchService[str], loop: subprocess.Popen[str]
) -> None:
    """files, source and names return futures at once; the answers are the program's; a line without code
    is said."""
    process = _process(service, loop.pid)
    files = service.files(process)
    assert isinstance(files, Future)
    assert str(LOOP) in _answer(files)
    source = _answer(service.source(process, str(LOOP), STEP, context=2))
    assert source.first == STEP - 2
    assert source.lines == tuple(LOOP.read_text().splitlines()[STEP - 3 : STEP + 2])
    names = _answer(service.names(process, str(LOOP), STEP))
    assert {"speed", "robot", "ranges", "config"} <= set(names.locals)
    with pytest.raises(WatchError) as raised:
        _answer(service.names(process, str(LOOP), STEP - 7))
    assert raised.value.state == "no_line"


def test_kept_watches_are_armed_reported_and_disarmed(
    service: WatchService[str], loop: subprocess.Popen[str]
) -> None:
    """A kept watch is armed with its topic; a dict's keys get their topics; a missing name, a call and a
    line without code are errors; a watch no longer kept is disarmed in the program."""
    specs = {
        "speed": WatchSpec(str(LOOP), STEP, ("speed",)),
        "config": WatchSpec(str(LOOP), STEP, ("config",)),
        "missing": WatchSpec(str(LOOP), STEP, ("nosuch",)),
        "call": WatchSpec(str(LOOP), STEP, ("len(ranges)",)),
        "blank": WatchSpec(str(LOOP), STEP - 7, ("speed",)),
    }
    service.keep(specs)
    speed = _report(service, "speed", "armed")
    assert speed.topics == ("/rosdashboard/watch/speed",)
    assert f"pid {loop.pid}" in speed.message
    assert wait_until(lambda: len(service.report("config").topics) == 2, 30)
    assert service.report("config").topics == (
        "/rosdashboard/watch/config/gain",
        "/rosdashboard/watch/config/mode",
    )
    assert "name 'nosuch' is not defined" in _report(service, "missing", "expr_error").message
    assert "calls are not allowed" in _report(service, "call", "expr_error").message
    assert _report(service, "blank", "no_line").message
    process = _process(service, loop.pid)
    assert {w.exprs for w in process.watches} >= {("speed",), ("config",), ("nosuch",)}
    service.keep({"speed": specs["speed"]})
    assert wait_until(lambda: {w.exprs for w in _process(service, loop.pid).watches} == {("speed",)}, 30)
    service.keep({})
    assert wait_until(lambda: not _process(service, loop.pid).watches, 30)


def test_closing_the_service_disarms_its_watches(loop: subprocess.Popen[str]) -> None:
    """A service closed with a watch armed leaves nothing armed in the program."""
    made: WatchService[str] = WatchService(poll_s=0.05)
    made.keep({"x": WatchSpec(str(LOOP), STEP, ("i",))})
    assert _report(made, "x", "armed").state == "armed"
    with WatchClient() as observer:
        assert wait_until(lambda: any(p.watches for p in observer.processes() if p.pid == loop.pid), 30)
        made.close()
        assert wait_until(lambda: not any(p.watches for p in observer.processes() if p.pid == loop.pid), 30)


def test_a_client_that_cannot_start_is_said_everywhere() -> None:
    """Without a client (no ROS) every watch says why, queries fail with the reason, no process is listed."""

    def broken() -> WatchClient:
        raise RuntimeError("rclpy is not installed")

    made: WatchService[str] = WatchService(broken)
    made.keep({"x": SPEC})
    assert wait_until(lambda: made.failure != "", 10)
    assert made.report("x") == WatchReport("failed", "cannot start watching: rclpy is not installed")
    assert made.processes() == []
    assert not made.discovering()
    with pytest.raises(WatchError, match="rclpy is not installed"):
        made.files(Process("a", "n", 1, "", (), "", "", "", (), "", ())).result(timeout=10)
    made.close()
