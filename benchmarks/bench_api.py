"""Cost of a dbglog call: switched off vs an empty function, switched on vs raw rclpy, and two peers.

Run: ``.venv/bin/python benchmarks/bench_api.py`` (prints Markdown tables). Each figure is the median
over repeats of the mean time per call; a subject and its baseline are timed in alternation in the same
process. The switched-off part needs ``DBGLOG=off`` at import, so it runs in a child process.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
import timeit
import types
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks._common import local_ros_env, print_table  # noqa: E402

Timing = dict[str, float]


def _time_alternating(
    subjects: dict[str, tuple[str, dict[str, Any]]],
    calls: int,
    repeats: int,
    between: Callable[[], object] | None = None,
) -> Timing:
    """Time each statement `calls` times per repeat, in alternation; return the median ns per call.

    `between` runs, untimed, after every timed batch (dbglog's: publish what the batch queued, so that
    no batch meets a full queue: 15 repeats of 20,000 calls would fill it and time the drops instead).
    """
    timers = {name: timeit.Timer(stmt, globals=ns) for name, (stmt, ns) in subjects.items()}
    for timer in timers.values():  # warm-up
        timer.timeit(number=max(1, calls // 10))
        if between is not None:
            between()
    samples: dict[str, list[float]] = {name: [] for name in timers}
    for _ in range(repeats):
        for name, timer in timers.items():
            samples[name].append(timer.timeit(number=calls) / calls * 1e9)
            if between is not None:
                between()
    return {name: statistics.median(values) for name, values in samples.items()}


def _nop(tag: str, value: float) -> None:
    """The baseline: an empty function of the two arguments a call passes."""


def _nop_same_signature(
    tag: str,
    value: float,
    *,
    msg_type: object = None,
    once: bool = False,
    throttle: float | None = None,
    skip_first: bool = False,
) -> None:
    """The other baseline: an empty function with logfloat's whole signature (options keyword-only)."""


def measure_disabled(calls: int, repeats: int) -> Timing:
    """Runs with DBGLOG=off: dbglog.logfloat vs an empty function via a module attribute vs logging.debug."""
    import logging

    import dbglog

    assert not dbglog.enabled, "run with DBGLOG=off"
    baseline = types.ModuleType("baseline")
    baseline.nop = _nop  # type: ignore[attr-defined]
    baseline.nop_sig = _nop_same_signature  # type: ignore[attr-defined]
    logging.getLogger().setLevel(logging.WARNING)
    ns = {"dbglog": dbglog, "baseline": baseline, "logging": logging}
    result = _time_alternating(
        {
            "nop": ("baseline.nop('x', 1.0)", ns),
            "nop_sig": ("baseline.nop_sig('x', 1.0)", ns),
            "dbglog": ("dbglog.logfloat('x', 1.0)", ns),
            "logging": ("logging.debug('x %s', 1.0)", ns),
        },
        calls,
        repeats,
    )
    result["rclpy_imported"] = float("rclpy" in sys.modules)
    return result


_SUBSCRIBER = """
import sys, time
import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.executors import SingleThreadedExecutor
from std_msgs.msg import Float64
ctx = Context(); rclpy.init(context=ctx)
node = Node("bench_subscriber", context=ctx)
for topic in sys.argv[1:]:
    node.create_subscription(Float64, topic, lambda m: None, 10)
ex = SingleThreadedExecutor(context=ctx); ex.add_node(node)
print("ready", flush=True)
try:
    while True:
        ex.spin_once(timeout_sec=0.1)
except KeyboardInterrupt:
    pass
"""


_BIG_INT = 2**62 + 1
"""An integer a float64 cannot hold (the batch carries it exactly)."""


def measure_enabled(calls: int, repeats: int, with_subscriber: bool) -> Timing:
    """dbglog.logfloat (switched on) vs raw rclpy publish of a reused Float64 on a cached publisher."""
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node
    from std_msgs.msg import Float64

    import dbglog
    from dbglog._ros._qos import tag_qos
    from dbglog.api._public import RUNTIME

    assert dbglog.enabled, "run without DBGLOG=off"
    ctx = Context()
    rclpy.init(context=ctx)
    node = Node("bench_raw", context=ctx)
    pub = node.create_publisher(Float64, "/bench/raw", tag_qos())
    msg = Float64(data=1.0)
    dbglog.logfloat("bench/x", 1.0)
    dbglog.logint("bench/n", _BIG_INT)
    sub = None
    if with_subscriber:
        sub = subprocess.Popen(
            [sys.executable, "-c", _SUBSCRIBER, "/bench/raw", "/rosdashboard/bench/x"],
            stdout=subprocess.PIPE,
            text=True,
        )
        assert sub.stdout is not None
        sub.stdout.readline()
        dbglog_pub = RUNTIME.channels["bench/x"].publisher
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and not (
            pub.get_subscription_count() and dbglog_pub.get_subscription_count()
        ):
            time.sleep(0.05)
    try:
        ns = {"dbglog": dbglog, "pub": pub, "msg": msg, "big": _BIG_INT}
        return _time_alternating(
            {
                "raw": ("pub.publish(msg)", ns),
                "dbglog": ("dbglog.logfloat('bench/x', 1.0)", ns),
                "dbglog_int": ("dbglog.logint('bench/n', big)", ns),
            },
            calls,
            repeats,
            between=lambda: dbglog.flush(30.0),
        )
    finally:
        if sub is not None:
            sub.terminate()
            sub.wait(10)
        node.destroy_node()
        rclpy.shutdown(context=ctx)
        dbglog.shutdown()


def measure_peers(calls: int, repeats: int) -> dict[str, float | str]:
    """rerun-sdk ``rr.log(tag, rr.Scalars(x))`` and foxglove-sdk ``Channel.log``, each with a file sink."""
    out: dict[str, float | str] = {}
    tmp = Path(tempfile.mkdtemp(prefix="dbglog_bench_"))
    try:
        import rerun as rr
    except ImportError:
        out["rerun"] = "not installed"
    else:
        rr.init("dbglog_bench", spawn=False)
        rr.save(str(tmp / "bench.rrd"))
        ns: dict[str, Any] = {"rr": rr}
        out["rerun"] = _time_alternating({"rerun": ("rr.log('x', rr.Scalars(1.0))", ns)}, calls, repeats)[
            "rerun"
        ]
        rr.disconnect()
    try:
        import foxglove
    except ImportError:
        out["foxglove"] = "not installed"
    else:
        writer = foxglove.open_mcap(str(tmp / "bench.mcap"), allow_overwrite=True)
        channel = foxglove.Channel("/x", message_encoding="json")
        ns = {"channel": channel, "payload": {"data": 1.0}}
        out["foxglove"] = _time_alternating({"foxglove": ("channel.log(payload)", ns)}, calls, repeats)[
            "foxglove"
        ]
        writer.close()
    return out


def _ratio(a: float, b: float) -> str:
    return f"{a / b:.2f}×"


def _run_disabled_child(calls: int, repeats: int) -> Timing:
    env = {**os.environ, "DBGLOG": "off", "PYTHONPATH": str(ROOT)}
    code = textwrap.dedent(
        f"""
        import json
        from benchmarks.bench_api import measure_disabled
        print(json.dumps(measure_disabled({calls}, {repeats})))
        """
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True, cwd=ROOT
    )
    result: Timing = json.loads(proc.stdout.strip().splitlines()[-1])
    return result


def main(argv: list[str] | None = None) -> int:
    """Run every measurement and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--repeats", type=int, default=15, help="repeats per figure (median taken)")
    parser.add_argument("--calls", type=int, default=20_000, help="calls per repeat, switched-on figures")
    parser.add_argument("--off-calls", type=int, default=500_000, help="calls per repeat, switched off")
    parser.add_argument("--no-subscriber", action="store_true", help="skip the run with a live subscriber")
    args = parser.parse_args(argv)
    local_ros_env()

    off = _run_disabled_child(args.off_calls, args.repeats)
    print_table(
        "dbglog switched off (DBGLOG=off), ns per call",
        ["call", "ns/call", "vs empty function", "target"],
        [
            ["`baseline.nop('x', 1.0)` (empty function, module attribute)", f"{off['nop']:.1f}", "1.00×", ""],
            [
                "`baseline.nop_sig('x', 1.0)` (empty, logfloat's signature: options keyword-only)",
                f"{off['nop_sig']:.1f}",
                _ratio(off["nop_sig"], off["nop"]),
                "",
            ],
            [
                "`dbglog.logfloat('x', 1.0)`",
                f"{off['dbglog']:.1f}",
                _ratio(off["dbglog"], off["nop"]),
                "≤ 1.2×",
            ],
            [
                "`dbglog.logfloat('x', 1.0)` vs the same-signature empty function",
                f"{off['dbglog']:.1f}",
                _ratio(off["dbglog"], off["nop_sig"]),
                "≤ 1.2×",
            ],
            [
                "`logging.debug('x %s', 1.0)` (level WARNING)",
                f"{off['logging']:.1f}",
                _ratio(off["logging"], off["nop"]),
                "report",
            ],
        ],
    )
    print(f"\nrclpy imported while switched off: {bool(off['rclpy_imported'])}")

    rows: list[list[str]] = []
    runs: list[tuple[str, bool]] = [("no subscriber", False)]
    if not args.no_subscriber:
        runs.append(("one subscriber process", True))
    raw_ref = 0.0
    for label, with_sub in runs:
        on = measure_enabled(args.calls, args.repeats, with_sub)
        raw_ref = raw_ref or on["raw"]
        rows.append([f"raw `pub.publish(msg)` ({label})", f"{on['raw']:.0f}", "1.00×", ""])
        rows.append(
            [
                f"`dbglog.logfloat('bench/x', 1.0)` ({label})",
                f"{on['dbglog']:.0f}",
                _ratio(on["dbglog"], on["raw"]),
                "≤ 1.10×",
            ]
        )
        rows.append(
            [
                f"`dbglog.logint('bench/n', 2**62 + 1)` ({label})",
                f"{on['dbglog_int']:.0f}",
                _ratio(on["dbglog_int"], on["raw"]),
                "≤ 1.10×",
            ]
        )
    peers = measure_peers(args.calls, args.repeats)
    for name, label in (
        ("rerun", "rerun-sdk `rr.log(tag, rr.Scalars(x))` (.rrd file sink)"),
        ("foxglove", "foxglove-sdk `Channel.log({...})` (MCAP file sink)"),
    ):
        value = peers[name]
        if isinstance(value, str):
            rows.append([label, value, "", "report"])
        else:
            rows.append([label, f"{value:.0f}", _ratio(value, raw_ref), "report"])
    print_table(
        "dbglog switched on, ns per call (ratios vs raw rclpy publish without subscriber for peers)",
        ["call", "ns/call", "ratio", "target"],
        rows,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
