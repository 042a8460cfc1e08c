"""Recordings benchmark: ``dbglog record`` under a flood, bytes per sample on disk, loading a large file.

Run from the repository root: ``.venv/bin/python -m benchmarks.bench_record`` (``--help`` for options;
``--seconds 10 --hours 0.1`` for a quick run). Side by side, in one run:

1. **record**: publisher processes send pre-serialised ``std_msgs/Float64`` round-robin over 50 tag
   topics (dbglog's tag QoS) at a fixed total rate; the real ``dbglog record`` CLI records them; every
   message sent is looked for in the file (lost = sent - recorded), and the lost ones are grouped into
   bursts per topic (each value is a per-publisher sequence number). ``--variants`` runs alternatives
   side by side, ``--repeats`` times each, interleaved: the publishers' history depth, the recorder's
   queue depth, and a viewer engine (``bench_engine``'s receiver) beside the recorder or alone. CPU per
   message of the publishers and of the recorder, and the load average, are printed with every run.
2. **bytes per sample**: the recorded file's size over its messages, and a file of the same shape
   written directly (100 Hz signals).
3. **load**: a file of 50 topics x 100 Hz x ``--hours`` written directly with dbglog's writer, loaded
   by ``read_recording``; the same messages decoded one by one by ``mcap`` + ``mcap_ros2`` on the first
   ``--peer-minutes`` (extrapolated per message; dbglog's reader is also timed on that same part).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

_ROOT = Path(__file__).resolve().parent.parent
if str(_ROOT) not in sys.path:
    sys.path.insert(0, str(_ROOT))

from benchmarks._common import local_ros_env, print_table  # noqa: E402

_TAG = "bench_rec"


def _publisher(args: argparse.Namespace) -> None:
    """Publish pre-serialised Float64 round-robin over the tag topics at `--rate` msg/s in total."""
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node
    from std_msgs.msg import Float64

    from dbglog._ros._qos import subscription_qos, tag_qos

    context = Context()
    rclpy.init(context=context)
    node = Node("bench_record_publisher", context=context)
    mine = range(args.part, args.topics, args.publishers)
    # 0: dbglog's tag QoS, what `dbglog.logfloat`'s publishers use (reliable, transient-local, depth 100).
    qos = tag_qos() if not args.pub_depth else subscription_qos(args.pub_depth, reliable=True, transient=True)
    pubs = [node.create_publisher(Float64, f"/rosdashboard/{_TAG}/t{i}", qos) for i in mine]
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not all(p.get_subscription_count() > 0 for p in pubs):
        time.sleep(0.02)
    matched = all(p.get_subscription_count() > 0 for p in pubs)
    time.sleep(0.5)
    header = b"\x00\x01\x00\x00"
    pack = struct.Struct("<d").pack
    n_topics, rate = len(pubs), args.rate / args.publishers
    k, stride = args.part, args.publishers
    sent = 0
    cpu = time.process_time()
    start = time.monotonic()
    end = start + args.seconds
    while True:
        now = time.monotonic()
        if now >= end:
            break
        due = int((now - start) * rate)
        if sent >= due:
            time.sleep(min(0.001, (sent + 1) / rate - (now - start)))
            continue
        for _ in range(min(due - sent, 1000)):
            pubs[sent % n_topics].publish(header + pack(float(sent * stride + k)))
            sent += 1
    stop = time.monotonic()
    cpu = time.process_time() - cpu
    print(json.dumps({"matched": matched, "seconds": stop - start, "sent": sent, "cpu": cpu}), flush=True)
    time.sleep(3.0)  # keep reliable writers alive while the recorder drains
    node.destroy_node()
    rclpy.shutdown(context=context)


_SDK_ROBOT = """
import math, sys, time
import dbglog
topics, seconds, hz, seq = int(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3]), sys.argv[4] == "seq"
tags = [f"bench_sdk/t{i}" for i in range(topics)]
dbglog.init()
print("ready", flush=True)
sys.stdin.readline()
k = 0
cpu = time.process_time()
start = t = time.monotonic()
while time.monotonic() - start < seconds:
    for i, tag in enumerate(tags):
        # seq: every sample's value is its number (to find each one in the file); else a sensor-like signal.
        if seq:
            dbglog.logfloat(tag, float(k * topics + i))
        else:
            dbglog.logfloat(tag, round(math.sin(k * 0.01 + i) + 0.001 * ((k * 7919 + i) % 13), 4))
    k += 1
    t += 1.0 / hz
    time.sleep(max(0.0, t - time.monotonic()))
elapsed = time.monotonic() - start
cpu = time.process_time() - cpu
dropped = dbglog.stats().dropped  # publishes what is still queued first
print(k * topics, elapsed, cpu, dropped, flush=True)
sys.stdin.readline()
"""


def _viewer_child(topics: int, prefix: str) -> subprocess.Popen[str]:
    """Start bench_engine's receiver (the viewer's engine bound to `topics` topics); wait until ready."""
    viewer = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "benchmarks.bench_engine",
            "--role",
            "engine",
            "--topics",
            str(topics),
            "--prefix",
            prefix,
            "--latency",
            "0",
        ],
        cwd=_ROOT,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert viewer.stdout is not None
    if viewer.stdout.readline().strip() != "ready":
        raise RuntimeError("the viewer engine did not start")
    return viewer


def _viewer_report(viewer: subprocess.Popen[str]) -> tuple[int, float]:
    """Stop the viewer child; return (samples it took into its series, CPU seconds it used)."""
    time.sleep(2.0)  # let the engine drain its queues
    out_text, _ = viewer.communicate("stop\n", timeout=60)
    report = json.loads(out_text.strip().splitlines()[-1])
    samples = report["samples"]
    cpu = samples[-1][2] - samples[0][2] if len(samples) >= 2 else float("nan")
    return int(report["landed"]), cpu


def _sdk_run(
    args: argparse.Namespace,
    out: Path,
    *,
    hz: float = 100.0,
    seq: bool = False,
    recorder: bool = True,
    viewer: bool = False,
) -> dict[str, Any]:
    """The dbglog SDK logging Float64 tags at `hz`, recorded with the default targets.

    With `seq`, every value is the sample's number and the samples of the batch copy are counted;
    `viewer` runs the viewer's engine beside, bound to every tag (it reads the batch topic).
    """
    import numpy as np

    from dbglog._ros._batch import decode_batch
    from dbglog.record import read_recording

    load0 = os.getloadavg()[0]
    robot = subprocess.Popen(
        [
            sys.executable,
            "-c",
            _SDK_ROBOT,
            str(args.topics),
            str(args.sdk_seconds),
            str(hz),
            "seq" if seq else "-",
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert robot.stdout is not None
    assert robot.stdin is not None
    assert robot.stdout.readline().strip() == "ready"
    engine = _viewer_child(args.topics, "/rosdashboard/bench_sdk/t") if viewer else None
    rec = None
    if recorder:
        rec = subprocess.Popen(
            [sys.executable, "-m", "dbglog", "record", "-o", str(out), "--force"],
            stderr=subprocess.PIPE,
            text=True,
        )
        assert rec.stderr is not None
        while "1 topics" not in rec.stderr.readline():  # the batch topic is there: go
            pass
    time.sleep(1.0 if recorder else 2.0)
    robot.stdin.write("go\n")
    robot.stdin.flush()
    samples_text, elapsed, robot_cpu, sdk_dropped = robot.stdout.readline().split()
    samples = int(samples_text)
    load1 = os.getloadavg()[0]
    result: dict[str, Any] = {
        "samples": samples,
        "seconds": float(elapsed),
        "robot_cpu": float(robot_cpu),
        "sdk_dropped": int(sdk_dropped),
        "load": max(load0, load1),
    }
    if engine is not None:
        result["viewer_landed"], result["viewer_cpu"] = _viewer_report(engine)
    if rec is None:
        robot.stdin.close()
        robot.wait(30)
        return result
    assert rec.stderr is not None
    last = -1
    while True:
        words = rec.stderr.readline().replace(",", "").split()
        if "messages" in words:
            count = int(words[words.index("messages") - 1])
            if count == last:
                break
            last = count
    rec_cpu = _cpu_seconds(rec.pid)
    rec.send_signal(signal.SIGINT)
    _, err = rec.communicate(timeout=120)
    robot.stdin.close()
    robot.wait(30)
    recording = read_recording(out)
    batch = recording.topics.get("/_dbglog/samples")
    payloads = list(batch.payloads()) if batch is not None else []
    batch_bytes = sum(len(p) for p in payloads)
    tag_msgs = sum(len(t) for n, t in recording.topics.items() if n.startswith("/rosdashboard/"))
    result |= {
        "rec_cpu": rec_cpu,
        "bytes": out.stat().st_size,
        "tag_msgs": tag_msgs,
        "batch_raw": batch_bytes,
        "batches": len(payloads),
        "recorded_msgs": sum(len(t) for t in recording.topics.values()),
        "dds_lost": next((ln.split()[-1] for ln in err.splitlines() if "longest pause" in ln), "?"),
        "batches_missing": next(
            (
                ln.split("batches missing ")[1].split(",")[0]
                for ln in err.splitlines()
                if "batches missing" in ln
            ),
            "?",
        ),
    }
    if seq:
        values = [
            t.values for b in payloads for t in decode_batch(bytes(b)).tags if not isinstance(t.values, list)
        ]
        got = np.unique(np.concatenate(values)) if values else np.zeros(0)
        result["batch_samples"] = len(got)
        result["lost"] = samples - len(got)
        missing = np.setdiff1d(np.arange(samples, dtype=np.float64), got)
        # When the lost samples were logged (s into the run), to tell a stall from a start or an end.
        result["lost_at"] = sorted({round(float(m) / args.topics / hz, 1) for m in missing})
        tag_values = [
            t.values
            for n, t in recording.topics.items()
            if n.startswith("/rosdashboard/") and t.values is not None
        ]
        in_tags = np.unique(np.concatenate(tag_values)) if tag_values else np.zeros(0)
        result["tag_samples"] = len(in_tags)
    return result


_VARIANTS: dict[str, dict[str, int | bool]] = {
    "tag": {"recorder": True, "viewer": False, "pub_depth": 0, "queue_depth": 0},
    "deep-queue": {"recorder": True, "viewer": False, "pub_depth": 0, "queue_depth": 10_000},
    "deep-pub": {"recorder": True, "viewer": False, "pub_depth": 1000, "queue_depth": 0},
    "deep-both": {"recorder": True, "viewer": False, "pub_depth": 1000, "queue_depth": 10_000},
    "viewer": {"recorder": False, "viewer": True, "pub_depth": 0, "queue_depth": 0},
    "rec+viewer": {"recorder": True, "viewer": True, "pub_depth": 0, "queue_depth": 0},
}
"""Record-run alternatives: publishers' depth (0: tag QoS, 100), recorder's queue depth (0: its default)."""


def _record_run(args: argparse.Namespace, out: Path, variant: str = "tag") -> dict[str, Any]:
    """Start the recorder CLI (and/or a viewer engine) and the publishers; return what each measured."""
    import numpy as np

    from dbglog.record import read_recording

    v = _VARIANTS[variant]
    load0 = os.getloadavg()[0]
    rec = None
    if v["recorder"]:
        cmd = [sys.executable, "-m", "dbglog", "record", "-o", str(out), "--force", _TAG]
        if v["queue_depth"]:
            cmd += ["--queue-depth", str(v["queue_depth"])]
        rec = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)
    viewer = _viewer_child(args.topics, f"/rosdashboard/{_TAG}/t") if v["viewer"] else None
    pubs = [
        subprocess.Popen(
            [
                sys.executable,
                "-m",
                "benchmarks.bench_record",
                "--role",
                "publisher",
                "--topics",
                str(args.topics),
                "--rate",
                str(args.rate),
                "--seconds",
                str(args.seconds),
                "--domain",
                str(args.domain),
                "--publishers",
                str(args.publishers),
                "--pub-depth",
                str(v["pub_depth"]),
                "--part",
                str(k),
            ],
            stdout=subprocess.PIPE,
            text=True,
        )
        for k in range(args.publishers)
    ]
    results = []
    for pub in pubs:
        assert pub.stdout is not None
        results.append(json.loads(pub.stdout.readline()))
    load1 = os.getloadavg()[0]
    for pub in pubs:
        pub.wait(60)
    sent_parts = [int(r["sent"]) for r in results]
    result: dict[str, Any] = {
        "matched": float(all(r["matched"] for r in results)),
        "seconds": max(r["seconds"] for r in results),
        "sent": sum(sent_parts),
        "pub_cpu": sum(r["cpu"] for r in results),
        "load": max(load0, load1),
    }
    if viewer is not None:
        time.sleep(2.0)  # let the engine drain its queues
        out_text, _ = viewer.communicate("stop\n", timeout=60)
        report = json.loads(out_text.strip().splitlines()[-1])
        samples = report["samples"]
        result["viewer_landed"] = report["landed"]
        if len(samples) >= 2:
            result["viewer_cpu"] = samples[-1][2] - samples[0][2]
    if rec is None:
        return result
    assert rec.stderr is not None
    last = -1
    while True:  # until the recorder's once-a-second summary stops growing
        line = rec.stderr.readline()
        words = line.replace(",", "").split()
        if "messages" in words:
            count = int(words[words.index("messages") - 1])
            if count == last and count >= result["sent"] * 0.5:
                break
            last = count
        if not line:
            break
    result["rec_cpu"] = _cpu_seconds(rec.pid)
    rec.send_signal(signal.SIGINT)
    _, err = rec.communicate(timeout=120)
    for line in err.splitlines():
        if "longest pause" in line:
            words = line.replace(",", "").replace("%", "").split()
            with contextlib.suppress(ValueError, IndexError):  # a recorder before these reports
                result["pause_ms"] = float(words[words.index("loop") + 1])
                result["fullest"] = float(words[words.index("queue") + 1])
                result["full_takes"] = float(words[words.index("(full") + 1])
                result["dds_lost"] = float(words[-1])
    recording = read_recording(out, keep_payloads=False)
    recorded = 0
    seen: list[np.ndarray] = []
    for topic in recording.topics.values():
        assert topic.values is not None
        recorded += len(topic)
        seen.append(topic.values)
    got = np.unique(np.concatenate(seen)).astype(np.int64) if seen else np.zeros(0, np.int64)
    result.update(recorded=recorded, distinct=len(got), lost=result["sent"] - len(got))
    result["bytes"] = out.stat().st_size
    result.update(_bursts(got, sent_parts, args))
    return result


def _bursts(got: object, sent_parts: list[int], args: argparse.Namespace) -> dict[str, Any]:
    """Group the lost sequence numbers into bursts (consecutive messages of one topic)."""
    import numpy as np

    stride = len(sent_parts)
    bursts: list[tuple[int, float]] = []  # (length, seconds into the run)
    for k, sent in enumerate(sent_parts):
        n_k = len(range(k, args.topics, stride))
        expected = np.arange(sent, dtype=np.int64) * stride + k
        missing = np.setdiff1d(expected, np.asarray(got))
        if not len(missing):
            continue
        seq = missing // stride  # the publisher's own sequence number
        topic, index = seq % n_k, seq // n_k
        order = np.lexsort((index, topic))
        topic, index, seq = topic[order], index[order], seq[order]
        breaks = np.flatnonzero((np.diff(topic) != 0) | (np.diff(index) != 1)) + 1
        for lo, hi in zip([0, *breaks.tolist()], [*breaks.tolist(), len(seq)], strict=True):
            bursts.append((hi - lo, float(seq[lo]) / (args.rate / stride)))
    times = sorted({round(t) for _, t in bursts})
    return {
        "bursts": float(len(bursts)),
        "longest_burst": float(max((n for n, _ in bursts), default=0)),
        "burst_seconds": times,
    }


def _cpu_seconds(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _write_large(path: Path, topics: int, hz: float, seconds: float) -> int:
    """Write `topics` Float64 topics at `hz` for `seconds` with dbglog's writer, interleaved by block."""
    import numpy as np
    from rclpy.serialization import serialize_message  # noqa: F401  (the wheels' share dir is needed)

    from dbglog.record import McapWriter

    rng = np.random.default_rng(1)
    t0 = 1_790_000_000_000_000_000
    period = int(1e9 / hz)
    n = int(hz * seconds)
    block = int(hz * 10)
    with McapWriter(path, force=True) as w:
        chans = [w.add_channel(f"/rosdashboard/big/t{i}", "std_msgs/msg/Float64") for i in range(topics)]
        level = rng.normal(size=topics)
        for lo in range(0, n, block):
            hi = min(n, lo + block)
            k = np.arange(lo, hi)
            for i, ch in enumerate(chans):
                # A 100 Hz sensor: smooth signal plus noise, rounded as a sensor would (1e-4).
                values = np.round(level[i] + np.sin(k * 0.01 + i) + rng.normal(0, 0.01, hi - lo), 4)
                payload = np.empty((hi - lo, 12), dtype=np.uint8)
                payload[:, :4] = (0, 1, 0, 0)
                payload[:, 4:] = values.astype("<f8").view(np.uint8).reshape(-1, 8)
                jitter = rng.integers(0, 200_000, hi - lo)
                times = (t0 + k * period + i * 1000 + jitter).astype(np.int64)
                w.write_fixed(ch, times, payload)
    return topics * n


def _peer_decode(path: Path, limit: int) -> tuple[int, float]:
    """Decode the first `limit` messages one by one with mcap + mcap_ros2; return (count, seconds)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    start = time.perf_counter()
    count = 0
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, _channel, _message, decoded in reader.iter_decoded_messages(log_time_order=False):
            _ = decoded.data
            count += 1
            if count >= limit:
                break
    return count, time.perf_counter() - start


def _spans(times: list[float]) -> str:
    """Sorted times (0.1 s steps) as a few 'a-b' spans."""
    spans: list[list[float]] = []
    for t in times:
        if spans and t - spans[-1][1] <= 0.11:
            spans[-1][1] = t
        else:
            spans.append([t, t])
    text = ", ".join(f"{a:g}-{b:g}" if b > a else f"{a:g}" for a, b in spans[:5])
    return text + (" ..." if len(spans) > 5 else "") if spans else "-"


def _record_table(args: argparse.Namespace, tmp: Path) -> None:
    """Run the record variants side by side (interleaved repeats) and print one row per run."""
    import statistics

    variants = [v.strip() for v in args.variants.split(",") if v.strip()]
    for v in variants:
        if v not in _VARIANTS:
            raise SystemExit(f"unknown variant {v!r} (known: {', '.join(_VARIANTS)})")
    rows = []
    lost: dict[str, list[float]] = {v: [] for v in variants}
    for _ in range(args.repeats):
        for v in variants:
            r = _record_run(args, tmp / "flood.mcap", v)
            sent = r["sent"]
            row = [
                v,
                f"{r['load']:.1f}",
                f"{sent / r['seconds']:,.0f}",
                f"{r['pub_cpu'] / sent * 1e6:.1f}",
            ]
            if "lost" in r:
                lost[v].append(r["lost"])
                row += [
                    f"{r['lost']:,.0f} ({r['lost'] / sent:.2%})",
                    f"{r['bursts']:.0f} / {r['longest_burst']:.0f}",
                    ", ".join(str(t) for t in r["burst_seconds"][:6]) or "-",
                    f"{r['rec_cpu'] / r['seconds']:.2f}",
                    f"{r['rec_cpu'] / max(1, r['recorded']) * 1e6:.1f}",
                    f"{r.get('pause_ms', float('nan')):.0f}",
                    f"{r.get('fullest', float('nan')):.0f} % / {r.get('full_takes', float('nan')):.0f}",
                    f"{r.get('dds_lost', float('nan')):.0f}",
                    f"{r['bytes'] / max(1, r['recorded']):.1f}",
                ]
            else:
                row += ["-"] * 9
            if "viewer_landed" in r:
                row += [
                    f"{r['viewer_landed']:,.0f} ({max(0.0, 1 - r['viewer_landed'] / sent):.2%} lost)",
                    f"{r.get('viewer_cpu', float('nan')) / max(1, r['viewer_landed']) * 1e6:.1f}",
                ]
            else:
                row += ["-", "-"]
            rows.append(row)
    print_table(
        f"dbglog record: {args.topics} topics, {args.rate:,.0f} msg/s for {args.seconds:g} s, "
        f"{args.publishers} publisher processes, {os.cpu_count()} CPUs",
        [
            "variant",
            "load avg",
            "achieved msg/s",
            "publishers CPU µs/msg",
            "recorder lost",
            "bursts / longest (msgs of one topic)",
            "bursts at (s)",
            "recorder CPU (cores)",
            "recorder CPU µs/msg",
            "longest take-loop pause (ms)",
            "fullest queue / times full",
            "DDS-reported lost",
            "bytes/msg",
            "viewer landed",
            "viewer CPU µs/msg",
        ],
        rows,
    )
    for v in variants:
        if lost[v]:
            print(f"{v}: median lost {statistics.median(lost[v]):,.0f} over {len(lost[v])} run(s)")


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print the tables."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--role", choices=["main", "publisher"], default="main")
    parser.add_argument("--topics", type=int, default=50)
    parser.add_argument("--rate", type=float, default=50_000.0, help="total msg/s for the record run")
    parser.add_argument("--seconds", type=float, default=60.0, help="length of the record run")
    parser.add_argument("--hours", type=float, default=1.0, help="length of the large file (100 Hz)")
    parser.add_argument("--peer-minutes", type=float, default=3.0, help="part decoded by mcap_ros2")
    parser.add_argument("--publishers", type=int, default=2, help="publisher processes for the record run")
    parser.add_argument("--pub-depth", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument(
        "--variants",
        default="tag",
        help=f"comma-separated record-run variants, run side by side: {', '.join(_VARIANTS)}",
    )
    parser.add_argument("--repeats", type=int, default=1, help="runs of each variant (interleaved)")
    parser.add_argument("--part", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--sdk-seconds", type=float, default=30.0, help="length of the SDK runs")
    parser.add_argument(
        "--sdk-hz",
        type=float,
        default=1000.0,
        help="rate per tag of the SDK flood run (every sample numbered and looked for in the file)",
    )
    parser.add_argument("--only", choices=["record", "sdk", "sdk-flood", "sdk-viewer", "load"], default=None)
    parser.add_argument("--domain", type=int, default=None)
    args = parser.parse_args(argv)
    if args.domain is None:
        args.domain = 100 + os.getpid() % 100
    local_ros_env(args.domain)
    if args.role == "publisher":
        _publisher(args)
        return 0
    from dbglog.record import read_recording

    tmp = Path(tempfile.mkdtemp(prefix="bench_record_"))
    if args.only in (None, "record"):
        _record_table(args, tmp)
    if args.only in (None, "sdk"):
        r = _sdk_run(args, tmp / "sdk.mcap")
        print_table(
            f"dbglog SDK: {args.topics} Float64 tags x 100 Hz for {args.sdk_seconds:g} s, default targets",
            ["load avg", "samples logged", "per-tag messages recorded", "file", "bytes/sample (both copies)"],
            [
                [
                    f"{r['load']:.1f}",
                    f"{r['samples']:,.0f}",
                    f"{r['tag_msgs']:,.0f}",
                    f"{r['bytes'] / 1e6:.2f} MB",
                    f"{r['bytes'] / r['samples']:.1f}",
                ]
            ],
        )
    if args.only in (None, "sdk", "sdk-flood"):
        rows = []
        for _ in range(args.repeats):
            r = _sdk_run(args, tmp / "sdk_flood.mcap", hz=args.sdk_hz, seq=True)
            rows.append(
                [
                    f"{r['load']:.1f}",
                    f"{r['samples'] / r['seconds']:,.0f}",
                    f"{r['samples']:,.0f}",
                    f"{r['batch_samples']:,.0f}",
                    f"{r['tag_samples']:,.0f}",
                    f"{r['lost']:,.0f}",
                    _spans(r["lost_at"]),
                    f"{r['sdk_dropped']:,}",
                    f"{r['recorded_msgs'] / r['seconds']:,.0f}",
                    f"{r['robot_cpu'] / r['samples'] * 1e6:.1f}",
                    f"{r['rec_cpu'] / r['seconds']:.2f}",
                    f"{r['rec_cpu'] / r['samples'] * 1e6:.2f}",
                    f"{r['batches_missing']} / {r['dds_lost']}",
                    f"{r['bytes'] / r['samples']:.1f}",
                ]
            )
        print_table(
            f"dbglog SDK flood: {args.topics} tags x {args.sdk_hz:g} Hz for {args.sdk_seconds:g} s, "
            "default targets, every sample numbered",
            [
                "load avg",
                "samples/s logged",
                "samples logged",
                "in the batch copy",
                "in the tag topics",
                "lost (batch copy)",
                "logged at (s)",
                "dropped by the SDK",
                "recorder msg/s",
                "robot CPU µs/sample",
                "recorder CPU (cores)",
                "recorder CPU µs/sample",
                "batches missing / DDS-reported lost",
                "bytes/sample",
            ],
            rows,
        )
    if args.only in (None, "sdk-viewer"):
        rows = []
        for _ in range(args.repeats):
            for with_recorder in (False, True):
                r = _sdk_run(
                    args,
                    tmp / "sdk_viewer.mcap",
                    hz=args.sdk_hz,
                    seq=True,
                    recorder=with_recorder,
                    viewer=True,
                )
                landed = r["viewer_landed"]
                rows.append(
                    [
                        "viewer + recorder" if with_recorder else "viewer alone",
                        f"{r['load']:.1f}",
                        f"{r['samples'] / r['seconds']:,.0f}",
                        f"{landed:,} ({max(0.0, 1 - landed / r['samples']):.2%} lost)",
                        f"{r['viewer_cpu'] / r['seconds']:.2f}",
                        (
                            f"{r['lost']:,} ({_spans(r['lost_at'])}; "
                            f"batches missing {r['batches_missing']}, DDS {r['dds_lost']})"
                        )
                        if "lost" in r
                        else "-",
                        f"{r['sdk_dropped']:,}",
                        f"{r['rec_cpu'] / r['seconds']:.2f}" if "rec_cpu" in r else "-",
                        f"{r['robot_cpu'] / r['samples'] * 1e6:.1f}",
                    ]
                )
        print_table(
            f"Viewer beside the recorder: {args.topics} tags x {args.sdk_hz:g} Hz, {args.sdk_seconds:g} s",
            [
                "run",
                "load avg",
                "samples/s logged",
                "viewer: samples taken",
                "viewer CPU (cores)",
                "recorder lost (logged at, s; batches missing, DDS-reported)",
                "dropped by the SDK",
                "recorder CPU (cores)",
                "robot CPU µs/sample",
            ],
            rows,
        )
    if args.only in (None, "load"):
        big = tmp / "big.mcap"
        t = time.perf_counter()
        n = _write_large(big, args.topics, 100.0, args.hours * 3600)
        write_s = time.perf_counter() - t
        size = big.stat().st_size
        t = time.perf_counter()
        rec = read_recording(big, keep_payloads=False)
        load_s = time.perf_counter() - t
        assert sum(len(x) for x in rec.topics.values()) == n
        del rec
        t = time.perf_counter()
        rec = read_recording(big)
        load_payload_s = time.perf_counter() - t
        del rec
        t = time.perf_counter()
        first = read_recording(big, end_ns=1_790_000_010_000_000_000, keep_payloads=False)
        first_s = time.perf_counter() - t
        first_n = sum(len(x) for x in first.topics.values())
        del first
        part = tmp / "part.mcap"
        peer_n = _write_large(part, args.topics, 100.0, args.peer_minutes * 60)
        t = time.perf_counter()
        read_recording(part, keep_payloads=False)
        own_part_s = time.perf_counter() - t
        got, peer_s = _peer_decode(part, peer_n)
        print_table(
            f"Large file: {args.topics} topics x 100 Hz x {args.hours:g} h ({n:,} Float64 messages)",
            ["file", "bytes/sample", "written in", "load (values)", "load (values + payloads)", "first 10 s"],
            [
                [
                    f"{size / 1e6:.0f} MB",
                    f"{size / n:.1f}",
                    f"{write_s:.1f} s",
                    f"{load_s:.2f} s",
                    f"{load_payload_s:.2f} s",
                    f"{first_s:.2f} s ({first_n:,} messages)",
                ]
            ],
        )
        peer_full = peer_s / got * n
        print_table(
            f"Loading vs mcap_ros2 (same {peer_n:,}-message file, {args.peer_minutes:g} min)",
            ["reader", "seconds", "µs/message", "full file (measured / extrapolated)", "speed-up"],
            [
                [
                    "dbglog read_recording",
                    f"{own_part_s:.2f}",
                    f"{own_part_s / peer_n * 1e6:.2f}",
                    f"{load_s:.1f} s (measured)",
                    f"{peer_s / own_part_s:.0f}×",
                ],
                [
                    "mcap + mcap_ros2 decoder",
                    f"{peer_s:.2f}",
                    f"{peer_s / got * 1e6:.2f}",
                    f"{peer_full:.0f} s (extrapolated)",
                    "1×",
                ],
            ],
        )
    for f in tmp.iterdir():
        f.unlink()
    tmp.rmdir()
    return 0


if __name__ == "__main__":
    sys.exit(main())
