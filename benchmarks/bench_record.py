"""Recordings benchmark: ``dbglog record`` under a flood, bytes per sample on disk, loading a large file.

Run from the repository root: ``.venv/bin/python -m benchmarks.bench_record`` (``--help`` for options;
``--seconds 10 --hours 0.1`` for a quick run). Side by side, in one run:

1. **record**: a publisher process sends pre-serialised ``std_msgs/Float64`` round-robin over 50 tag
   topics (dbglog's tag QoS) at a fixed total rate; the real ``dbglog record`` CLI records them; every
   message sent is looked for in the file (lost = sent - recorded).
2. **bytes per sample**: the recorded file's size over its messages, and a file of the same shape
   written directly (100 Hz signals).
3. **load**: a file of 50 topics x 100 Hz x ``--hours`` written directly with dbglog's writer, loaded
   by ``read_recording``; the same messages decoded one by one by ``mcap`` + ``mcap_ros2`` on the first
   ``--peer-minutes`` (extrapolated per message; dbglog's reader is also timed on that same part).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

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

    from dbglog._ros._qos import tag_qos

    context = Context()
    rclpy.init(context=context)
    node = Node("bench_record_publisher", context=context)
    mine = range(args.part, args.topics, args.publishers)
    pubs = [node.create_publisher(Float64, f"/rosdashboard/{_TAG}/t{i}", tag_qos()) for i in mine]
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
    print(json.dumps({"matched": matched, "seconds": stop - start, "sent": sent}), flush=True)
    time.sleep(3.0)  # keep reliable writers alive while the recorder drains
    node.destroy_node()
    rclpy.shutdown(context=context)


_SDK_ROBOT = """
import math, sys, time
import dbglog
topics, seconds = int(sys.argv[1]), float(sys.argv[2])
tags = [f"bench_sdk/t{i}" for i in range(topics)]
dbglog.init()
print("ready", flush=True)
sys.stdin.readline()
k = 0
start = t = time.monotonic()
while time.monotonic() - start < seconds:
    for i, tag in enumerate(tags):
        dbglog.logfloat(tag, round(math.sin(k * 0.01 + i) + 0.001 * ((k * 7919 + i) % 13), 4))
    k += 1
    t += 0.01
    time.sleep(max(0.0, t - time.monotonic()))
dbglog.flush()
print(k * topics, flush=True)
sys.stdin.readline()
"""


def _sdk_run(args: argparse.Namespace, out: Path) -> dict[str, float]:
    """The dbglog SDK logging Float64 tags at 100 Hz, recorded with the default targets."""
    from dbglog.record import read_recording

    robot = subprocess.Popen(
        [sys.executable, "-c", _SDK_ROBOT, str(args.topics), str(args.sdk_seconds)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert robot.stdout is not None
    assert robot.stdin is not None
    assert robot.stdout.readline().strip() == "ready"
    rec = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "record", "-o", str(out), "--force"],
        stderr=subprocess.PIPE,
        text=True,
    )
    assert rec.stderr is not None
    while "1 topics" not in rec.stderr.readline():  # the batch topic is there: go
        pass
    time.sleep(1.0)
    robot.stdin.write("go\n")
    robot.stdin.flush()
    samples = int(robot.stdout.readline())
    last = -1
    while True:
        words = rec.stderr.readline().replace(",", "").split()
        if "messages" in words:
            count = int(words[words.index("messages") - 1])
            if count == last:
                break
            last = count
    rec.send_signal(signal.SIGINT)
    rec.communicate(timeout=120)
    robot.stdin.close()
    robot.wait(30)
    recording = read_recording(out)
    batch = recording.topics.get("/_dbglog/samples")
    batch_bytes = sum(len(p) for p in batch.payloads()) if batch is not None else 0
    tag_msgs = sum(len(t) for n, t in recording.topics.items() if n.startswith("/rosdashboard/"))
    return {"samples": samples, "bytes": out.stat().st_size, "tag_msgs": tag_msgs, "batch_raw": batch_bytes}


def _record_run(args: argparse.Namespace, out: Path) -> dict[str, float]:
    """Start the recorder CLI and the publisher; return sent, recorded, lost, CPU and the file's size."""
    import numpy as np

    from dbglog.record import read_recording

    rec = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "record", "-o", str(out), "--force", _TAG],
        stderr=subprocess.PIPE,
        text=True,
    )
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
    for pub in pubs:
        pub.wait(60)
    result = {
        "matched": all(r["matched"] for r in results),
        "seconds": max(r["seconds"] for r in results),
        "sent": sum(r["sent"] for r in results),
    }
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
    cpu = _cpu_seconds(rec.pid)
    rec.send_signal(signal.SIGINT)
    rec.communicate(timeout=120)
    recording = read_recording(out, keep_payloads=False)
    recorded = 0
    seen: list[np.ndarray] = []
    for topic in recording.topics.values():
        assert topic.values is not None
        recorded += len(topic)
        seen.append(topic.values)
    distinct = len(np.unique(np.concatenate(seen))) if seen else 0
    return {
        "matched": float(result["matched"]),
        "seconds": result["seconds"],
        "sent": result["sent"],
        "recorded": recorded,
        "distinct": distinct,
        "lost": result["sent"] - distinct,
        "bytes": out.stat().st_size,
        "cpu": cpu,
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
    parser.add_argument("--part", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--sdk-seconds", type=float, default=30.0, help="length of the SDK run")
    parser.add_argument("--only", choices=["record", "sdk", "load"], default=None)
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
        r = _record_run(args, tmp / "flood.mcap")
        print_table(
            f"dbglog record: {args.topics} topics, {args.rate:,.0f} msg/s for {args.seconds:g} s",
            ["sent", "achieved msg/s", "recorded", "lost", "recorder CPU (cores)", "file", "bytes/msg"],
            [
                [
                    f"{r['sent']:,.0f}",
                    f"{r['sent'] / r['seconds']:,.0f}",
                    f"{r['distinct']:,.0f}",
                    f"{r['lost']:,.0f}",
                    f"{r['cpu'] / max(1.0, r['seconds']):.2f}",
                    f"{r['bytes'] / 1e6:.1f} MB",
                    f"{r['bytes'] / max(1, r['recorded']):.1f}",
                ]
            ],
        )
    if args.only in (None, "sdk"):
        r = _sdk_run(args, tmp / "sdk.mcap")
        print_table(
            f"dbglog SDK: {args.topics} Float64 tags x 100 Hz for {args.sdk_seconds:g} s, default targets",
            ["samples logged", "per-tag messages recorded", "file", "bytes/sample (both copies)"],
            [
                [
                    f"{r['samples']:,.0f}",
                    f"{r['tag_msgs']:,.0f}",
                    f"{r['bytes'] / 1e6:.2f} MB",
                    f"{r['bytes'] / r['samples']:.1f}",
                ]
            ],
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
