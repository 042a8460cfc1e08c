"""The engine remembers (issue 16): every dbglog tag and every bound topic is kept by time, a binding
made later starts with its topic's past, and any series answers "the state at time t".

Real ROS 2 throughout: dbglog SDK publishers in child processes (tags arrive on the batch topic),
plain rclpy publishers in this process for other topics.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from std_msgs.msg import Float64, String

from dbglog._ros._tags import topic_for_tag
from dbglog.viewer._data._engine import Engine
from dbglog.viewer._data._model import Binding, SeriesSnapshot, Status, ValueKind
from dbglog.viewer._data._timeline import NOT_YET, Timeline
from dbglog.viewer._values._transforms import Derivative, Scale
from tests._children import run_sdk
from tests._ros import RosPeer, wait_until

ROOT = Path(__file__).resolve().parent.parent
TIMEOUT = 30.0
_RUN = f"hist_{uuid.uuid4().hex[:6]}"


@pytest.fixture(scope="module")
def engine() -> Iterator[Engine]:
    """One real viewer engine with a history, for the module."""
    with Engine(node_name="history_engine", history_seconds=600, history_bytes=64 << 20) as e:
        yield e


@pytest.fixture(scope="module")
def peer() -> Iterator[RosPeer]:
    """An independent ROS participant publishing plain topics."""
    with RosPeer("history_peer") as p:
        yield p


def _wait_snap(engine: Engine, binding: Binding, ok: object) -> SeriesSnapshot:
    assert callable(ok)
    wait_until(lambda: bool(ok(engine.snapshot(binding))), TIMEOUT)
    snap = engine.snapshot(binding)
    assert ok(snap), f"condition never held: {snap}"
    return snap


def _sdk_log_known_values(engine: Engine, tag: str, n: int, period: float) -> None:
    """Log the values 0..n-1, one per `period` seconds, from a child process that stays until `engine`
    holds them all (at most 30 s)."""
    done = run_sdk(
        f"""
        import time, dbglog
        dbglog.init()
        time.sleep(2.0)  # the viewer's engine sees the batch writer first
        for i in range({n}):
            dbglog.logfloat({tag!r}, float(i))
            time.sleep({period})
        assert dbglog.flush(5.0)
        """,
        stay_until=lambda: engine.store.count(topic_for_tag(tag)) >= n,
    )
    assert done.returncode == 0, done.stderr


def test_a_tag_logged_before_anything_binds_it_is_back_filled(engine: Engine) -> None:
    """Every dbglog tag is kept from the moment it is seen: a plot added later starts with its past."""
    tag = f"{_RUN}/early"
    _sdk_log_known_values(engine, tag, 200, 0.005)
    topic = topic_for_tag(tag)
    assert wait_until(lambda: engine.store.count(topic) >= 200, TIMEOUT), engine.store.stats()
    binding = Binding(topic)
    own_keys = {k for k in engine.store.topics() if not k.startswith("/")}
    started = time.monotonic()
    engine.bind(binding)
    snap = _wait_snap(engine, binding, lambda s: s.count >= 200)
    assert time.monotonic() - started < 5
    # The plotted values are the tag's own: read from its history, not kept a second time.
    assert {k for k in engine.store.topics() if not k.startswith("/")} == own_keys
    assert snap.values.tolist() == [float(i) for i in range(200)]
    assert np.all(np.diff(snap.times) > 0)
    assert engine.samples_held(binding) == 200
    # A second binding on the same tag with a transform gets the same past, transformed.
    scaled = Binding(topic, transforms=(Scale(2.0),))
    engine.bind(scaled)
    snap2 = _wait_snap(engine, scaled, lambda s: s.count >= 200)
    assert snap2.values.tolist() == [2.0 * i for i in range(200)]


def test_snapshot_at_gives_the_value_and_status_at_that_time(engine: Engine, peer: RosPeer) -> None:
    """A series at time t: the last value at t, its samples up to t, stale when nothing came for a while."""
    topic = f"/{_RUN}/plain"
    pub = peer.publisher(topic, Float64)
    binding = Binding(topic)
    engine.bind(binding)
    assert peer.wait_for_subscribers(pub, timeout=TIMEOUT)
    for i in range(50):
        pub.publish(Float64(data=float(i)))
        time.sleep(0.01)
    time.sleep(2.5)  # a gap longer than the stale time
    for i in range(50, 60):
        pub.publish(Float64(data=float(i)))
        time.sleep(0.01)
    snap = _wait_snap(engine, binding, lambda s: s.count >= 60)
    times, values = snap.times, snap.values
    assert values.tolist() == [float(i) for i in range(60)]
    for k in (0, 10, 49, 55):
        at = engine.snapshot_at(binding, float(times[k]))
        assert at.last == float(k), (k, at)
        assert at.last_time == float(times[k])
        assert at.values[-1] == float(k)
        assert len(at.values) == k + 1
        assert at.status is Status.LIVE
        assert at.count == k + 1
    mid = float(times[49]) + 2.2  # in the gap, past the stale time
    gap = engine.snapshot_at(binding, mid)
    assert gap.last == 49.0
    assert gap.status is Status.STALE
    assert "no message for 2.2 s" in gap.reason
    before = engine.snapshot_at(binding, float(times[0]) - 1)
    assert before.status is Status.WAITING
    assert before.reason == NOT_YET
    assert before.last is None
    # Stepping walks the samples one by one.
    assert engine.neighbour_time(binding, float(times[10]), +1) == float(times[11])
    assert engine.neighbour_time(binding, float(times[10]), -1) == float(times[9])
    span = engine.time_span()
    assert span is not None
    assert span[0] <= times[0]
    assert span[1] >= times[-1]


def test_a_binding_added_later_on_a_plain_topic_starts_with_its_past(engine: Engine, peer: RosPeer) -> None:
    """A topic one widget binds is kept raw: another widget on another field of it gets the past too."""
    topic = f"/{_RUN}/words"
    pub = peer.publisher(topic, String)
    first = Binding(topic)
    engine.bind(first)
    assert peer.wait_for_subscribers(pub, timeout=TIMEOUT)
    for i in range(40):
        pub.publish(String(data=f"distance {i / 10:.1f} m"))
        time.sleep(0.01)
    snap = _wait_snap(engine, first, lambda s: s.count >= 40)
    assert snap.kind is ValueKind.TEXT
    assert engine.store.count(topic) == 40
    later = Binding(topic, regex=r"distance (\S+) m")
    engine.bind(later)
    got = _wait_snap(engine, later, lambda s: s.count >= 40)
    assert got.values.tolist() == [i / 10 for i in range(40)]
    assert got.times.tolist() == snap.times.tolist()
    # Text at a past time: the texts up to it, the last one the text then.
    at = engine.snapshot_at(first, float(snap.times[9]))
    assert at.last == "distance 0.9 m"
    assert at.texts[-1] == "distance 0.9 m"
    assert len(at.texts) == 10
    # New messages after the back-fill arrive once, in order.
    for i in range(40, 45):
        pub.publish(String(data=f"distance {i / 10:.1f} m"))
    got = _wait_snap(engine, later, lambda s: s.count >= 45)
    assert got.values.tolist() == [i / 10 for i in range(45)]


def test_unbinding_frees_the_series_history_but_keeps_the_topic(engine: Engine, peer: RosPeer) -> None:
    """A removed widget's values leave the history; the topic's own history stays for the next one."""
    topic = f"/{_RUN}/freed"
    pub = peer.publisher(topic, Float64)
    binding = Binding(topic, transforms=(Scale(3.0),))
    engine.bind(binding)
    assert peer.wait_for_subscribers(pub, timeout=TIMEOUT)
    for i in range(20):
        pub.publish(Float64(data=float(i)))
        time.sleep(0.005)
    _wait_snap(engine, binding, lambda s: s.count >= 20)
    key = next(k for k in engine.store.topics() if k.startswith("\x00") and engine.store.count(k) == 20)
    engine.unbind(binding)
    keep = Binding(f"/{_RUN}/other_to_wake_the_engine")
    engine.bind(keep)  # any change makes the ROS thread reconcile
    assert wait_until(lambda: key not in engine.store.topics(), TIMEOUT)
    assert engine.store.count(topic) == 20


def test_timeline_over_the_engine_pauses_steps_and_resumes(engine: Engine, peer: RosPeer) -> None:
    """The Timeline is the DataSource widgets read: paused, it hands out the past; live, the present."""
    topic = f"/{_RUN}/timeline"
    pub = peer.publisher(topic, Float64)
    binding = Binding(topic)
    timeline = Timeline(engine)
    timeline.bind(binding)
    assert peer.wait_for_subscribers(pub, timeout=TIMEOUT)
    for i in range(10):
        pub.publish(Float64(data=float(i)))
        time.sleep(0.01)
    snap = _wait_snap(engine, binding, lambda s: s.count >= 10)
    timeline.seek(float(snap.times[4]))
    assert not timeline.live
    assert timeline.snapshot(binding).last == 4.0
    assert timeline.step([binding], +1)
    assert timeline.snapshot(binding).last == 5.0
    assert timeline.step([binding], -1)
    assert timeline.step([binding], -1)
    assert timeline.snapshot(binding).last == 3.0
    for i in range(10, 15):
        pub.publish(Float64(data=float(i)))
    _wait_snap(engine, binding, lambda s: s.count >= 15)
    assert timeline.snapshot(binding).last == 3.0  # paused: new data does not move the widgets
    timeline.resume()
    assert timeline.snapshot(binding).last == 14.0
    stats = timeline.stats()
    assert stats is not None
    assert stats.bytes_used > 0
    assert stats.samples >= 15


def test_a_tag_bound_while_it_is_being_logged_gets_its_past_and_every_new_sample_once(engine: Engine) -> None:
    """Bound mid-stream: back-fill and live samples join without a gap or a duplicate, in time order."""
    tag = f"{_RUN}/midstream"
    topic = topic_for_tag(tag)
    env = {k: v for k, v in os.environ.items() if k not in ("DBGLOG", "DBGLOG_STRICT")}
    env["PYTHONPATH"] = str(ROOT)
    code = f"""
        import time, dbglog
        dbglog.init()
        time.sleep(2.0)
        for i in range(400):
            dbglog.logfloat({tag!r}, float(i))
            time.sleep(0.01)
        assert dbglog.flush(5.0)
        time.sleep(3.0)
    """
    child = subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], env=env, cwd=ROOT)
    try:
        assert wait_until(lambda: engine.store.count(topic) >= 100, TIMEOUT)
        binding = Binding(topic)
        engine.bind(binding)  # about a quarter of the way through
        snap = _wait_snap(engine, binding, lambda s: s.count >= 400)
    finally:
        child.wait(timeout=60)
    assert snap.values.tolist() == [float(i) for i in range(400)]
    assert np.all(np.diff(snap.times) > 0)
    assert snap.count == 400


def _two_writers(tag: str, start: float, seconds: float) -> list[subprocess.Popen[str]]:
    """Two SDK processes logging `tag` (one the value 1, the other 2) from wall time `start` for `seconds`,
    about every 0.5 ms: each flushes its batch every 10 ms, so the batches' source times interleave."""
    env = {k: v for k, v in os.environ.items() if k not in ("DBGLOG", "DBGLOG_STRICT")}
    env["PYTHONPATH"] = str(ROOT)
    children: list[subprocess.Popen[str]] = []
    for value in (1.0, 2.0):
        code = f"""
            import time, dbglog
            dbglog.init()
            dbglog.logfloat({tag!r}, 0.0)  # the tag shows on the graph: the viewer binds it before `start`
            time.sleep(max(0.0, {start!r} - time.time()))
            n = 0
            while time.time() < {start + seconds!r}:
                dbglog.logfloat({tag!r}, {value!r})
                n += 1
                time.sleep(0.0005)
            assert dbglog.flush(5.0)
            print(n, flush=True)
            time.sleep(2.0)
        """
        args = [sys.executable, "-c", textwrap.dedent(code)]
        children.append(subprocess.Popen(args, env=env, cwd=ROOT, stdout=subprocess.PIPE, text=True))
    return children


def test_two_publishers_of_one_tag_are_drawn_in_source_time_order(engine: Engine, tmp_path: Path) -> None:
    """Two real SDK publishers of one tag, their batches' source times interleaved: the live series, the
    history, the state at a past time and a CSV export all read it in source time order, both writers'
    samples interleaved, none lost (the plot drew loops back in time from the series in arrival order)."""
    from dbglog.viewer._data._export import export_csv

    tag = f"{_RUN}/two"
    topic = topic_for_tag(tag)
    binding = Binding(topic)
    engine.bind(binding)
    start = time.time() + 5.0
    children = _two_writers(tag, start, 0.6)
    try:
        _wait_snap(engine, binding, lambda s: s.count >= 2)
        assert time.time() < start, "the viewer took the tag too late for the test to mean anything"
        counts = [int(child.communicate(timeout=60)[0].split()[-1]) for child in children]
    finally:
        for child in children:
            if child.poll() is None:
                child.kill()
                child.wait()
    total = 2 + sum(counts)
    snap = _wait_snap(engine, binding, lambda s: s.count >= total)
    assert snap.count == total
    times, values = snap.times, snap.values
    assert len(times) == total, "the ring holds them all"
    assert np.all(np.diff(times) >= 0), f"{int(np.sum(np.diff(times) < 0))} steps back in time"
    live = values[times >= start]
    assert (live == 1.0).sum() == counts[0]
    assert (live == 2.0).sum() == counts[1]
    switches = int(np.count_nonzero(np.diff(live)))
    assert switches > 20, f"the writers' samples interleave in time ({switches} switches)"
    assert snap.last_time == times[-1]
    assert snap.last == values[-1]
    held_t, held_v = engine.store.range(topic, -np.inf, np.inf)
    assert held_t.tolist() == times.tolist()
    assert held_v.tolist() == values.tolist()
    mid = float(times[len(times) // 2])
    then = engine.snapshot_at(binding, mid)
    assert then.last_time == mid
    assert np.all(np.diff(then.times) >= 0)
    assert then.times.tolist() == times[times <= mid].tolist()
    rows = export_csv(engine, [binding], float(times[0]), float(times[-1]), tmp_path / "two.csv")
    exported = np.loadtxt(tmp_path / "two.csv", delimiter=",", skiprows=1, usecols=0)
    assert rows == len(exported) == len(times)  # one series: each sample its row (two may share a time)
    assert np.all(np.diff(exported) >= 0)  # (to the microsecond: two writers' samples may share one)


def test_a_derivative_of_two_publishers_of_one_tag_is_taken_in_source_time_order(engine: Engine) -> None:
    """Two real SDK publishers of one tag, their batches' source times interleaved: a derivative binding
    differentiates consecutive samples by source time, as the raw series holds them (it took them in
    arrival order: NaN for every sample older than the last it took, and slopes across the wrong pairs)."""
    tag = f"{_RUN}/slope"
    topic = topic_for_tag(tag)
    raw, slope = Binding(topic), Binding(topic, transforms=(Derivative(),))
    engine.bind(raw)
    engine.bind(slope)
    start = time.time() + 5.0
    children = _two_writers(tag, start, 0.6)
    try:
        _wait_snap(engine, raw, lambda s: s.count >= 2)
        assert time.time() < start, "the viewer took the tag too late for the test to mean anything"
        counts = [int(child.communicate(timeout=60)[0].split()[-1]) for child in children]
    finally:
        for child in children:
            if child.poll() is None:
                child.kill()
                child.wait()
    total = 2 + sum(counts)
    values = _wait_snap(engine, raw, lambda s: s.count >= total)
    assert values.count == total
    switches = int(np.count_nonzero(np.diff(values.values[values.times >= start])))
    assert switches > 20, f"the writers' samples interleave in time ({switches} switches)"
    # A sample that arrives after newer ones were differentiated is left out and counted (it waits at
    # most 0.5 s for older ones: a loaded machine delivers some batches later than that).
    sinks = [sink for sink in engine._ordering if sink.binding == slope and sink.reorder is not None]

    def left_out() -> int:
        return sum(sink.reorder.dropped for sink in sinks if sink.reorder is not None)

    wait_until(lambda: len(engine.snapshot(slope).times) + left_out() >= total, TIMEOUT)  # the last waited
    d = engine.snapshot(slope)
    assert len(d.times) + left_out() == total, f"{total - len(d.times)} of {total} samples left out"
    assert len(d.times) >= 0.5 * total, f"{left_out()} of {total} samples came too late"
    steps = np.diff(d.times)
    assert np.all(steps >= 0), "the derivative went back in source time"
    # Two writers' samples may share a source time (a float's resolution is ~0.24 us here): the second of
    # a tie has no slope (NaN), and a slope touching a shared time has no one value to check against.
    assert np.all(np.isnan(d.values[1:][steps == 0]))
    held_times, repeats = np.unique(values.times, return_counts=True)
    shared = set(held_times[repeats > 1].tolist()) | set(d.times[1:][steps == 0].tolist())
    by_time = dict(zip(values.times.tolist(), values.values.tolist(), strict=True))
    v = np.array([by_time[t] for t in d.times.tolist()])
    with np.errstate(divide="ignore", invalid="ignore"):
        expected = np.diff(v) / steps  # between the samples it took, consecutive by source time
    check = np.array(
        [a not in shared and b not in shared for a, b in zip(d.times[:-1], d.times[1:], strict=True)]
    )
    assert check.sum() >= 0.9 * len(check)
    assert np.isnan(d.values[0])
    wrong = ~np.isclose(d.values[1:][check], expected[check], rtol=1e-9, atol=0.0)
    assert not wrong.any(), f"{int(wrong.sum())} of {int(check.sum())} slopes differ"


def test_a_publisher_that_stops_is_drawn_with_a_gap_and_integers_as_steps(
    engine: Engine, peer: RosPeer
) -> None:
    """Real publishers that stop for 1.5 s and go on: the plot's lines from the engine's series break at
    the silence; an SDK logint tag and a plain Int32 topic are drawn as steps, a logfloat tag as a line."""
    from std_msgs.msg import Int32

    from dbglog.viewer._widgets._plotlines import LineJob, plot_lines, stepped

    count, level = topic_for_tag(f"{_RUN}/stop/count"), topic_for_tag(f"{_RUN}/stop/level")
    plain = f"/{_RUN}/stop/plain"
    bindings = [Binding(count), Binding(level), Binding(plain)]
    for binding in bindings:
        engine.bind(binding)
    pub = peer.publisher(plain, Int32)
    env = {k: v for k, v in os.environ.items() if k not in ("DBGLOG", "DBGLOG_STRICT")}
    env["PYTHONPATH"] = str(ROOT)
    code = f"""
        import time, dbglog
        dbglog.init()
        time.sleep(2.0)
        for part in range(2):
            for i in range(60):
                dbglog.logint({f"{_RUN}/stop/count"!r}, part * 100 + i // 10)
                dbglog.logfloat({f"{_RUN}/stop/level"!r}, 0.5 * i)
                time.sleep(0.01)
            time.sleep(1.5 if part == 0 else 0.0)
        assert dbglog.flush(5.0)
        time.sleep(1.0)
    """
    child = subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], env=env, cwd=ROOT)
    try:
        assert peer.wait_for_subscribers(pub, timeout=TIMEOUT)
        for part in range(2):
            for i in range(60):
                pub.publish(Int32(data=i // 10))
                time.sleep(0.01)
            time.sleep(1.5 if part == 0 else 0.0)
        snaps = [_wait_snap(engine, b, lambda s: s.count >= 120) for b in bindings]
    finally:
        child.wait(timeout=60)
    assert [stepped(s) for s in snaps] == [True, False, True]
    assert type(snaps[0].last) is int
    for snap in snaps:
        start, stop = float(snap.times[0]), float(snap.times[-1])
        job = LineJob((snap,), (None,), start, stop, stop, 800, None, None, 848, 240)
        ((x, y),) = plot_lines(job).lines
        # The silence is a break; any other break is an interval of the data itself far above its usual
        # one (a loaded machine pauses the publishing loops).
        intervals = np.diff(snap.times)
        assert 1 <= np.isnan(y).sum() <= np.sum(intervals > 5 * np.median(intervals)), snap.binding
        ok = ~np.isnan(y)
        spans = [x[i + 1] - x[i] for i in range(len(x) - 1) if ok[i] and ok[i + 1]]
        assert max(spans) < 0.5, f"{snap.binding.topic}: a segment across the silence ({max(spans):.2f} s)"


def test_tags_of_the_regex_bridge_and_of_a_plain_node_are_held_before_anything_binds_them(
    engine: Engine, peer: RosPeer, tmp_path: Path
) -> None:
    """A real bridge's tag and a plain node's tag, never bound: the history holds them from when the engine
    saw them, a binding made later starts with their past, and Save history as recording includes them."""
    from dbglog.record._inspect import echo_lines
    from dbglog.viewer._data._export import save_recording
    from tests._children import stop_child

    bridged, plain = f"{_RUN}/turtle/heading_deg", f"{_RUN}/plain_user"
    rules = tmp_path / "rules.yaml"
    rules.write_text(  # the demo's rule: two captures, two tags
        f"rules:\n  - tag: {_RUN}/turtle\n    node: history_peer\n"
        "    pattern: 'speed (?P<speed>[-+.0-9]+) m/s, heading (?P<heading_deg>[-+.0-9]+) deg'\n",
        encoding="utf-8",
    )
    bridge = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "bridge", str(rules), "--no-state", "--name", "history_bridge"],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
        cwd=ROOT,
    )
    try:
        # The engine sees the bridge's output as soon as the bridge runs, and subscribes to it unbound.
        assert wait_until(lambda: topic_for_tag(bridged) in engine.stats().per_topic, TIMEOUT)
        pub = peer.publisher(topic_for_tag(plain), Float64)
        assert wait_until(lambda: topic_for_tag(plain) in engine.stats().per_topic, TIMEOUT)
        assert peer.wait_for_subscribers(pub, 1, TIMEOUT)
        for k in range(20):
            peer.node.get_logger().info(f"odometry: speed 0.5 m/s, heading {1.5 * k} deg")
            pub.publish(Float64(data=-1.0 * k))
            time.sleep(0.01)
        held = [topic_for_tag(bridged), topic_for_tag(plain)]
        assert wait_until(lambda: all(engine.store.count(t) >= 20 for t in held), TIMEOUT), held
        binding = Binding(topic_for_tag(bridged))
        engine.bind(binding)  # a plot added later: its past at once, not "waiting"
        snap = _wait_snap(engine, binding, lambda s: s.count >= 20)
        assert snap.values.tolist() == [1.5 * k for k in range(20)]
        assert snap.status in (Status.LIVE, Status.STALE)
        out = tmp_path / "held.mcap"
        save_recording(engine.store, engine.held_types(), out)  # File > Save history > Everything held
        assert [float(v) for v in echo_lines(out, bridged)] == [1.5 * k for k in range(20)]
        assert [float(v) for v in echo_lines(out, plain)] == [-1.0 * k for k in range(20)]
        engine.unbind(binding)
    finally:
        stop_child(bridge)
