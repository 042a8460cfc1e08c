"""Does dbglog's writer thread hold up *another* node's topic on a busy machine? (Fast DDS's shared memory)

Run: ``.venv/bin/python benchmarks/bench_shared_port.py [--seconds 30] [--repeats 2] [--hogs 4]``
(prints a Markdown table).

Fast DDS delivers between processes of one machine through a shared-memory port per subscribing
participant; every publisher that sends to that participant pushes under the port's one interprocess
mutex (``SharedMemGlobal::Port::try_push``). A thread preempted inside that push keeps the mutex, and every
other publisher to the same subscriber waits for it. An ordinary thread gets the CPU back within a
scheduler slice; a ``SCHED_IDLE`` thread on a machine kept busy by other work may not for a long time.

Each run, on one ROS domain of its own:

- a *robot* node (plain rclpy) publishes a heartbeat at 100 Hz;
- a *subscriber* process (plain rclpy) takes that heartbeat and 10 dbglog tags;
- a *dbglog* process logs those 10 tags at 1 kHz (every sample also goes on its tag's topic, which the
  subscriber takes), its writer thread ordinary (as dbglog ships it) or put under ``SCHED_IDLE`` from
  inside the process (what 567eb5d shipped);
- `hogs` busy processes keep the CPUs saturated (a build, say).

It reports the heartbeat as the subscriber received it: the longest gap and the gaps over 200 ms (at
100 Hz a gap should be ~10 ms), and how many heartbeats came. Runs alternate the two policies.

``--party recorder`` asks the same of a whole dbglog process in the background (``dbglog record --cpu
background``, as ``dbglog view`` runs by default): the robot publishes the 10 tags itself (plain rclpy,
1 kHz, the heartbeat every 10th iteration) and the recorder takes them, its threads (Fast DDS's shared
memory listener among them) ordinary or ``SCHED_IDLE``; the subscriber takes only the heartbeat.
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
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks._common import local_ros_env, print_table  # noqa: E402

_TAGS = 10
_HEARTBEAT = "/bench_shared/heartbeat"
_SETTLE_S = 4.0
"""Seconds the processes get to discover each other before the busy processes start."""


def _robot(seconds: float, tags: bool) -> None:
    import rclpy
    from std_msgs.msg import Float64

    from dbglog._ros._qos import tag_qos

    rclpy.init()
    node = rclpy.create_node("bench_shared_robot")
    pub = node.create_publisher(Float64, _HEARTBEAT, 10)
    tag_pubs = [
        node.create_publisher(Float64, f"/rosdashboard/bench_shared_{k}", tag_qos()) for k in range(_TAGS)
    ]
    end, i = time.monotonic() + seconds, 0
    while time.monotonic() < end:
        if tags:
            for tag in tag_pubs:
                tag.publish(Float64(data=float(i)))
        if not tags or i % 10 == 0:
            pub.publish(Float64(data=float(i)))
        i += 1
        time.sleep(0.001 if tags else 0.01)


def _subscriber(seconds: float, measure_after: float, take_tags: bool) -> None:
    import rclpy
    from std_msgs.msg import Float64

    rclpy.init()
    node = rclpy.create_node("bench_shared_subscriber")
    beats: list[float] = []
    tags = [0]
    node.create_subscription(Float64, _HEARTBEAT, lambda _m: beats.append(time.monotonic()), 10)
    for k in range(_TAGS if take_tags else 0):
        node.create_subscription(
            Float64, f"/rosdashboard/bench_shared_{k}", lambda _m: tags.__setitem__(0, tags[0] + 1), 10
        )
    start = time.monotonic()
    while time.monotonic() < start + seconds:
        rclpy.spin_once(node, timeout_sec=0.05)
    kept = [t for t in beats if t >= start + measure_after]
    gaps = [b - a for a, b in itertools.pairwise(kept)] or [0.0]
    print(
        json.dumps(
            {
                "beats": len(kept),
                "max_gap_ms": max(gaps) * 1e3,
                "gaps_200ms": sum(g > 0.2 for g in gaps),
                "tag_messages": tags[0],
            }
        ),
        flush=True,
    )


def _dbglog(seconds: float, policy: str) -> None:
    import dbglog
    from dbglog.api._public import RUNTIME

    dbglog.logfloat("bench_shared_0", 0.0)
    dbglog.flush(10.0)
    writer = RUNTIME._writer
    if writer is None:
        raise SystemExit("bench_shared_port: dbglog has no writer thread here (no compiled module)")
    if policy == "idle":
        os.sched_setscheduler(writer.native_id, os.SCHED_IDLE, os.sched_param(0))
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for k in range(_TAGS):
            dbglog.logfloat(f"bench_shared_{k}", time.time())
        time.sleep(0.001)


def run(seconds: float, hogs: int, policy: str, party: str, tmp: Path) -> dict[str, Any]:
    """One run: robot, subscriber and dbglog processes, then `hogs` busy ones; the subscriber's figures."""
    env = {**os.environ, "ROS_DOMAIN_ID": str(random.randint(101, 200)), "DBGLOG_CPU": "normal"}
    me = [sys.executable, str(Path(__file__).resolve())]
    total = seconds + _SETTLE_S
    writer = party == "writer"
    sub = subprocess.Popen(
        [*me, "--role", "subscriber", "--seconds", str(total), *(["--tags"] if writer else [])],
        env=env,
        stdout=subprocess.PIPE,
        text=True,
    )
    robot = [*me, "--role", "robot", "--seconds", str(total + 2), *([] if writer else ["--tags"])]
    if writer:
        party_cmd = [*me, "--role", "dbglog", "--seconds", str(total + 2), "--policy", policy]
    else:
        cpu = "normal" if policy == "ordinary" else "background"
        tags = [f"bench_shared_{k}" for k in range(_TAGS)]
        mcap = tmp / f"bench_shared_{policy}.mcap"
        party_cmd = [
            sys.executable,
            "-m",
            "dbglog",
            "record",
            "-o",
            str(mcap),
            "--force",
            "--cpu",
            cpu,
            *tags,
        ]
    others = [
        subprocess.Popen(robot, env=env),
        subprocess.Popen(party_cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL),
    ]
    time.sleep(_SETTLE_S)
    hog = f"import time\nend = time.time() + {seconds}\nwhile time.time() < end: pass"
    busy = [subprocess.Popen([sys.executable, "-c", hog]) for _ in range(hogs)]
    try:
        out, _ = sub.communicate(timeout=total + 60)
        return dict(json.loads(out.strip().splitlines()[-1]))
    finally:
        procs: list[subprocess.Popen[Any]] = [*busy, *others, sub]
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
            proc.wait()


def main() -> None:
    """Parse the options; run a role, or alternate the two policies and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--role", choices=["main", "robot", "subscriber", "dbglog"], default="main")
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--hogs", type=int, default=4, help="busy processes (default 4: 2 per core here)")
    parser.add_argument("--policy", choices=["ordinary", "idle"], default="ordinary")
    parser.add_argument(
        "--party",
        choices=["writer", "recorder"],
        default="writer",
        help="what runs ordinary or SCHED_IDLE: the SDK's writer thread (default) or a whole dbglog record",
    )
    parser.add_argument("--tags", action="store_true", help="(robot, subscriber roles) the tags too")
    args = parser.parse_args()
    local_ros_env()
    if args.role == "robot":
        _robot(args.seconds, args.tags)
        return
    if args.role == "subscriber":
        _subscriber(args.seconds, _SETTLE_S, args.tags)
        return
    if args.role == "dbglog":
        _dbglog(args.seconds, args.policy)
        return
    runs: dict[str, list[dict[str, Any]]] = {"ordinary": [], "idle": []}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeats):
            for policy in runs:
                runs[policy].append(run(args.seconds, args.hogs, policy, args.party, Path(tmp)))
                print(f"{policy}: {runs[policy][-1]}", file=sys.stderr, flush=True)
    if args.party == "writer":
        names = {"ordinary": "ordinary (as shipped)", "idle": "SCHED_IDLE (as 567eb5d had it)"}
        title = "Another node's 100 Hz heartbeat at a subscriber that also takes dbglog's tags"
        what = "dbglog's writer thread"
    else:
        names = {"ordinary": "--cpu normal (default)", "idle": "--cpu background"}
        title = "A robot's 100 Hz heartbeat, its 10 tags at 1 kHz taken by dbglog record"
        what = "dbglog record"
    rows = []
    for policy, results in runs.items():
        rows.append(
            [
                names[policy],
                " / ".join(f"{r['max_gap_ms']:.0f}" for r in results),
                " / ".join(str(r["gaps_200ms"]) for r in results),
                " / ".join(str(r["beats"]) for r in results),
                f"{statistics.median(r['tag_messages'] for r in results):.0f}",
            ]
        )
    print_table(
        f"{title}, {args.hogs} busy processes, {args.seconds:.0f} s a run",
        [what, "longest gap (ms), each run", "gaps > 200 ms", "heartbeats", "tag msgs"],
        rows,
    )


if __name__ == "__main__":
    main()
