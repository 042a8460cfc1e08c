"""The engine feeds the Log console (issue 18): every /rosout line into a LogStore, its past from the history,
lines written before the viewer started, and bindings filtered by node and minimum level.

Real rclpy loggers in child processes (several nodes each) write to the real /rosout; nothing is mocked.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import threading
import uuid
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import pytest

from dbglog._regex._propose import propose
from dbglog.viewer._data._engine import Engine
from dbglog.viewer._data._logstore import DEBUG, ERROR, INFO, WARN, LogFilter, LogStore
from dbglog.viewer._data._model import Binding, SeriesSnapshot, Status
from tests._ros import RosPeer, first_line, wait_until

TIMEOUT = 40.0
LEVELS = (DEBUG, INFO, WARN, ERROR)

_CHILD = textwrap.dedent(
    """
    import sys, time
    import rclpy
    from rclpy.context import Context
    from rclpy.logging import LoggingSeverity
    from rclpy.node import Node

    run, nodes, count, phase = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    ctx = Context()
    rclpy.init(context=ctx)
    made = [Node(f"{run}_{k}", context=ctx) for k in range(nodes)]
    loggers = [n.get_logger() for n in made]
    for log in loggers:
        log.set_level(LoggingSeverity.DEBUG)

    def write(phase):
        for i in range(count):
            for k, log in enumerate(loggers):
                text = f"{phase} line {i} of {k}: value={i * 0.5}"
                if i % 4 == 0:  # one call site per level: rclpy refuses two levels at one site
                    log.debug(text)
                elif i % 4 == 1:
                    log.info(text)
                elif i % 4 == 2:
                    log.warning(text)
                else:
                    log.error(text)

    write(phase)
    print("logged", flush=True)
    for line in sys.stdin:  # each line asks for another phase; EOF ends
        write(line.strip())
        print("logged", flush=True)
    """
)


@contextmanager
def _loggers(run: str, nodes: int, count: int, phase: str) -> Iterator[subprocess.Popen[str]]:
    """A child process with `nodes` rclpy nodes that each log `count` lines, then stay up (their /rosout
    publishers keep the lines for late readers) and log another phase per line written to stdin."""
    proc = subprocess.Popen(
        [sys.executable, "-c", _CHILD, run, str(nodes), str(count), phase],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,  # rcl's console copy of every line
        text=True,
        env={**os.environ},
    )
    try:
        assert proc.stdout is not None
        assert first_line(proc.stdout) == "logged"
        yield proc
    finally:
        if proc.stdin is not None:
            proc.stdin.close()
        proc.wait(20)
        if proc.stdout is not None:
            proc.stdout.close()


def _again(proc: subprocess.Popen[str], phase: str) -> None:
    assert proc.stdin is not None
    assert proc.stdout is not None
    proc.stdin.write(phase + "\n")
    proc.stdin.flush()
    assert first_line(proc.stdout) == "logged"


def _ours(store: LogStore, run: str, phase: str | None = None) -> list[tuple[str, int, str]]:
    """The run's lines held: (node, level, message)."""
    store.sync()
    found = []
    for i in store.select(LogFilter(text=f"{phase} line" if phase else "")):
        line = store.line(int(i))
        if line.node.startswith(run):
            found.append((line.node, line.level, line.message))
    return found


def _expected(run: str, nodes: int, count: int, phase: str) -> set[tuple[str, int, str]]:
    return {
        (f"{run}_{k}", LEVELS[i % 4], f"{phase} line {i} of {k}: value={i * 0.5}")
        for i in range(count)
        for k in range(nodes)
    }


def _wait_lines(store: LogStore, run: str, phase: str, n: int) -> list[tuple[str, int, str]]:
    wait_until(lambda: len(_ours(store, run, phase)) >= n, TIMEOUT, 0.05)
    return _ours(store, run, phase)


def test_lines_written_before_the_viewer_started_arrive_in_time_order() -> None:
    """Two processes of three nodes log before the engine exists; their kept /rosout lines all reach the
    store, with level, node, message and source location, sorted by time."""
    run = f"early_{uuid.uuid4().hex[:6]}"
    with (
        _loggers(run + "a", 3, 40, "early"),
        _loggers(run + "b", 3, 40, "early"),
        Engine(node_name=f"logs_engine_{run}") as engine,
    ):
        engine.bind(Binding("/rosout"))
        store = engine.log_store("/rosout")
        got = _wait_lines(store, run, "early", 240)
    want = _expected(run + "a", 3, 40, "early") | _expected(run + "b", 3, 40, "early")
    assert set(got) == want
    assert len(got) == 240
    times = store.times(store.select(LogFilter()))
    assert np.all(np.diff(times) >= 0)
    ids = store.select(LogFilter(text="early line 7 of 2"))
    line = store.line(int(ids[0]))
    error_site = _CHILD.splitlines().index("                log.error(text)") + 1
    assert (line.level, line.function, line.line) == (ERROR, "write", error_site)
    assert line.file.endswith("<string>")


def test_a_store_made_later_starts_with_the_history_then_follows_live_lines() -> None:
    """The console opened after lines went by shows them (the engine's history), then each new line once."""
    run = f"later_{uuid.uuid4().hex[:6]}"
    with Engine(node_name=f"logs_engine_{run}") as engine:
        # No wait before the loggers start: the engine subscribes /rosout when its first publisher appears
        # (nothing publishes it before, so waiting for a type or a count here only ran out its timeout),
        # and their transient-local /rosout publishers keep every line for it.
        engine.bind(Binding("/rosout"))
        with _loggers(run, 2, 60, "past") as proc:
            # The store is made only once the history holds every past line: they went by before it.
            assert wait_until(lambda: engine.stats().per_topic.get("/rosout", 0) >= 120, TIMEOUT)
            store = engine.log_store("/rosout")
            assert store is engine.log_store("rosout")  # one store per topic
            past = _wait_lines(store, run, "past", 120)
            _again(proc, "live")
            live = _wait_lines(store, run, "live", 120)
            _again(proc, "more")
            more = _wait_lines(store, run, "more", 120)
    assert set(past) == _expected(run, 2, 60, "past")
    assert set(live) == _expected(run, 2, 60, "live")
    assert set(more) == _expected(run, 2, 60, "more")
    assert len(_ours(store, run)) == 360  # nothing twice


def test_log_bindings_filter_by_node_and_level_live_and_from_the_past() -> None:
    """A regex binding with a node and a minimum level takes only those lines, for a binding made after the
    lines went by (back-filled from the history) as for live ones; the store's preview counts the same."""
    run = f"filt_{uuid.uuid4().hex[:6]}"
    with Engine(node_name=f"logs_engine_{run}") as engine:
        engine.bind(Binding("/rosout"))
        with _loggers(run, 3, 40, "past") as proc:
            wait_until(lambda: engine.stats().per_topic.get("/rosout", 0) >= 120, TIMEOUT)
            line = f"past line 7 of 1: value={7 * 0.5}"
            proposal = propose(line, 2, node=f"{run}_1")  # "value=3.5": numbers are 7, 1, 3.5
            filtered = Binding("/rosout", "msg", proposal.pattern, node=f"{run}_1", level="warn")
            engine.bind(filtered)
            want_past = [i * 0.5 for i in range(40) if LEVELS[i % 4] >= WARN]
            snap = _wait_values(engine, filtered, len(want_past))
            assert snap.values.tolist() == want_past
            _again(proc, "past")  # the same kind of line again, live
            snap = _wait_values(engine, filtered, 2 * len(want_past))
            assert snap.values.tolist() == want_past * 2
            store = engine.log_store("/rosout")
            wait_until(lambda: len(_ours(store, run)) >= 240, TIMEOUT)
            assert store.preview(proposal, min_level=WARN).count == 2 * len(want_past)
            glob = Binding("/rosout", "msg", proposal.pattern, node=f"{run}_*", level="error")
            engine.bind(glob)
            snap = _wait_values(engine, glob, 2 * 3 * 10)
            assert sorted(snap.values.tolist()) == sorted([i * 0.5 for i in range(40) if i % 4 == 3] * 6)


def test_the_stores_worker_answers_a_console_whose_filter_changes_while_rosout_lines_arrive() -> None:
    """The engine's store decodes and filters on its own thread: a console's reader asks one filter, then
    another while a second phase of real /rosout lines is in flight, and is answered with exactly that
    filter's lines of both phases, none missing."""
    run = f"worker_{uuid.uuid4().hex[:6]}"
    with Engine(node_name=f"logs_engine_{run}") as engine:
        engine.bind(Binding("/rosout"))
        store = engine.log_store("/rosout")
        assert store.threaded
        reader = store.reader()
        warn = LogFilter(min_level=WARN, include="^(past|live) line")
        reader.ask(warn)
        with _loggers(run, 3, 40, "past") as proc:
            _wait_lines(store, run, "past", 120)
            store.step()
            shown = reader.shown()
            assert shown is not None
            assert shown.filt == warn
            ours = [line for line in map(store.line, map(int, shown.ids)) if line.node.startswith(run)]
            assert len(ours) == 3 * 20
            assert {line.level for line in ours} == {WARN, ERROR}
            _again(proc, "live")  # written; still on their way to the engine while the filter changes
            errors = LogFilter(min_level=ERROR, hidden=frozenset({f"{run}_0"}), include="line [0-9]*3 ")
            reader.ask(errors)
            _wait_lines(store, run, "live", 120)

            def answered() -> bool:
                store.step()
                got = reader.shown()
                return got is not None and got.filt == errors and got.complete

            assert wait_until(answered, TIMEOUT)
        shown = reader.shown()
    assert shown is not None
    got = {
        (line.node, line.message)
        for line in map(store.line, map(int, shown.ids))
        if line.node.startswith(run)
    }
    want = {
        (f"{run}_{k}", f"{phase} line {i} of {k}: value={i * 0.5}")
        for phase in ("past", "live")
        for i in range(40)
        for k in (1, 2)
        if i % 4 == 3 and i % 10 == 3
    }
    assert got == want


def test_stopping_the_engine_ends_its_stores_workers() -> None:
    """`Engine.stop` ends the worker thread of every log store it made; their lines stay readable."""
    run = uuid.uuid4().hex[:6]
    before = {t for t in threading.enumerate() if t.name == "dbglog-logs"}
    with Engine(node_name=f"logs_engine_{run}") as engine:
        store = engine.log_store("/rosout")
        (worker,) = {t for t in threading.enumerate() if t.name == "dbglog-logs"} - before
        assert worker.is_alive()
    assert not worker.is_alive()
    assert not store.threaded
    assert store.select(LogFilter()).dtype == np.int64


def test_a_node_filter_on_a_topic_without_nodes_is_an_error() -> None:
    """A String topic has no loggers: a node or level filter there is the binding's error, with the reason."""
    run = uuid.uuid4().hex[:6]
    topic = f"/logs_test_{run}/chatter"
    with Engine(node_name=f"logs_engine_{run}") as engine, RosPeer(f"logs_peer_{run}") as peer:
        from std_msgs.msg import String

        pub = peer.publisher(topic, String)
        binding = Binding(topic, "", r"(\d+)", node="talker")
        engine.bind(binding)
        peer.wait_for_subscribers(pub)
        pub.publish(String(data="n=1"))
        wait_until(lambda: engine.snapshot(binding).status is Status.ERROR, TIMEOUT)
        snap = engine.snapshot(binding)
    assert snap.status is Status.ERROR
    assert "node or level filter applies to rcl_interfaces/msg/Log topics" in snap.reason


def _wait_values(engine: Engine, binding: Binding, n: int) -> SeriesSnapshot:
    wait_until(lambda: len(engine.snapshot(binding).values) >= n, TIMEOUT)
    snap = engine.snapshot(binding)
    assert len(snap.values) == n, snap
    return snap


@pytest.mark.parametrize("topic", ["/rosout"])
def test_stores_go_with_their_last_user(topic: str) -> None:
    """The engine holds log stores weakly: dropped by every user, a store is no longer fed."""
    import gc

    with Engine(node_name=f"logs_engine_{uuid.uuid4().hex[:6]}") as engine:
        store = engine.log_store(topic)
        assert engine.log_store(topic) is store
        del store
        gc.collect()
        assert len(engine._logs) == 0
