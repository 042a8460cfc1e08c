"""Benchmark discovery: how long a new dbglog process takes to see every robot's node and topics.

Run: ``.venv/bin/python -m benchmarks.bench_discovery`` (2 robots of 300 tags, ``benchmarks/_fleet.py``;
``--peers 8`` adds plain ROS nodes, for 10 processes on the domain; ``--runs 20``). Each run is a fresh
process that creates a private node as a ``dbglog`` command does, with the discovery profile (``profile``)
or without it (``plain``, as before 2026-11-28), the two interleaved; it reports, from its start, when its
census found every participant of this host, when it saw every robot's node and when all their topics.
A run is *late* when a robot took more than 1 s: it was then found only at its next announcement.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

from benchmarks._common import local_ros_env, print_table, start_ready

_LATE_S = 1.0


def _probe(args: argparse.Namespace) -> int:
    """One run: a private node (claimed or not) watching the graph until every robot is complete."""
    started = time.monotonic()
    from dbglog._ros import _profile

    if args.claim:
        _profile.claim()
    from dbglog._ros._census import take_census
    from dbglog._ros._node import PrivateNode

    robots = args.robots.split(",")
    ros = PrivateNode("bench_discovery")
    ready = time.monotonic() - started
    node_at: dict[str, float] = {}
    topics_at: dict[str, float] = {}
    census_at = None
    while time.monotonic() - started < args.limit:
        now = time.monotonic() - started
        counts = dict.fromkeys(robots, 0)
        for name, _types in ros.node.get_topic_names_and_types():
            robot = name.split("/")[1]
            if robot in counts:
                counts[robot] += 1
        namespaces = {ns.strip("/") for _name, ns in ros.node.get_node_names_and_namespaces()}
        for robot in robots:
            if robot in namespaces:
                node_at.setdefault(robot, now)
            if counts[robot] >= args.expect:
                topics_at.setdefault(robot, now)
        if census_at is None and take_census(ros.node).unseen == 0:
            census_at = now
        if len(topics_at) == len(robots) and len(node_at) == len(robots) and census_at is not None:
            break
        time.sleep(0.01)
    ros.close()
    missing = args.limit
    print(
        json.dumps(
            {
                "ready": ready,
                "census": census_at if census_at is not None else missing,
                "nodes": max(node_at.get(r, missing) for r in robots),
                "topics": max(topics_at.get(r, missing) for r in robots),
            }
        )
    )
    return 0


def _peer(name: str) -> int:
    """A plain ROS node with five topics at 1 Hz (another process on the domain)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from std_msgs.msg import Float64

    context = Context()
    rclpy.init(args=[], context=context)
    node = Node(name, context=context)
    pubs = [node.create_publisher(Float64, f"/{name}/x{k}", 10) for k in range(5)]
    node.create_timer(1.0, lambda: [p.publish(Float64(data=1.0)) for p in pubs])
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    print("publishing", flush=True)
    executor.spin()
    return 0


def _summary(name: str, runs: list[dict[str, float]]) -> list[object]:
    topics = [r["topics"] for r in runs]
    late = sum(1 for r in runs if r["nodes"] > _LATE_S)
    return [
        name,
        len(runs),
        late,
        f"{statistics.median(r['census'] for r in runs):.2f}",
        f"{statistics.median(r['nodes'] for r in runs):.2f} / {max(r['nodes'] for r in runs):.2f}",
        f"{statistics.median(topics):.2f} / {max(topics):.2f}",
    ]


def main(argv: list[str] | None = None) -> int:
    """Start the robots (and peers), run the interleaved probes, print the table."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=20, help="runs of each variant")
    parser.add_argument("--subsystems", type=int, default=15, help="a robot's subsystems (20 tags each)")
    parser.add_argument("--peers", type=int, default=0, help="plain ROS nodes added to the domain")
    parser.add_argument("--limit", type=float, default=6.0, help="seconds a run waits at most")
    parser.add_argument("--domain", type=int, default=None, help="ROS domain (default: the environment's)")
    parser.add_argument("--probe", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--claim", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--robots", default="robot1,robot2", help=argparse.SUPPRESS)
    parser.add_argument("--expect", type=int, default=301, help=argparse.SUPPRESS)
    parser.add_argument("--peer", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    local_ros_env(args.domain)
    if args.probe:
        return _probe(args)
    if args.peer:
        return _peer(args.peer)
    robots = ["robot1", "robot2"]
    procs = []
    try:
        for robot in robots:
            os.environ["DBGLOG_NAMESPACE"] = robot
            fleet = ["-m", "benchmarks._fleet", "--subsystems", str(args.subsystems), "--tags", "20"]
            procs.append(start_ready(fleet))
        os.environ.pop("DBGLOG_NAMESPACE", None)
        for k in range(args.peers):
            procs.append(start_ready(["-m", "benchmarks.bench_discovery", "--peer", f"peer{k}"]))
        time.sleep(2.0)
        expect = str(args.subsystems * 20 + 1)  # the tags and the batch topic
        results: dict[str, list[dict[str, float]]] = {"plain": [], "profile": []}
        for _ in range(args.runs):
            for name in results:
                probe = ["-m", "benchmarks.bench_discovery", "--probe", "--robots", ",".join(robots)]
                probe += ["--expect", expect, "--limit", str(args.limit)]
                probe += ["--claim"] if name == "profile" else []
                out = subprocess.run([sys.executable, *probe], capture_output=True, text=True, check=True)
                results[name].append(json.loads(out.stdout.splitlines()[-1]))
    finally:
        for proc in procs:
            proc.kill()
            proc.wait(10)
    print_table(
        f"Discovery by a new dbglog process: {len(robots)} robots of {args.subsystems * 20} tags"
        + (f" and {args.peers} plain nodes" if args.peers else "")
        + f" ({len(robots) + args.peers} processes on the domain); seconds from the process's start",
        [
            "variant",
            "runs",
            f"late (> {_LATE_S:g} s)",
            "census complete, median",
            "every node median / max",
            "every topic median / max",
        ],
        [_summary(name, runs) for name, runs in results.items()],
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
