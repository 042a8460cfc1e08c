"""The watch back ends in one process: every hit in every thread, and nothing left once removed."""

from __future__ import annotations

import sys
import threading
import types
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from dbglog.watch._monitor import Backend, BackendError, MonitoringBackend, TraceBackend, new_backend
from tests._watch_targets import line_of, load_targets


class Recorder:
    """A watcher that records one local at each hit (the program's thread calls it)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.values: list[object] = []
        self.threads: set[str] = set()
        self.on = True

    def hit(self, frame: types.FrameType) -> bool:
        self.values.append(frame.f_locals.get(self.name))
        self.threads.add(threading.current_thread().name)
        return self.on


def _from_agent_thread(fn: Callable[[], object]) -> None:
    """Run `fn` on a thread of its own, as the agent arms and disarms (not on the traced threads)."""
    thread = threading.Thread(target=fn, name="dbglog-watch-test")
    thread.start()
    thread.join()


@pytest.fixture
def backend() -> Iterator[Backend]:
    """This Python's back end, closed after the test."""
    made = new_backend()
    yield made
    _from_agent_thread(made.close)


@pytest.fixture(scope="module")
def targets() -> types.ModuleType:
    """The targets module."""
    return load_targets()


def test_this_python_gets_its_back_end() -> None:
    """3.12+ watches with sys.monitoring, 3.11 with trace functions."""
    expected = MonitoringBackend if sys.version_info >= (3, 12) else TraceBackend
    assert isinstance(new_backend(), expected)


def test_hits_in_every_thread_hit_for_hit(backend: Backend, targets: types.ModuleType) -> None:
    """The main thread, a thread started before and one started after arming all report every hit."""
    rec = Recorder("total")
    code, line = targets.plain.__code__, line_of("plain")
    stop = threading.Event()
    out: list[int] = []
    spin_rec = Recorder("n")
    before = threading.Thread(target=targets.spin, args=(stop, out), name="before")
    before.start()
    _from_agent_thread(lambda: backend.watch(code, line, (rec,)))
    _from_agent_thread(lambda: backend.watch(targets.spin.__code__, line_of("thread"), (spin_rec,)))
    try:
        assert targets.plain(4) == 6
        after = threading.Thread(target=targets.plain, args=(3,), name="after")
        after.start()
        after.join()
        while len(spin_rec.values) < 3:
            threading.Event().wait(0.01)
    finally:
        stop.set()
        before.join()
    assert rec.values == [0, 0, 1, 3, 0, 0, 1]
    assert {"MainThread", "after"} == rec.threads
    assert spin_rec.threads == {"before"}
    seen = [v for v in spin_rec.values if isinstance(v, int)]
    assert seen == list(range(seen[0], seen[0] + len(seen)))  # every loop of the running frame


def test_removed_watch_leaves_nothing(backend: Backend, targets: types.ModuleType) -> None:
    """Once the last watch goes, no trace function and no monitoring tool remain, and hits stop."""
    rec = Recorder("total")
    code, line = targets.plain.__code__, line_of("plain")
    before_trace = sys.gettrace()
    _from_agent_thread(lambda: backend.watch(code, line, (rec,)))
    targets.plain(2)
    _from_agent_thread(lambda: backend.watch(code, line, ()))
    targets.plain(2)
    assert rec.values == [0, 0]
    assert sys.gettrace() is before_trace
    assert threading.gettrace() is None
    if sys.version_info >= (3, 12):
        mon: Any = sys.monitoring  # type: ignore[attr-defined]
        assert all(mon.get_tool(tool) is None for tool in (3, 4))
        assert mon.get_local_events(4, code) == 0


def test_a_watch_that_says_no_more_stops_at_once(backend: Backend, targets: types.ModuleType) -> None:
    """When a watcher returns False (its count, the CPU rule), the line stops calling it."""
    rec = Recorder("total")
    rec.on = False
    _from_agent_thread(lambda: backend.watch(targets.plain.__code__, line_of("plain"), (rec,)))
    targets.plain(5)
    assert len(rec.values) == (1 if sys.version_info >= (3, 12) else 5)  # 3.12: DISABLE; 3.11: filtered


def test_an_error_in_a_watcher_never_reaches_the_program(backend: Backend, targets: types.ModuleType) -> None:
    """A watcher that raises is contained: the program's function returns as before."""

    class Broken:
        def hit(self, frame: types.FrameType) -> bool:
            raise RuntimeError("boom")

    _from_agent_thread(lambda: backend.watch(targets.plain.__code__, line_of("plain"), (Broken(),)))
    assert targets.plain(4) == 6


def test_other_tools_are_left_alone(targets: types.ModuleType) -> None:
    """Another tool keeps its thread tracer (3.11, reported) or its sys.monitoring tool id (3.12)."""
    if sys.version_info >= (3, 12):
        mon: Any = sys.monitoring  # type: ignore[attr-defined]
        mon.use_tool_id(4, "someone")
        try:
            backend = MonitoringBackend()
            rec = Recorder("total")
            backend.watch(targets.plain.__code__, line_of("plain"), (rec,))
            assert backend.tool == 3
            targets.plain(2)
            backend.close()
            assert rec.values == [0, 0]
            assert mon.get_tool(4) == "someone"
            mon.use_tool_id(3, "another")
            try:
                with pytest.raises(BackendError, match="no free tool id"):
                    MonitoringBackend().watch(targets.plain.__code__, line_of("plain"), (rec,))
            finally:
                mon.free_tool_id(3)
        finally:
            mon.free_tool_id(4)
        return
    trace_backend = TraceBackend()
    events: list[str] = []
    ready, stop = threading.Event(), threading.Event()

    def theirs(frame: types.FrameType, event: str, arg: object) -> None:
        events.append(event)

    def traced() -> None:
        sys.settrace(theirs)
        ready.set()
        stop.wait()
        mine.append(sys.gettrace())
        sys.settrace(None)

    mine: list[object] = []
    thread = threading.Thread(target=traced, name="debugged")
    thread.start()
    ready.wait()
    rec = Recorder("total")
    _from_agent_thread(lambda: trace_backend.watch(targets.plain.__code__, line_of("plain"), (rec,)))
    assert "debugged" in trace_backend.skipped
    _from_agent_thread(trace_backend.close)
    stop.set()
    thread.join()
    assert mine == [theirs]
