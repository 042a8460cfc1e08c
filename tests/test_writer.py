"""The compiled writer thread (``dbglog/api/_writer.c``): real rclpy, real Fast DDS, two participants."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import rclpy
from rclpy.serialization import serialize_message
from std_msgs.msg import Float64, String, UInt8MultiArray

import dbglog
from dbglog import DbglogWarning
from dbglog._ros._nogil import publisher_address, rcl_addresses
from dbglog._ros._qos import batch_qos
from dbglog.api._hot import Writer
from dbglog.api._public import RUNTIME
from tests._children import busy_loop
from tests._ros import RosPeer, wait_until


def _writer(capacity: int = 1 << 20) -> Writer:
    addresses = rcl_addresses()
    assert addresses is not None
    return Writer(*addresses, capacity)


def _policies() -> dict[int, int]:
    """Each thread of this process and its scheduling policy (``/proc``'s stat, field 41)."""
    out = {}
    for task in Path("/proc/self/task").iterdir():
        stat = (task / "stat").read_text()
        out[int(task.name)] = int(stat.rsplit(")", 1)[1].split()[38])
    return out


def test_messages_arrive_in_order_across_publishers() -> None:
    """Batch-sized and small messages on two topics, submitted in turn, arrive whole and in order."""
    payload = bytes(range(256)) * 64
    with RosPeer("writer_pub") as a, RosPeer("writer_sub") as b:
        got_big = b.subscribe("/writer/big", UInt8MultiArray, batch_qos())
        got_x = b.subscribe("/writer/x", Float64)
        big, x = a.publisher("/writer/big", UInt8MultiArray, batch_qos()), a.publisher("/writer/x", Float64)
        assert a.wait_for_subscribers(big)
        assert a.wait_for_subscribers(x)
        writer = _writer()
        big_at, x_at = publisher_address(big), publisher_address(x)
        assert big_at is not None
        assert x_at is not None
        for i in range(300):
            writer.submit(x_at, serialize_message(Float64(data=float(i))))
            if i % 30 == 0:
                writer.submit(big_at, serialize_message(UInt8MultiArray(data=payload[: 1000 + i])))
        assert writer.drain(10.0)
        assert got_x.wait_for(300)
        assert got_big.wait_for(10)
        assert got_x.values() == [float(i) for i in range(300)]
        assert [bytes(v) for v in got_big.values()] == [payload[: 1000 + i] for i in range(0, 300, 30)]
        stats = writer.stats()
        assert 0.0 < stats.pop("longest_wait_s") < 10.0  # the longest a message waited to be written
        assert stats == {"written": 310, "failed": 0, "queued_bytes": 0, "busy": False}
        assert writer.stats()["longest_wait_s"] == 0.0  # since the last look: nothing waited
        writer.stop()


def test_a_full_writer_makes_the_submitter_wait_and_loses_nothing() -> None:
    """With room for one message at a time every `submit` waits (without the GIL) for the one before."""
    with RosPeer("writer_full_pub") as a, RosPeer("writer_full_sub") as b:
        got = b.subscribe("/writer/full", String)
        pub = a.publisher("/writer/full", String)
        assert a.wait_for_subscribers(pub)
        writer = _writer(capacity=1)
        at = publisher_address(pub)
        assert at is not None
        ticks = [0]
        stop = threading.Event()

        def tick() -> None:  # runs only while the submitting thread lets the GIL go
            while not stop.is_set():
                ticks[0] += 1
                time.sleep(0.0001)

        ticker = threading.Thread(target=tick)
        ticker.start()
        try:
            for i in range(200):
                writer.submit(at, serialize_message(String(data=f"m{i}")))
        finally:
            stop.set()
            ticker.join()
        assert writer.drain(10.0)
        assert got.wait_for(200)
        assert got.values() == [f"m{i}" for i in range(200)]
        assert ticks[0] > 0


def test_the_thread_is_an_ordinary_thread() -> None:
    """The writer's thread is a thread of this process of its own, under the ordinary policy (never
    SCHED_IDLE: docs/api.md, *Why the writer thread is an ordinary thread*)."""
    writer = _writer()
    assert writer.native_id != threading.get_native_id()
    assert _policies()[writer.native_id] == 0
    writer.stop()


def test_refused_writes_are_counted_and_said_once() -> None:
    """A write rcl refuses (its context shut down) is counted, rcl's error state reset on the writer's
    own thread, and the runtime names it once; later writes still go."""
    with RosPeer("writer_refused") as a:
        pub = a.publisher("/writer/refused", Float64)
        at = publisher_address(pub)
        assert at is not None
        writer = _writer()
        rclpy.shutdown(context=a.context)  # the node and publisher stay: rcl refuses the write
        data = serialize_message(Float64(data=1.0))
        writer.submit(at, data)
        writer.submit(at, data)
        assert writer.drain(10.0)
        assert writer.stats()["failed"] == 2
        saved = RUNTIME._writer, RUNTIME._writer_failed
        RUNTIME._writer, RUNTIME._writer_failed = writer, 0
        try:
            with pytest.warns(DbglogWarning, match=r"refused 2 message\(s\)"):
                RUNTIME.note_writer()
            RUNTIME.note_writer()  # nothing new: silent
        finally:
            RUNTIME._writer, RUNTIME._writer_failed = saved
        writer.stop()


def test_discard_drops_what_waits_and_a_stopped_writer_refuses() -> None:
    """`discard` empties the queue (a shutdown that cannot wait); after `stop`, `submit` raises."""
    with RosPeer("writer_discard") as a:
        pub = a.publisher("/writer/discard", Float64)
        at = publisher_address(pub)
        assert at is not None
        writer = _writer()
        data = serialize_message(Float64(data=1.0))
        for _ in range(2000):
            writer.submit(at, data)
        dropped = writer.discard()
        assert writer.drain(10.0)
        stats = writer.stats()
        assert stats["written"] + dropped == 2000
        assert stats["queued_bytes"] == 0
        writer.stop()
        with pytest.raises(RuntimeError, match="stopped"):
            writer.submit(at, data)
        assert writer.drain(0.0)


def test_bad_arguments_are_refused() -> None:
    """No rcl addresses, a zero capacity, a NULL publisher, not bytes: clear errors, no thread left."""
    addresses = rcl_addresses()
    assert addresses is not None
    with pytest.raises(ValueError, match="addresses and a capacity"):
        Writer(0, addresses[1], 10)
    with pytest.raises(ValueError, match="addresses and a capacity"):
        Writer(*addresses, 0)
    writer = _writer()
    with pytest.raises(ValueError, match="NULL publisher"):
        writer.submit(0, b"x")
    with pytest.raises(TypeError):
        writer.submit(1, "text")  # type: ignore[arg-type]
    writer.stop()


def test_the_sdk_writes_through_its_writer_thread() -> None:
    """dbglog's own node: the batch and every tag topic go through one writer thread, which `flush`
    waits for; an ordinary thread."""
    dbglog.logfloat("writer/sdk", 1.0)
    assert dbglog.flush(10.0)
    writer = RUNTIME._writer
    assert writer is not None
    assert RUNTIME.channels["writer/sdk"].publish_raw.func == writer.submit  # type: ignore[attr-defined]
    assert RUNTIME.batch_publish.func == writer.submit  # type: ignore[union-attr]
    before = writer.stats()["written"]
    for k in range(50):
        dbglog.logfloat("writer/sdk", float(k))
    assert dbglog.flush(10.0)
    assert wait_until(lambda: writer.stats()["written"] > before)
    assert writer.stats()["queued_bytes"] == 0
    assert _policies()[writer.native_id] == 0


def _run(script: str, cpu: str | None = None) -> subprocess.CompletedProcess[str]:
    """Run `script` in a fresh interpreter (with ``DBGLOG_CPU=cpu`` when given); it must succeed."""
    env = {**os.environ, "DBGLOG_CPU": cpu} if cpu is not None else dict(os.environ)
    proc = subprocess.run(
        [sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=90, check=False
    )
    assert proc.returncode == 0, proc.stderr
    return proc


_POLICY_SCRIPT = """
import dbglog
from pathlib import Path
from dbglog.api._public import RUNTIME
dbglog.logfloat("writer/policy", 1.0)
assert dbglog.flush(10.0)
stat = Path(f"/proc/self/task/{RUNTIME._writer.native_id}/stat").read_text()
print("policy", stat.rsplit(")", 1)[1].split()[38])
"""


@pytest.mark.parametrize("value", ["normal", "background", "fast"])
def test_dbglog_cpu_leaves_the_writer_thread_ordinary(value: str) -> None:
    """``DBGLOG_CPU`` is the viewer's, bridge's and recorder's: the SDK's writer thread stays an ordinary
    thread whatever it says (and the SDK says nothing of it)."""
    proc = _run(_POLICY_SCRIPT, value)
    assert "policy 0" in proc.stdout
    assert "DBGLOG_CPU" not in proc.stderr, proc.stderr


_STARVED_SCRIPT = f"""
import os, subprocess, sys, time
os.sched_setaffinity(0, {{0}})  # this process and 6 busy ones share one CPU: the rest of the machine is free
hogs = [subprocess.Popen([sys.executable, "-c", {busy_loop(60, cpu=0)!r}]) for _ in range(6)]
try:
    import dbglog
    from dbglog.api import _runtime
    from dbglog.api._public import RUNTIME
    _runtime._WRITER_STARVED_S = 0.01  # (1 s in use; below the full wait, so a refusal proves starvation)
    _runtime._WRITER_CAPACITY = 1  # one message at a time: full as soon as it is starved
    _runtime._WRITER_FULL_WAIT_S = 0.02
    dbglog.logfloat("writer/starved", 1.0)
    assert dbglog.flush(10.0)
    os.setpriority(os.PRIO_PROCESS, RUNTIME._writer.native_id, 19)  # an ordinary thread, but the least
    end = time.monotonic() + 4.0
    while time.monotonic() < end:
        dbglog.logfloat("writer/starved", 1.0)
        time.sleep(0.001)
finally:
    for hog in hogs:
        hog.kill()
        hog.wait()
print("done", dbglog.stats().dropped_by_reason.get("queue_full", 0), flush=True)
"""


def test_a_starved_writer_thread_is_said_once() -> None:
    """A writer kept off its CPU (here: niced to 19, beside busy processes on the one CPU it may use) is
    named once. Full (here one message), it makes the publisher thread wait a moment (1 s in use, 20 ms
    here), then the samples are dropped, counted and said once: the process still ends at once. The
    writer remembers the longest wait since the publisher thread last looked, so a message written late
    between two looks is still said."""
    started = time.monotonic()
    proc = _run(_STARVED_SCRIPT)
    assert time.monotonic() - started < 30
    dropped = int(proc.stdout.split("done")[1].split()[0])
    assert dropped > 0, proc.stderr
    assert proc.stderr.count("values are dropped until it catches up") == 1, proc.stderr
    assert proc.stderr.count("in dbglog's writer thread to be published") == 1, proc.stderr
