"""The probe effect: what 10 dbglog calls per iteration cost a 1 kHz control loop, with a viewer attached.

Run: ``.venv/bin/python benchmarks/bench_probe.py [--before /tmp/dbglog-before]`` (prints Markdown tables).

Each run is a fresh publisher process: a 1 kHz loop with ~25 µs of its own work that sleeps to the next
deadline and, per iteration, makes 10 calls (6x ``logfloat``, 2x ``logint``, ``logbool``, ``logstring``
throttled to 10 Hz) - or the same publishes with raw rclpy, or calls to an empty function of the same
signature (the floor of a Python call in this loop), or nothing. With ``sub``, a real viewer engine
(``Engine`` of the same source tree) runs in another process, bound to the 10 tags, and reports how
many samples reached its series, in order, the publish -> series latency and its own CPU.
Per-call times are taken around each call (``perf_counter_ns``; the "no calls" row shows that
clock's own cost), also per position in the iteration. CPU is the publisher process's and its child
processes', all threads (``/proc/*/stat``), minus the loop's own (the "no calls" run), per 10k
samples/s. For each wake-up more than 0.5 ms late the loop also reads how long it was runnable but
not running (``/proc/thread-self/schedstat``): waiting for a CPU, as opposed to waiting for the GIL.
``--before DIR`` adds rows for another source tree (e.g. ``git worktree add /tmp/dbglog-before
HEAD``). Medians over ``--repeats`` runs, run in alternation.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import random
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
_FLOATS = 6
_INTS = 2
_TAGS = [
    *(f"probe/f{i}" for i in range(_FLOATS)),
    *(f"probe/i{i}" for i in range(_INTS)),
    "probe/b",
    "probe/s",
]
_STRING_EVERY = 100
"""The throttled logstring (throttle=0.1 s) publishes every 100th iteration at 1 kHz."""
_WORK_S = 25e-6
_MIX_LATE_US = 100.0
"""The interleaved run counts the wake-ups later than this (µs) per mode, and their time runnable."""
_WARMUP_S = 6.0
"""The loop runs unmeasured until its tags are this old: a robot logs for minutes, and dbglog sends
every sample on a tag's own topic during the tag's first 5 s (a subscriber may still be matching)."""


# --- the publisher process ------------------------------------------------------------------------


def _cpu_s() -> float:
    """CPU seconds of this process and of its child processes, all threads (utime + stime)."""
    me, total = os.getpid(), 0
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:  # ended meanwhile
            continue
        if int(entry.name) == me or int(fields[1]) == me:
            total += int(fields[11]) + int(fields[12])
    return total / os.sysconf("SC_CLK_TCK")


class _RunQueue:
    """This thread's time spent runnable but not running (``/proc/thread-self/schedstat``, ns)."""

    def __init__(self) -> None:
        try:
            self._fd: int | None = os.open("/proc/thread-self/schedstat", os.O_RDONLY)
        except OSError:
            self._fd = None

    def ns(self) -> int:
        return int(os.pread(self._fd, 100, 0).split()[1]) if self._fd is not None else 0


def _work() -> None:
    end = time.perf_counter() + _WORK_S
    while time.perf_counter() < end:
        pass


def _make_calls(mode: str) -> Any:
    """Return ``step(k, clock, out)``: the iteration's 10 calls, each timed into `out`."""
    if mode == "none":

        def nothing(k: int, clock: Any, out: list[int]) -> None:
            t = clock()
            for _ in range(10):
                t2 = clock()
                out.append(t2 - t)
                t = t2

        return nothing
    if mode == "rclpy":
        import rclpy
        from rclpy.context import Context
        from rclpy.node import Node
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        from std_msgs.msg import Bool, Float64, Int64, String

        ctx = Context()
        rclpy.init(context=ctx)
        node = Node("probe_rclpy", context=ctx, enable_rosout=False, start_parameter_services=False)
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=100,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
        types = [Float64] * _FLOATS + [Int64] * _INTS + [Bool, String]
        pubs = [
            node.create_publisher(t, "/rosdashboard/" + tag, qos) for t, tag in zip(types, _TAGS, strict=True)
        ]
        msgs = [t() for t in types]
        for pub, msg, t in zip(pubs, msgs, types, strict=True):
            msg.data = t().data
            if t is Float64:
                msg.data = -1.0
            elif t is Int64:
                msg.data = -1
            elif t is String:
                msg.data = "k-1"
            pub.publish(msg)
        fpubs = list(zip(pubs[:_FLOATS], msgs[:_FLOATS], strict=True))
        ipubs = list(zip(pubs[_FLOATS : _FLOATS + _INTS], msgs[_FLOATS : _FLOATS + _INTS], strict=True))
        bpub, bmsg = pubs[-2], msgs[-2]
        spub, smsg = pubs[-1], msgs[-1]
        _make_calls.keep = (ctx, node)  # type: ignore[attr-defined]

        def raw(k: int, clock: Any, out: list[int]) -> None:
            t = clock()
            for pub, msg in fpubs:
                msg.data = float(k)
                pub.publish(msg)
                t2 = clock()
                out.append(t2 - t)
                t = t2
            for pub, msg in ipubs:
                msg.data = k
                pub.publish(msg)
                t2 = clock()
                out.append(t2 - t)
                t = t2
            bmsg.data = k % 2 == 0
            bpub.publish(bmsg)
            t2 = clock()
            out.append(t2 - t)
            t = t2
            if k % _STRING_EVERY == 0:
                smsg.data = f"k{k}"
                spub.publish(smsg)
            t2 = clock()
            out.append(t2 - t)

        return raw
    ftags, itags = _TAGS[:_FLOATS], _TAGS[_FLOATS : _FLOATS + _INTS]
    btag, stag = _TAGS[-2], _TAGS[-1]
    logfloat: Any
    logint: Any
    logbool: Any
    logstring: Any
    if mode == "nop":  # the floor: an empty function of the same signature, called the same way

        def nop(
            tag: str,
            value: object,
            *,
            msg_type: object = None,
            once: bool = False,
            throttle: float | None = None,
            skip_first: bool = False,
        ) -> None:
            pass

        logfloat = logint = logbool = logstring = nop
    else:
        import dbglog

        if mode == "off" and dbglog.enabled:  # the interleaved run: the functions DBGLOG=off binds
            from dbglog.api import _disabled as off

            logfloat, logint, logbool, logstring = off.logfloat, off.logint, off.logbool, off.logstring
        else:
            assert dbglog.enabled == (mode in _DBGLOG_MODES), (mode, dbglog.enabled)
            if mode == "on":
                dbglog.init()
            logfloat, logint, logbool, logstring = (
                dbglog.logfloat,
                dbglog.logint,
                dbglog.logbool,
                dbglog.logstring,
            )
            if mode == "py":  # the same functions without their compiled hot path (docs/api.md)
                logfloat, logint, logbool, logstring = (
                    getattr(f, "slow", f) for f in (logfloat, logint, logbool, logstring)
                )
    for tag in ftags:
        logfloat(tag, -1.0)
    for tag in itags:
        logint(tag, -1)
    logbool(btag, True)
    logstring(stag, "k-1")

    def step(k: int, clock: Any, out: list[int]) -> None:
        t = clock()
        value = float(k)
        for tag in ftags:
            logfloat(tag, value)
            t2 = clock()
            out.append(t2 - t)
            t = t2
        for tag in itags:
            logint(tag, k)
            t2 = clock()
            out.append(t2 - t)
            t = t2
        logbool(btag, k % 2 == 0)
        t2 = clock()
        out.append(t2 - t)
        t = t2
        logstring(stag, f"k{k}", throttle=0.1)
        t2 = clock()
        out.append(t2 - t)

    return step


def _pct(values: list[float], q: float) -> float:
    values = sorted(values)
    return values[min(len(values) - 1, int(q * len(values)))] if values else float("nan")


def publisher(mode: str, seconds: float) -> None:
    """Set up, say ``ready``, wait for ``go``, run the loop, print the figures, wait for ``exit``."""
    step = _make_calls(mode)
    created = time.monotonic()
    print("ready", flush=True)
    sys.stdin.readline()
    n = int(seconds * 1000)
    calls: list[int] = []
    starts: list[float] = []
    clock = time.perf_counter_ns
    warmup = 0
    while warmup < 200 or time.monotonic() - created < _WARMUP_S:  # not measured (values -2)
        step(-2, clock, [])
        warmup += 1
        time.sleep(0.001)
    print("measuring", flush=True)
    runq = _RunQueue()
    late: list[tuple[float, float]] = []
    """(sleep overshoot, run-queue wait) in µs of each wake-up more than 0.5 ms late."""
    cpu0, wall0 = _cpu_s(), time.monotonic()
    deadline = time.monotonic()
    for k in range(n):
        starts.append(time.monotonic())
        _work()
        step(k, clock, calls)
        deadline += 0.001
        rest = deadline - time.monotonic()
        if rest > 0:
            q0, t0 = runq.ns(), time.monotonic()
            time.sleep(rest)
            over = (time.monotonic() - t0 - rest) * 1e6
            if over > 500:
                late.append((over, (runq.ns() - q0) / 1e3))
    wall = time.monotonic() - wall0
    cpu = _cpu_s() - cpu0
    periods = [(b - a) * 1e6 for a, b in itertools.pairwise(starts)]
    samples = n * (_FLOATS + _INTS + 1) + n // _STRING_EVERY
    per_call = [float(c) for c in calls]
    print(
        json.dumps(
            {
                "call_p50_ns": _pct(per_call, 0.5),
                "call_p99_ns": _pct(per_call, 0.99),
                "position_p50_ns": [_pct(per_call[i::10], 0.5) for i in range(10)],
                "position_p90_ns": [_pct(per_call[i::10], 0.9) for i in range(10)],
                "period_p50_us": _pct(periods, 0.5),
                "period_p99_us": _pct(periods, 0.99),
                "late_wakeups": len(late),
                "late_runqueue_share": sum(q for _, q in late) / sum(o for o, _ in late) if late else None,
                "cpu_s": cpu,
                "wall_s": wall,
                "samples": samples,
                "warmup": warmup,
                "n": n,
            }
        ),
        flush=True,
    )
    sys.stdin.readline()
    if mode == "on":
        import dbglog

        dbglog.flush(5.0)


_MIX_MODES = ("none", "nop", "off", "on", "py")
_DBGLOG_MODES = ("on", "py")
"""The modes that publish: dbglog on, through its compiled hot path and through the Python one."""
_MIX_BLOCK = 500
"""Iterations per block of one mode in the interleaved run (0.5 s)."""
_MIX_SETTLE = 20
"""The first iterations of each block that are run but not measured: the publisher thread's last flush
of a dbglog block, at most 10 ms later, spills into the next block (two of the five modes are dbglog,
so without this margin the blocks after them carried some of their cost)."""


def set_thread_slice(microseconds: float) -> None:
    """Give the calling thread its own scheduler slice (Linux >= 6.12, EEVDF's ``sched_runtime``).

    A thread with a shorter slice than the one running on its CPU may preempt it at once when it wakes
    up; with the default (here 1.4 ms) a waking loop can wait for the running task's slice to end.

    Raises:
        OSError: the kernel refused (older than 6.12, or a value outside 0.1-100 ms).
    """
    import ctypes

    class _SchedAttr(ctypes.Structure):
        _fields_ = [
            ("size", ctypes.c_uint32),
            ("sched_policy", ctypes.c_uint32),
            ("sched_flags", ctypes.c_uint64),
            ("sched_nice", ctypes.c_int32),
            ("sched_priority", ctypes.c_uint32),
            ("sched_runtime", ctypes.c_uint64),
            ("sched_deadline", ctypes.c_uint64),
            ("sched_period", ctypes.c_uint64),
            ("sched_util_min", ctypes.c_uint32),
            ("sched_util_max", ctypes.c_uint32),
        ]

    libc = ctypes.CDLL(None, use_errno=True)
    attr = _SchedAttr()
    get_attr, set_attr = 315, 314  # x86_64 syscall numbers of sched_getattr / sched_setattr
    if libc.syscall(get_attr, 0, ctypes.byref(attr), ctypes.sizeof(attr), 0) != 0:
        raise OSError(ctypes.get_errno(), f"sched_getattr: {os.strerror(ctypes.get_errno())}")
    attr.size = ctypes.sizeof(attr)
    attr.sched_runtime = int(microseconds * 1000)
    if libc.syscall(set_attr, 0, ctypes.byref(attr), 0) != 0:
        raise OSError(
            ctypes.get_errno(), f"sched_setattr slice {microseconds} us: {os.strerror(ctypes.get_errno())}"
        )


def publisher_mixed(seconds: float, slice_us: float | None = None, writer: str = "ordinary") -> None:
    """The interleaved run: one process alternates blocks of no calls, the empty function, dbglog off, and
    dbglog on with its compiled hot path and with the Python one.

    Each block of `_MIX_BLOCK` iterations runs one mode, in a new random order every round, so the
    machine's load (other processes, this VM's neighbours) falls on all of them alike: the loop period's
    p99 per mode compares dbglog with the same loop without calls *in the same minutes*, which
    separate runs on a shared 2-core machine cannot (their p99 drifts ±50 % run to run).

    `writer` ``idle`` puts dbglog's writer thread under ``SCHED_IDLE`` once it exists (what 567eb5d
    shipped; docs/api.md says why it is an ordinary thread now).
    """
    steps = {mode: _make_calls(mode) for mode in _MIX_MODES}
    if slice_us is not None:
        set_thread_slice(slice_us)
    created = time.monotonic()
    print("ready", flush=True)
    sys.stdin.readline()
    clock = time.perf_counter_ns
    warmup = 0
    while warmup < 200 or time.monotonic() - created < _WARMUP_S:
        steps["on"](-2, clock, [])
        warmup += 1
        time.sleep(0.001)
    if writer == "idle":
        from dbglog.api._public import RUNTIME

        if RUNTIME._writer is None:
            raise SystemExit("bench_probe: --writer idle, but dbglog has no writer thread here")
        os.sched_setscheduler(RUNTIME._writer.native_id, os.SCHED_IDLE, os.sched_param(0))
    print("measuring", flush=True)
    rounds = max(1, int(seconds * 1000) // (_MIX_BLOCK * len(_MIX_MODES)))
    periods: dict[str, list[float]] = {m: [] for m in _MIX_MODES}
    calls: dict[str, list[float]] = {m: [] for m in _MIX_MODES}
    runq = _RunQueue()
    late: dict[str, list[tuple[float, float]]] = {m: [] for m in _MIX_MODES}
    """Per mode, (sleep overshoot, run-queue wait) in µs of each wake-up more than `_MIX_LATE_US` late."""
    rng = random.Random(7)
    k = 0
    on_iterations = 0
    deadline = time.monotonic()
    previous: tuple[str, float, int] | None = None
    for _ in range(rounds):
        order = list(_MIX_MODES)
        rng.shuffle(order)
        for mode in order:
            step, out = steps[mode], calls[mode]
            timed: list[int] = []
            for i in range(_MIX_BLOCK):
                start = time.monotonic()
                if previous is not None and previous[2] >= _MIX_SETTLE:
                    periods[previous[0]].append((start - previous[1]) * 1e6)
                previous = (mode, start, i)
                _work()
                step(k, clock, timed)
                k += 1
                deadline += 0.001
                rest = deadline - time.monotonic()
                if rest > 0:
                    q0, t0 = runq.ns(), time.monotonic()
                    time.sleep(rest)
                    over = (time.monotonic() - t0 - rest) * 1e6
                    if over > _MIX_LATE_US and i >= _MIX_SETTLE:
                        late[mode].append((over, (runq.ns() - q0) / 1e3))
                elif rest < -0.001:  # a missed deadline is skipped, as a ROS 2 timer does: no burst
                    deadline = time.monotonic()
            out.extend(float(c) for c in timed[_MIX_SETTLE * 10 :])
            on_iterations += _MIX_BLOCK if mode in _DBGLOG_MODES else 0
    figures = {
        mode: {
            "period_p50_us": _pct(periods[mode], 0.5),
            "period_p99_us": _pct(periods[mode], 0.99),
            "call_p50_ns": _pct(calls[mode], 0.5),
            "call_p99_ns": _pct(calls[mode], 0.99),
            "position_p50_ns": [_pct(calls[mode][i::10], 0.5) for i in range(10)],
            "position_p90_ns": [_pct(calls[mode][i::10], 0.9) for i in range(10)],
            "iterations": len(periods[mode]),
            "late_wakeups": len(late[mode]),
            "late_runqueue_share": (
                sum(q for _, q in late[mode]) / sum(o for o, _ in late[mode]) if late[mode] else None
            ),
        }
        for mode in _MIX_MODES
    }
    print(json.dumps({"modes": figures, "warmup": warmup, "n": on_iterations}), flush=True)
    sys.stdin.readline()
    import dbglog

    dbglog.flush(5.0)


# --- the subscriber process (a real viewer engine) --------------------------------------------------


def subscriber(expect: int, history: int, cpu: str) -> None:
    """Bind the 10 tags in a real engine; print ``bound``, then counts/order/latency on a stdin line.

    The process shares the CPU as ``dbglog view --cpu`` would (`cpu`), before any thread starts.
    """
    import importlib

    try:
        sched: Any = importlib.import_module("dbglog._sched")
    except ImportError:  # a source tree from before ``--cpu`` (``--before``): an ordinary process
        sched = None
    if sched is not None:
        refused = sched.set_cpu_policy(sched.CpuPolicy(cpu))
        assert refused is None, refused

    try:
        data = "dbglog.viewer._data."
        importlib.import_module(data + "_engine")
    except ImportError:  # a source tree from before the viewer's packages (``--before``)
        data = "dbglog.viewer."
    engine_cls: Any = importlib.import_module(data + "_engine").Engine
    binding_cls: Any = importlib.import_module(data + "_model").Binding

    bindings = [binding_cls("/rosdashboard/" + tag) for tag in _TAGS]
    with engine_cls(history=history, measure_latency=True, node_name="probe_viewer") as engine:
        for b in bindings:
            engine.bind(b)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not all(engine.snapshot(b).count >= 1 for b in bindings):
            time.sleep(0.02)
        print("bound", flush=True)
        sys.stdin.readline()  # "start": the publisher's measured loop begins
        cpu0 = engine.stats().thread_cpu_s
        total = int(sys.stdin.readline().split()[1])  # initial value + warm-up + measured iterations
        cpu = engine.stats().thread_cpu_s - cpu0
        wanted = dict.fromkeys(bindings[:-1], total)
        stable_since, last = time.monotonic(), -1
        end = time.monotonic() + 30
        while time.monotonic() < end:
            seen = sum(engine.snapshot(b).count for b in bindings)
            if all(engine.snapshot(b).count >= n for b, n in wanted.items()):
                break
            if seen != last:
                stable_since, last = time.monotonic(), seen
            elif time.monotonic() - stable_since > 2.0:
                break
            time.sleep(0.05)
        counts, ordered = [], True
        for b in bindings[:-1]:
            snap = engine.snapshot(b)
            counts.append(snap.count)
            vals = [v for v in snap.values.tolist() if v >= 0] if b != bindings[-2] else []
            if any(b <= a for a, b in itertools.pairwise(vals)):  # gaps are counted, not flagged
                ordered = False
        raw = engine.latencies()
        lat = sorted(raw[raw == raw].tolist())
        p99 = lat[int(0.99 * (len(lat) - 1))] * 1e3 if lat else None
        p50 = lat[int(0.5 * (len(lat) - 1))] * 1e3 if lat else None
        p90 = lat[int(0.9 * (len(lat) - 1))] * 1e3 if lat else None
        print(
            json.dumps(
                {
                    "min_count": min(counts),
                    "counts": counts,
                    "ordered": ordered,
                    "latency_p99_ms": p99,
                    "latency_p50_ms": p50,
                    "latency_p90_ms": p90,
                    "expected": total,
                    "engine_cpu_s": cpu,
                }
            ),
            flush=True,
        )


# --- the orchestrator -----------------------------------------------------------------------------


def _env(tree: Path, mode: str, domain: int) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("DBGLOG", "DBGLOG_STRICT")}
    env.update(
        PYTHONPATH=str(tree),
        ROS_DOMAIN_ID=str(domain),
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        DBGLOG="off" if mode == "off" else "on",
    )
    return env


def _spawn(args: list[str], env: dict[str, str]) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, str(Path(__file__).resolve()), *args],
        env=env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd="/",
    )


def _readline(proc: subprocess.Popen[str], timeout: float) -> str:
    import select

    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], timeout)
    if not ready:
        raise TimeoutError(f"no answer from {proc.args!r} in {timeout} s")
    return proc.stdout.readline().strip()


def _send(proc: subprocess.Popen[str], line: str) -> None:
    assert proc.stdin is not None
    proc.stdin.write(line + "\n")
    proc.stdin.flush()


def _start_echo(tree: Path, domain: int) -> tuple[subprocess.Popen[str], list[str]]:
    """Start ``dbglog echo probe/f0`` of `tree`; return it once it printed its first (current) value."""
    import threading

    echo = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "echo", _TAGS[0]],
        env=_env(tree, "on", domain),
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        cwd="/",
    )
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(echo.stdout or []), daemon=True).start()
    deadline = time.monotonic() + 60
    while not lines and time.monotonic() < deadline:
        time.sleep(0.05)
    return echo, lines


def _echo_result(echo: subprocess.Popen[str], lines: list[str], n: int) -> dict[str, Any]:
    """Stop echo once it stopped printing; count the loop's values it printed, and check their order."""
    last, since = -1, time.monotonic()
    while time.monotonic() - since < 2.0:
        if len(lines) != last:
            last, since = len(lines), time.monotonic()
        time.sleep(0.1)
    echo.terminate()
    echo.wait(10)
    values = [float(v) for v in lines if v.strip() and float(v) >= 0]
    return {"echo_count": len(values), "echo_ordered": values == [float(k) for k in range(len(values))]}


def run_interleaved(
    seconds: float, slice_us: float | None = None, cpu: str = "background", writer: str = "ordinary"
) -> dict[str, Any]:
    """One interleaved publisher (`publisher_mixed`, dbglog's writer thread `writer`) with a real viewer
    engine attached (sharing the CPU as ``dbglog view --cpu`` `cpu` does); its figures."""
    domain = random.randint(101, 200)
    sliced = [] if slice_us is None else ["--loop-slice-us", str(slice_us)]
    pub = _spawn(
        ["--role", "publisher", "--mode", "mix", "--seconds", str(seconds), "--writer", writer, *sliced],
        _env(ROOT, "on", domain),
    )
    engine = None
    try:
        assert _readline(pub, 60) == "ready"
        n = int(seconds * 1000)
        engine = _spawn(
            ["--role", "subscriber", "--expect", str(n), "--history", str(n + 20_000), "--viewer-cpu", cpu],
            _env(ROOT, "on", domain),
        )
        assert _readline(engine, 90) == "bound"
        time.sleep(0.5)
        _send(pub, "go")
        assert _readline(pub, 60) == "measuring"
        _send(engine, "start")
        result: dict[str, Any] = json.loads(_readline(pub, seconds * 1.5 + 60))
        primed = len(_DBGLOG_MODES)  # each dbglog mode's first call per tag
        _send(engine, f"report {primed + result['warmup'] + result['n']}")
        result.update(json.loads(_readline(engine, 60)))
        _send(pub, "exit")
        pub.wait(30)
        return result
    finally:
        for proc in (pub, engine):
            if proc is not None and proc.poll() is None:
                proc.kill()


def _print_interleaved(
    runs: list[dict[str, Any]], seconds: float, loop: str = "", cpu: str = "background", writer: str = ""
) -> None:
    sys.path.insert(0, str(ROOT))
    from benchmarks._common import print_table

    names = {
        "none": "no calls",
        "nop": "empty function",
        "off": "dbglog off",
        "on": "dbglog on",
        "py": "dbglog on, Python hot path",
    }
    rows = []
    for mode in _MIX_MODES:
        p99 = [r["modes"][mode]["period_p99_us"] for r in runs]
        ratio = [r["modes"][mode]["period_p99_us"] / r["modes"]["none"]["period_p99_us"] for r in runs]
        lates = [r["modes"][mode].get("late_wakeups", 0) for r in runs]
        shares = [s for r in runs if (s := r["modes"][mode].get("late_runqueue_share")) is not None]
        share = f" ({statistics.median(shares):.0%})" if shares else ""
        rows.append(
            [
                names[mode],
                f"{statistics.median(r['modes'][mode]['call_p50_ns'] for r in runs) / 1e3:.2f}",
                f"{statistics.median(r['modes'][mode]['call_p99_ns'] for r in runs) / 1e3:.1f}",
                f"{statistics.median(r['modes'][mode]['period_p50_us'] for r in runs):.0f}",
                f"{statistics.median(p99):.0f} ({min(p99):.0f}-{max(p99):.0f})",
                f"{statistics.median(ratio):.3f} ({min(ratio):.3f}-{max(ratio):.3f})",
                f"{statistics.median(lates):.0f}{share}",
            ]
        )
    delivered = [
        f"{r['min_count']}/{r['expected']}{'' if r['ordered'] else ' (out of order!)'}" for r in runs
    ]
    print_table(
        f"Interleaved 1 kHz loop{loop}{writer} with a viewer attached (--cpu {cpu}): blocks of {_MIX_BLOCK} "
        f"iterations per mode, random order, {seconds:.0f} s per run, {len(runs)} runs (medians, ranges); "
        "samples of the dbglog "
        f"blocks in the viewer (min per tag / sent): {', '.join(delivered)}",
        [
            "Calls",
            "per call p50 µs",
            "per call p99 µs",
            "period p50 µs",
            "period p99 µs",
            "p99 / no calls",
            f"wake-ups > {_MIX_LATE_US:.0f} µs late (share waiting for a CPU)",
        ],
        rows,
    )
    print_table(
        "Per call by position in the iteration, p50 / p90 µs, medians of the runs (1-6 logfloat, 7-8 logint, "
        "9 logbool, 10 logstring throttled; 1, 7, 9 and 10 are the first call of their function)",
        ["Calls", *(str(i) for i in range(1, 11))],
        [
            [
                names[mode],
                *(
                    f"{statistics.median(r['modes'][mode]['position_p50_ns'][i] for r in runs) / 1e3:.1f} / "
                    f"{statistics.median(r['modes'][mode]['position_p90_ns'][i] for r in runs) / 1e3:.1f}"
                    for i in range(10)
                ),
            ]
            for mode in _MIX_MODES
            if mode != "none"
        ],
    )


def run_once(
    tree: Path, mode: str, sub: bool, seconds: float, echo: bool = False, cpu: str = "background"
) -> dict[str, Any]:
    """One publisher run (and a viewer engine process when `sub`, sharing the CPU as ``--cpu`` `cpu`);
    return its figures."""
    domain = random.randint(101, 200)
    pub = _spawn(["--role", "publisher", "--mode", mode, "--seconds", str(seconds)], _env(tree, mode, domain))
    engine = None
    echo_proc: tuple[subprocess.Popen[str], list[str]] | None = None
    try:
        assert _readline(pub, 60) == "ready"
        if sub:
            n = int(seconds * 1000)
            args = ["--role", "subscriber", "--expect", str(n), "--history", str(n + 20_000)]
            args += ["--viewer-cpu", cpu]
            engine = _spawn(args, _env(tree, "on", domain))
            assert _readline(engine, 90) == "bound"
            if echo:
                echo_proc = _start_echo(tree, domain)
            time.sleep(0.5)
        _send(pub, "go")
        assert _readline(pub, 60) == "measuring"
        if engine is not None:
            _send(engine, "start")
        result: dict[str, Any] = json.loads(_readline(pub, seconds + 60))
        if engine is not None:
            _send(engine, f"report {1 + result['warmup'] + result['n']}")
            result.update(json.loads(_readline(engine, 60)))
        if echo_proc is not None:
            result.update(_echo_result(*echo_proc, int(seconds * 1000)))
        _send(pub, "exit")
        pub.wait(30)
        return result
    finally:
        for proc in (pub, engine, echo_proc[0] if echo_proc else None):
            if proc is not None and proc.poll() is None:
                proc.kill()


def main() -> None:
    """Run every configuration in alternation and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--role", choices=["main", "publisher", "subscriber"], default="main")
    parser.add_argument("--mode", choices=["none", "nop", "rclpy", "off", "on", "mix"], default="on")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--expect", type=int, default=0)
    parser.add_argument("--history", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--before", type=Path, default=None, help="another source tree to compare")
    parser.add_argument("--only", default="", help="comma-separated config names to run")
    parser.add_argument(
        "--echo", action="store_true", help="also run `dbglog echo` on one tag (with a viewer)"
    )
    parser.add_argument(
        "--viewer", choices=["both", "with", "without"], default="both", help="runs with/without a viewer"
    )
    parser.add_argument(
        "--interleaved",
        action="store_true",
        help="only the interleaved run: no calls / empty function / dbglog on in alternating blocks of one "
        "process, a viewer attached (the loop period's p99 compared under the same load)",
    )
    parser.add_argument(
        "--loop-slice-us",
        type=float,
        default=None,
        help="with --interleaved: also run the loop with this scheduler slice (Linux >= 6.12; runs "
        "alternate with the default slice)",
    )
    parser.add_argument(
        "--viewer-cpu",
        choices=["background", "normal", "both"],
        default="background",
        help="how the viewer engine shares the CPU (dbglog view --cpu; default background, as dbglog view "
        "does); both: with --interleaved, runs alternate the two",
    )
    parser.add_argument(
        "--writer",
        choices=["ordinary", "idle", "both"],
        default="ordinary",
        help="with --interleaved: dbglog's writer thread as shipped (ordinary) or under SCHED_IDLE (as "
        "567eb5d had it); both: runs alternate the two",
    )
    args = parser.parse_args()
    if args.viewer_cpu == "both" and not args.interleaved and args.role == "main":
        parser.error("--viewer-cpu both needs --interleaved (separate runs take one policy)")
    if args.writer == "both" and args.role != "main":
        parser.error("--writer both is for the main role")
    if args.writer != "ordinary" and args.role == "main" and not args.interleaved:
        parser.error("--writer idle/both needs --interleaved (separate runs keep the writer as shipped)")
    if args.role == "publisher" and args.mode == "mix":
        publisher_mixed(args.seconds, args.loop_slice_us, args.writer)
        return
    if args.role == "publisher":
        publisher(args.mode, args.seconds)
        return
    cpus = ["background", "normal"] if args.viewer_cpu == "both" else [args.viewer_cpu]
    if args.interleaved:
        slices: list[float | None] = [None] if args.loop_slice_us is None else [None, args.loop_slice_us]
        writers = ["ordinary", "idle"] if args.writer == "both" else [args.writer]
        arms = [(slice_us, cpu, writer) for writer in writers for cpu in cpus for slice_us in slices]
        by_arm: dict[tuple[float | None, str, str], list[dict[str, Any]]] = {arm: [] for arm in arms}
        for rep in range(args.repeats):
            for arm in arms if rep % 2 == 0 else arms[::-1]:
                res = run_interleaved(args.seconds, *arm)
                by_arm[arm].append(res)
                note = f"# interleaved repeat {rep} slice {arm[0]} viewer cpu {arm[1]} writer {arm[2]}: "
                print(note + json.dumps(res), file=sys.stderr, flush=True)
        for (slice_us, cpu, writer), runs in by_arm.items():
            slice_text = "the default" if slice_us is None else f"{slice_us:g} µs"
            loop = "" if args.loop_slice_us is None else f" (its thread's slice: {slice_text})"
            label = f", dbglog's writer thread {writer}" if len(writers) > 1 else ""
            _print_interleaved(runs, args.seconds, loop, cpu, label)
        return
    if args.role == "subscriber":
        subscriber(args.expect, args.history, args.viewer_cpu)
        return
    configs: list[tuple[str, Path, str]] = [
        ("no calls", ROOT, "none"),
        ("empty function", ROOT, "nop"),
        ("raw rclpy publish", ROOT, "rclpy"),
        ("dbglog off", ROOT, "off"),
        ("dbglog on (after)", ROOT, "on"),
    ]
    if args.before is not None:
        configs.append(("dbglog on (before)", args.before, "on"))
    if args.only:
        keep = set(args.only.split(","))
        configs = [c for c in configs if c[2] in keep or c[0] in keep]
    results: dict[tuple[str, bool], list[dict[str, Any]]] = {}
    for rep in range(args.repeats):
        for sub in {"both": (False, True), "with": (True,), "without": (False,)}[args.viewer]:
            for name, tree, mode in configs:
                echo = args.echo and sub and mode in ("rclpy", "on")
                res = run_once(tree, mode, sub, args.seconds, echo=echo, cpu=cpus[0])
                results.setdefault((name, sub), []).append(res)
                print(f"# repeat {rep} {name} sub={sub}: {json.dumps(res)}", file=sys.stderr, flush=True)
    _print(configs, results)


def _med(runs: list[dict[str, Any]], key: str) -> float:
    values = [r[key] for r in runs if r.get(key) is not None]
    return statistics.median(values) if values else float("nan")


Results = dict[tuple[str, bool], list[dict[str, Any]]]


def _print(configs: list[tuple[str, Path, str]], results: Results) -> None:
    sys.path.insert(0, str(ROOT))
    from benchmarks._common import print_table

    base_cpu = {sub: _med(results.get(("no calls", sub), []), "cpu_s") for sub in (False, True)}
    rows, positions = [], []
    for sub in (False, True):
        for name, _, mode in configs:
            runs = results.get((name, sub), [])
            if not runs:
                continue
            wall = _med(runs, "wall_s")
            rate = _med(runs, "samples") / wall / 10_000
            extra = (_med(runs, "cpu_s") - base_cpu[sub]) / wall / rate * 1e3 if name != "no calls" else 0.0
            delivered = ""
            if sub and mode in ("rclpy", "on"):
                delivered = f"{_med(runs, 'min_count'):.0f} / {_med(runs, 'expected'):.0f}"
                if not all(r.get("ordered", True) for r in runs):
                    delivered += " (out of order!)"
                if "echo_count" in runs[0]:
                    delivered += f"; echo {_med(runs, 'echo_count'):.0f} / {runs[0]['n']}"
                    if not all(r.get("echo_ordered", True) for r in runs):
                        delivered += " (out of order!)"
            share = _med(runs, "late_runqueue_share")
            viewer = _med(runs, "engine_cpu_s") / wall * 1e3 if sub else float("nan")
            rows.append(
                [
                    name,
                    "1 viewer" if sub else "none",
                    f"{_med(runs, 'call_p50_ns') / 1e3:.2f}",
                    f"{_med(runs, 'call_p99_ns') / 1e3:.1f} ({_range(runs, 'call_p99_ns', 1e3)})",
                    f"{_med(runs, 'period_p99_us'):.0f} ({_range(runs, 'period_p99_us')})",
                    f"{_med(runs, 'late_wakeups'):.0f} ({share:.0%})" if share == share else "0",
                    delivered,
                    f"{_med(runs, 'latency_p99_ms'):.1f}" if sub and mode in ("rclpy", "on") else "",
                    f"{extra:.0f}" if name != "no calls" else "",
                    f"{viewer:.0f}" if sub else "",
                ]
            )
            if mode != "none":
                p50 = [statistics.median(r["position_p50_ns"][i] for r in runs) / 1e3 for i in range(10)]
                p90 = [statistics.median(r["position_p90_ns"][i] for r in runs) / 1e3 for i in range(10)]
                cells = [f"{a:.1f} / {b:.1f}" for a, b in zip(p50, p90, strict=True)]
                positions.append([name, "1 viewer" if sub else "none", *cells])
    print_table(
        f"1 kHz loop, 10 calls/iteration, {len(next(iter(results.values())))} repeats (medians, ranges)",
        [
            "Calls",
            "Subscriber",
            "per call p50 µs",
            "per call p99 µs",
            "loop period p99 µs",
            "wake-ups > 0.5 ms late (share waiting for a CPU)",
            "min samples/tag in viewer",
            "latency p99 ms",
            "CPU ms/s per 10k samples/s",
            "viewer CPU ms/s",
        ],
        rows,
    )
    print_table(
        "Per call by position in the iteration, p50 / p90 µs (1-6 logfloat, 7-8 logint, 9 logbool, "
        "10 logstring throttled; 1, 7, 9 and 10 are the first call of their function)",
        ["Calls", "Subscriber", *(str(i) for i in range(1, 11))],
        positions,
    )


def _range(runs: list[dict[str, Any]], key: str, scale: float = 1.0) -> str:
    values = [r[key] / scale for r in runs if r.get(key) is not None]
    return f"{min(values):.0f}-{max(values):.0f}" if values else ""


if __name__ == "__main__":
    main()
