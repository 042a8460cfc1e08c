"""Parameters benchmark (issue 35): how soon a change is in the viewer's events store, and what it costs.

Run from the repository root: ``.venv/bin/python -m benchmarks.bench_params`` (``--help`` for options).

* **latency**: a real rclpy node in a child process with a declared ``kp``; this process runs the viewer's
  engine (its events store fed from ``/parameter_events``) and a `ParamClient` that sets ``kp`` ``--sets``
  times at ``--rate`` Hz. Per change: the set's round trip (call to answer), and the time from the node's
  own stamp of the change (when it accepted it; the same machine's clock) to the change being in the
  store, read by a 1 ms poll (so up to 1 ms late). Median, p95, p99 and the worst.
* **query**: `EventStore.between` over a 1 s window of a store holding ``--held`` changes (the timeline's
  question each frame): median µs a query; and `push` of one ParameterEvent (decode, old → new).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np

_ROOT = Path(__file__).resolve().parent.parent
if str(_ROOT) not in sys.path:
    sys.path.insert(0, str(_ROOT))

from benchmarks._common import local_ros_env, median_ns_per_call, print_table  # noqa: E402

_NODE = textwrap.dedent(
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.node import Node
    rclpy.init()
    node = Node("bench_pid")
    node.declare_parameter("kp", 0.0)
    print("ready", flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    """
)


def _pct(values: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(values), q))


def latency(sets: int, rate: float) -> None:
    """Set kp `sets` times; print the round trips and the delays to the events store."""
    from dbglog._ros._paramclient import ParamClient
    from dbglog._ros._params import PARAMETER_EVENTS
    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._events import ParamChange

    child = subprocess.Popen([sys.executable, "-c", _NODE], stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout is not None
        assert child.stdout.readline().strip() == "ready"
        with Engine() as engine, ParamClient() as params:
            store = engine.events()
            params.watch(store.seed)
            deadline = time.monotonic() + 30
            while (
                PARAMETER_EVENTS not in engine.stats().per_topic or store.value("/bench_pid", "kp") is None
            ) and (time.monotonic() < deadline):
                time.sleep(0.05)
            round_trips: list[float] = []
            delays: list[float] = []
            for i in range(sets):
                held = len(store.all())
                start = time.perf_counter()
                answer = params.set("/bench_pid", {"kp": float(i + 1)})
                while len(store.all()) <= held:
                    time.sleep(0.001)
                seen = time.time()
                change = store.all()[-1]
                assert isinstance(change, ParamChange)
                delays.append((seen - change.stamp) * 1e3)
                assert answer.result(10)[0].ok
                round_trips.append((time.perf_counter() - start) * 1e3)
                time.sleep(max(0.0, 1 / rate - (time.perf_counter() - start)))
    finally:
        child.terminate()
        child.wait(10)
    rows = [
        [name, f"{statistics.median(v):.1f}", f"{_pct(v, 95):.1f}", f"{_pct(v, 99):.1f}", f"{max(v):.1f}"]
        for name, v in (("set: call to answer", round_trips), ("node's change to events store", delays))
    ]
    print_table(f"{sets} changes of kp at {rate:g} Hz (ms)", ["", "median", "p95", "p99", "worst"], rows)


def query(held: int) -> None:
    """Time `between` on a store of `held` changes, and one push."""
    from rcl_interfaces.msg import Parameter, ParameterEvent
    from rclpy.serialization import serialize_message

    from dbglog._ros._params import PARAMETER_EVENTS, ParamValue
    from dbglog.viewer._data._events import EventStore

    msg = ParameterEvent(
        node="/bench_pid", changed_parameters=[Parameter(name="kp", value=ParamValue.of(1.0).to_msg())]
    )
    payload = bytes(serialize_message(msg))
    store = EventStore(capacity=held * 2)
    store.push(PARAMETER_EVENTS, np.arange(held) * 0.01, [payload] * held)
    span = held * 0.01
    rng = np.random.default_rng(1)
    starts = iter(rng.uniform(0, span, 10_000_000).tolist())
    between = median_ns_per_call(lambda: store.between(t := next(starts), t + 1.0), calls=2000, repeats=5)
    t = [span]

    def push() -> None:
        t[0] += 0.01
        store.push(PARAMETER_EVENTS, [t[0]], [payload])

    pushed = median_ns_per_call(push, calls=2000, repeats=5)
    print_table(
        f"events store holding {held:,} changes",
        ["operation", "median µs"],
        [
            ["between(t, t + 1 s) (about 100 events)", f"{between / 1e3:.1f}"],
            ["push one ParameterEvent", f"{pushed / 1e3:.1f}"],
        ],
    )


def main() -> None:
    """Run the benchmark."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--sets", type=int, default=200, help="changes made (default 200)")
    parser.add_argument("--rate", type=float, default=20.0, help="changes a second (default 20)")
    parser.add_argument(
        "--held", type=int, default=100_000, help="changes the store holds for --query (100,000)"
    )
    parser.add_argument("--domain", type=int, default=None, help="ROS_DOMAIN_ID (default: the environment's)")
    args = parser.parse_args()
    local_ros_env(args.domain)
    latency(args.sets, args.rate)
    query(args.held)


if __name__ == "__main__":
    main()
