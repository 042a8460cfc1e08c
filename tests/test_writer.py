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
from tests._ros import RosPeer, wait_until

SCHED_IDLE = 5


def _writer(background: bool = True, capacity: int = 1 << 20) -> Writer:
    addresses = rcl_addresses()
    assert addresses is not None
    return Writer(*addresses, background, capacity)


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
        assert writer.stats() == {
            "written": 310,
            "failed": 0,
            "queued_bytes": 0,
            "busy": False,
            "oldest_s": 0.0,
        }
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


def test_the_thread_steps_aside_unless_asked_not_to() -> None:
    """``background``: the writer's own thread runs under SCHED_IDLE, the caller's policy unchanged."""
    before = _policies()
    idle = _writer(background=True)
    assert idle.policy_error is None
    after = _policies()
    assert after[idle.native_id] == SCHED_IDLE
    assert after[threading.get_native_id()] == before[threading.get_native_id()] == 0
    idle.stop()
    normal = _writer(background=False)
    assert _policies()[normal.native_id] == 0
    normal.stop()


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
        Writer(0, addresses[1], True, 10)
    with pytest.raises(ValueError, match="addresses and a capacity"):
        Writer(*addresses, True, 0)
    writer = _writer()
    with pytest.raises(ValueError, match="NULL publisher"):
        writer.submit(0, b"x")
    with pytest.raises(TypeError):
        writer.submit(1, "text")  # type: ignore[arg-type]
    writer.stop()


def test_the_sdk_writes_through_its_writer_thread() -> None:
    """dbglog's own node: the batch and every tag topic go through one writer thread, which `flush`
    waits for; it runs in the background unless ``DBGLOG_CPU=normal`` (as this suite sets it)."""
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
    normal = os.environ.get("DBGLOG_CPU", "").strip() == "normal"
    assert _policies()[writer.native_id] == (0 if normal else SCHED_IDLE)


def _run(script: str, cpu: str) -> subprocess.CompletedProcess[str]:
    """Run `script` in a fresh interpreter with ``DBGLOG_CPU=cpu``; it must succeed."""
    env = {**os.environ, "DBGLOG_CPU": cpu}
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


@pytest.mark.parametrize(
    ("value", "policy", "said"),
    [("normal", 0, False), ("background", SCHED_IDLE, False), ("fast", SCHED_IDLE, True)],
)
def test_dbglog_cpu_sets_the_writer_threads_policy(value: str, policy: int, said: bool) -> None:
    """``DBGLOG_CPU`` as the viewer reads it: a value that is no policy is named, and the default stands."""
    proc = _run(_POLICY_SCRIPT, value)
    assert f"policy {policy}" in proc.stdout
    assert ("DBGLOG_CPU: 'fast' is not a CPU policy" in proc.stderr) == said, proc.stderr


_STARVED_SCRIPT = """
import os, subprocess, sys, time
os.sched_setaffinity(0, {0})  # this process and 6 busy ones share one CPU: the rest of the machine is free
hogs = [
    subprocess.Popen([sys.executable, "-c", "import os\\nos.sched_setaffinity(0, {0})\\nwhile True: pass"])
    for _ in range(6)
]
try:
    import dbglog
    from dbglog.api import _runtime
    _runtime._WRITER_STARVED_S = 0.2  # (1 s in use: a test need not wait that long)
    _runtime._WRITER_CAPACITY = 1  # one message at a time: full as soon as it is starved
    _runtime._WRITER_FULL_WAIT_S = 0.02
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


def test_a_starved_writer_thread_is_said_with_the_way_out() -> None:
    """In the background, a writer kept off its CPU by ordinary work (busy processes on the one CPU it may
    use) is named once, with DBGLOG_CPU=normal as the way out. Full (here one message), it makes the
    publisher thread wait a moment (1 s in use, 20 ms here), then the samples are dropped, counted and
    said once: the process still ends at once."""
    started = time.monotonic()
    proc = _run(_STARVED_SCRIPT, "background")
    assert time.monotonic() - started < 30
    dropped = int(proc.stdout.split("done")[1].split()[0])
    assert dropped > 0, proc.stderr
    assert proc.stderr.count("values are dropped until it catches up") == 1, proc.stderr
    assert proc.stderr.count("its writer thread runs in the background (SCHED_IDLE)") == 1, proc.stderr
    assert "Set DBGLOG_CPU=normal" in proc.stderr
