"""The viewer's history store: time queries against a brute-force reference, budgets, threads, CDR."""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dbglog.viewer._data._history import History

T = "/rosdashboard/x"

# Times on a coarse grid so that ties (equal source times) happen often.
_times = st.integers(min_value=0, max_value=60).map(lambda i: 1_700_000_000.0 + i * 0.5)
_batches = st.lists(st.lists(_times, min_size=1, max_size=12), min_size=1, max_size=25)


class _Reference:
    """Every appended sample, ordered by time with ties in arrival order: what the history must answer."""

    def __init__(self) -> None:
        self.times: list[float] = []
        self.values: list[float] = []

    def add(self, times: list[float], values: list[float]) -> None:
        self.times.extend(times)
        self.values.extend(values)

    def ordered(self) -> tuple[np.ndarray[Any, Any], np.ndarray[Any, Any]]:
        t = np.asarray(self.times)
        order = np.argsort(t, kind="stable")
        return t[order], np.asarray(self.values)[order]


def _fill(h: History, batches: list[list[float]]) -> _Reference:
    ref = _Reference()
    serial = 0.0
    for batch in batches:
        values = [serial + i for i in range(len(batch))]  # unique per sample: shows which one came back
        serial += len(batch)
        h.append_numbers(T, np.asarray(batch), np.asarray(values))
        ref.add(batch, values)
    return ref


@settings(deadline=None, max_examples=150)
@given(
    _batches,
    st.integers(min_value=2, max_value=9),
    st.lists(_times, min_size=1, max_size=10),
    st.sampled_from([0.0, 0.25, 1.0, 5.0, 1000.0]),
)
def test_time_queries_match_a_brute_force_reference(
    batches: list[list[float]], chunk: int, probes: list[float], window: float
) -> None:
    """at/prev/next/range/count agree with a sorted copy of everything sent, out-of-order batches included."""
    h = History(clock=None, chunk_samples=chunk, reorder_window=window)
    ref_t, ref_v = _fill(h, batches).ordered()
    assert h.count(T) == len(ref_t)
    assert h.span(T) == (ref_t[0], ref_t[-1])
    all_t, all_v = h.range(T, -np.inf, np.inf)
    assert all_t.tolist() == ref_t.tolist()
    assert all_v.tolist() == ref_v.tolist()
    lowest = float(ref_t[0]) - 1
    for p in [*probes, lowest, float(ref_t[-1]) + 1]:
        for q in (p, p + 0.25):
            k = int(np.searchsorted(ref_t, q, side="right")) - 1
            got = h.at(T, q)
            if k < 0:
                assert got is None
            else:
                assert got is not None
                assert (got.index, got.time, got.value) == (k, ref_t[k], ref_v[k])
            lower = ref_t[ref_t < q]
            assert h.prev_time(T, q) == (float(lower[-1]) if len(lower) else None)
            upper = ref_t[ref_t > q]
            assert h.next_time(T, q) == (float(upper[0]) if len(upper) else None)
            t, v = h.range(T, p, q + 1)
            inside = (ref_t >= p) & (ref_t <= q + 1)
            assert t.tolist() == ref_t[inside].tolist()
            assert v.tolist() == ref_v[inside].tolist()


def test_range_includes_both_ends_and_empty_ranges_are_empty() -> None:
    """range(t0, t1) holds t0 <= time <= t1 exactly; a range between samples or reversed is empty."""
    h = History(clock=None, chunk_samples=4)
    h.append_numbers(T, np.arange(10.0), np.arange(10.0) * 2)
    t, v = h.range(T, 3.0, 7.0)
    assert t.tolist() == [3.0, 4.0, 5.0, 6.0, 7.0]
    assert v.tolist() == [6.0, 8.0, 10.0, 12.0, 14.0]
    assert h.range(T, 3.2, 3.8)[0].size == 0
    assert h.range(T, 7.0, 3.0)[0].size == 0
    assert h.range(T, -5.0, -1.0)[0].size == 0
    assert h.range("/never", 0.0, 10.0)[0].size == 0
    assert h.at(T, 3.0) is not None
    assert h.at(T, -0.5) is None
    assert h.at("/never", 1.0) is None


def test_ints_beyond_2_53_and_bools_keep_their_exact_values() -> None:
    """Int64 values beyond 2**53 come back exactly (int64 column); bools come back as bools."""
    h = History(clock=None)
    big = np.array([2**53 + 1, 2**62 + 3, -(2**63)], dtype=np.int64)
    h.append_numbers("/i", [1.0, 2.0, 3.0], big)
    h.append_numbers("/u", [1.0], np.array([2**64 - 1], dtype=np.uint64))
    h.append_numbers("/b", [1.0, 2.0], np.array([True, False]))
    got = h.at("/i", 2.0)
    assert got is not None
    assert got.value == 2**62 + 3
    assert h.range("/i", 0, 9)[1].tolist() == [2**53 + 1, 2**62 + 3, -(2**63)]
    u = h.at("/u", 1.0)
    assert u is not None
    assert u.value == 2**64 - 1
    b = h.at("/b", 1.5)
    assert b is not None
    assert b.value is True


def test_duration_budget_drops_the_oldest_and_stale_arrivals() -> None:
    """With 10 s kept, a 100 s fill holds only the last ~10 s; a sample older than that is never stored."""
    h = History(clock=None, max_seconds=10.0, chunk_samples=64)
    for second in range(100):
        t = second + np.arange(100) / 100
        h.append_numbers(T, t, t)
        h.append_numbers("/slow", [float(second)], [1.0])
    span = h.span(T)
    assert span is not None
    assert 99.99 - 10.0 - 0.1 - 1e-9 <= span[0] <= 99.99 - 10.0 + 1e-9  # trimmed at most every 0.1 s
    slow = h.span("/slow")
    assert slow is not None
    assert slow[0] >= 89.0  # a 1 Hz topic in a single open chunk is trimmed too
    stats = h.stats()
    assert stats.samples + stats.evicted == 100 * 100 + 100
    assert stats.bytes_used < 100 * 100 * 16  # chunks of 64 samples: the evicted ones are freed
    h.append_numbers(T, [50.0, 99.995], [1.0, 2.0])
    assert h.stats().late_dropped == 1
    assert h.range(T, 0, 99.0)[0][0] == span[0]
    first = h.at(T, span[0])
    assert first is not None
    assert first.index == 100 * 100 + 1 - h.count(T)  # indices keep counting from the first sample ever


def test_memory_budget_evicts_oldest_chunks_across_topics() -> None:
    """Under a byte cap the history stays within it and what is left is the newest of every topic."""
    cap = 1024 * 1024
    h = History(clock=None, max_seconds=1e9, max_bytes=cap, chunk_samples=4096)
    for second in range(200):
        for k in range(5):
            t = second + np.arange(100) / 100
            h.append_numbers(f"/t{k}", t, t)
        assert h.bytes_used() <= cap
    stats = h.stats()
    assert stats.evicted > 0
    assert stats.samples + stats.evicted == 200 * 100 * 5
    assert stats.newest == pytest.approx(199.99)
    oldest = [h.span(f"/t{k}") for k in range(5)]
    starts = [s[0] for s in oldest if s is not None]
    assert len(starts) == 5
    assert max(starts) - min(starts) <= 4096 / 100  # evicted in age order: no topic kept much older data
    assert stats.samples * 16 <= cap


def test_a_future_clock_on_one_topic_does_not_evict_the_others() -> None:
    """The duration budget is bounded by the wall clock: one publisher an hour ahead evicts nothing."""
    now = 1_700_000_000.0
    h = History(max_seconds=60.0, clock=lambda: now)
    h.append_numbers("/ok", now - 30 + np.arange(30.0), np.arange(30.0))
    h.append_numbers("/ahead", [now + 3600.0], [1.0])
    h.append_numbers("/ok", [now], [1.0])
    assert h.count("/ok") == 31


def test_bad_input_is_refused_with_a_clear_error() -> None:
    """Mismatched lengths, NaN times, a kind or dtype change and bad budgets name what is wrong."""
    h = History(clock=None)
    with pytest.raises(ValueError, match="2 times but 1 values"):
        h.append_numbers(T, [1.0, 2.0], [1.0])
    with pytest.raises(ValueError, match="finite"):
        h.append_numbers(T, [np.nan], [1.0])
    with pytest.raises(ValueError, match="numbers or bools"):
        h.append_numbers(T, [1.0], np.array(["a"]))
    h.append_numbers(T, [1.0], [1.0])
    with pytest.raises(ValueError, match="holds float64 values, not int64"):
        h.append_numbers(T, [2.0], np.array([1], dtype=np.int64))
    with pytest.raises(ValueError, match="holds numbers, not payloads"):
        h.append_payloads(T, [2.0], [b"x"])
    with pytest.raises(ValueError, match="holds numbers: use range"):
        h.payloads(T, 0, 1)
    with pytest.raises(ValueError, match="query time is NaN"):
        h.at(T, float("nan"))
    with pytest.raises(ValueError, match="max_seconds must be > 0"):
        History(max_seconds=0)
    with pytest.raises(ValueError, match="at least 1 pixel"):
        h.decimate(T, 0, 1, 0)
    h.drop(T)
    h.append_payloads(T, [2.0], [b"x"], msg_type="std_msgs/msg/String")
    assert h.kind(T) == "payloads"
    assert h.msg_type(T) == "std_msgs/msg/String"


def test_cdr_payloads_round_trip_through_closed_chunks() -> None:
    """Real std_msgs/sensor_msgs/geometry_msgs CDR bytes come back identical and deserialize equal."""
    from geometry_msgs.msg import Twist
    from rclpy.serialization import deserialize_message, serialize_message
    from sensor_msgs.msg import LaserScan
    from std_msgs.msg import String

    h = History(clock=None, chunk_samples=7, chunk_bytes=300)
    kinds = {"/s": String, "/scan": LaserScan, "/cmd": Twist}
    sent: dict[str, list[Any]] = {topic: [] for topic in kinds}
    wire: dict[str, list[bytes]] = {topic: [] for topic in kinds}
    t0 = 1_700_000_000.0
    for i in range(40):
        s = String(data=f"line {i} é" * (i % 5))
        scan = LaserScan(angle_min=-1.0, ranges=[float(i + k) for k in range(i % 9)])
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = float(i), -float(i)
        for topic, msg in (("/s", s), ("/scan", scan), ("/cmd", cmd)):
            data = serialize_message(msg)  # serialized once: CDR padding bytes are not deterministic
            sent[topic].append(msg)
            wire[topic].append(data)
            h.append_payloads(topic, [t0 + i], [data], msg_type="any/msg/Type" if topic == "/s" else "")
    assert h.msg_type("/s") == "any/msg/Type"
    for topic, msgs in sent.items():
        times, payloads = h.payloads(topic, t0, t0 + 100)
        assert times.tolist() == [t0 + i for i in range(40)]
        assert payloads == wire[topic]
        assert [deserialize_message(p, kinds[topic]) for p in payloads] == msgs
        got = h.at(topic, t0 + 12.5)
        assert got is not None
        assert got.value == wire[topic][12]
        assert deserialize_message(got.value, kinds[topic]) == msgs[12]
    some_t, some = h.payloads("/scan", t0 + 5, t0 + 9)
    assert some == wire["/scan"][5:10]
    assert some_t.tolist() == [t0 + i for i in range(5, 10)]


def test_late_payloads_are_merged_in_time_order() -> None:
    """A late transient-local burst of older messages lands in time order, ties in arrival order."""
    from rclpy.serialization import deserialize_message, serialize_message
    from std_msgs.msg import String

    h = History(clock=None, chunk_samples=4, chunk_bytes=10_000)
    live = [serialize_message(String(data=f"live {i}")) for i in range(10)]
    h.append_payloads(T, [100.0 + i for i in range(10)], live)
    burst = [serialize_message(String(data=f"old {i}")) for i in range(6)]
    h.append_payloads(T, [103.0, 90.0, 91.0, 105.5, 92.0, 109.0], burst)
    times, payloads = h.payloads(T, 0, 1000)
    texts = [deserialize_message(p, String).data for p in payloads]
    assert times.tolist() == sorted(times.tolist())
    assert texts[:3] == ["old 1", "old 2", "old 4"]
    assert texts[3:8] == ["live 0", "live 1", "live 2", "live 3", "old 0"]  # 103.0: held first, then late
    assert texts.index("old 3") == texts.index("live 5") + 1
    assert texts[-2:] == ["live 9", "old 5"]


def _decimated_history(
    samples: int, chunk: int = 1000
) -> tuple[History, np.ndarray[Any, Any], np.ndarray[Any, Any]]:
    rng = np.random.default_rng(7)
    h = History(clock=None, chunk_samples=chunk)
    t = np.sort(rng.uniform(0, 100, samples))
    v = rng.normal(size=t.size)
    v[samples // 4 : samples // 4 + 100] = np.nan
    for part in np.array_split(np.arange(samples), 37):  # closed chunks and an open one
        h.append_numbers(T, t[part], v[part])
    return h, t, v


def test_decimate_keeps_each_pixels_min_and_max() -> None:
    """Below the block threshold the envelope of each pixel column equals a brute-force min/max."""
    h, t, v = _decimated_history(4000)
    pixels = 50  # 3200 samples in range: < 50 px x 4 blocks x 32, so raw samples are binned
    dt, dv = h.decimate(T, 10.0, 90.0, pixels)
    assert len(dt) <= 2 * pixels + 2
    edges = np.linspace(10.0, 90.0, pixels + 1)
    assert dt[0] < 10.0  # the neighbours outside the range
    assert dt[-1] > 90.0
    inner_t, inner_v = dt[1:-1], dv[1:-1]
    for b in range(pixels):
        hi_edge = edges[b + 1] if b < pixels - 1 else np.inf
        sel = (t >= edges[b]) & (t < hi_edge) & (t <= 90.0)
        mask = (inner_t >= edges[b]) & (inner_t < hi_edge)
        assert np.nanmin(v[sel]) == np.nanmin(inner_v[mask])
        assert np.nanmax(v[sel]) == np.nanmax(inner_v[mask])
    few_t, _ = h.decimate(T, 10.0, 10.05, 1000)
    raw_t, _ = h.range(T, 10.0, 10.05)
    assert few_t[1:-1].tolist() == raw_t.tolist()


@pytest.mark.parametrize("chunk", [1000, 65536])
def test_decimate_from_block_summaries_is_off_by_at_most_one_block(chunk: int) -> None:
    """Over many samples per pixel the envelope is exact overall and each column is within one block.

    With 65536-sample chunks everything is in the open chunk, whose blocks are filled in as it grows.
    """
    h, t, v = _decimated_history(200_000, chunk)
    pixels = 40  # 160,000 samples in range: 4,000 per column, block summaries answer
    dt, dv = h.decimate(T, 10.0, 90.0, pixels)
    inner_t, inner_v = dt[1:-1], dv[1:-1]
    assert len(inner_t) == 2 * pixels
    inside = (t >= 10.0) & (t <= 90.0)
    assert np.nanmin(inner_v) == np.nanmin(v[inside])
    assert np.nanmax(inner_v) == np.nanmax(v[inside])
    edges = np.searchsorted(t, np.linspace(10.0, 90.0, pixels + 1))
    edges[-1] = np.searchsorted(t, 90.0, side="right")
    block = 32
    for b in range(pixels):
        got_lo, got_hi = inner_v[2 * b], inner_v[2 * b + 1]
        a, e = edges[b], edges[b + 1]
        wide = v[max(a - block, edges[0]) : min(e + block, edges[-1])]
        narrow = v[a + block : e - block]
        assert np.nanmin(wide) <= got_lo <= np.nanmin(narrow)
        assert np.nanmax(narrow) <= got_hi <= np.nanmax(wide)
        assert t[a] <= inner_t[2 * b] <= t[min(a + block, e - 1)]


def test_a_writer_and_readers_never_see_an_inconsistent_history() -> None:
    """While one thread appends (late batches, eviction on), readers only ever see whole, sorted samples."""
    h = History(clock=None, max_seconds=20.0, max_bytes=3_000_000, chunk_samples=512)
    stop = threading.Event()
    problems: list[str] = []
    checks = [0]

    def value_of(t: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
        out: np.ndarray[Any, Any] = (
            np.sin(t) * 1000 + t
        )  # a sample's value follows from its time: a torn write shows
        return out

    def writer() -> None:
        base = 1_700_000_000.0
        for i in range(6000):
            t = base + i * 0.01 + np.arange(10) * 0.001
            if i % 7 == 0:
                t = t[::-1] - 0.05  # out of order within the batch, inside the reorder window
            elif i % 13 == 0:
                t = t - 2.0  # older than the window: rewrites held chunks
            for k in range(3):
                h.append_numbers(f"/w{k}", t, value_of(t))
        stop.set()

    def reader() -> None:
        last_count = 0
        while not stop.is_set():
            for k in range(3):
                topic = f"/w{k}"
                span = h.span(topic)
                if span is None:
                    continue
                t, v = h.range(topic, span[0], span[1])
                if len(t) != len(v) or np.any(np.diff(t) < 0) or not np.allclose(v, value_of(t)):
                    problems.append(f"range of {topic} inconsistent")
                mid = (span[0] + span[1]) / 2
                s = h.at(topic, mid)
                if s is None or s.time > mid or not np.isclose(s.value, value_of(np.array(s.time))):
                    problems.append(f"at({mid}) of {topic} gave {s}")
                nt = h.next_time(topic, mid)
                if nt is not None and nt <= mid:
                    problems.append(f"next_time({mid}) of {topic} gave {nt}")
                dt, _ = h.decimate(topic, span[0], span[1], 100)
                if np.any(np.diff(dt) < 0):
                    problems.append(f"decimate of {topic} not in time order")
            stats = h.stats()
            if stats.samples + stats.evicted + stats.late_dropped < last_count:
                problems.append("total count went backwards")
            last_count = stats.samples + stats.evicted + stats.late_dropped
            checks[0] += 1

    threads = [threading.Thread(target=writer), *(threading.Thread(target=reader) for _ in range(2))]
    for th in threads:
        th.start()
    for th in threads:
        th.join(timeout=100)
    assert not any(th.is_alive() for th in threads)
    assert problems == []
    assert checks[0] > 5
    assert h.bytes_used() <= 3_000_000
    assert h.stats().evicted > 0


def test_stats_report_span_and_bytes() -> None:
    """stats() gives topics, samples, bytes and the span over every topic; clear() empties it."""
    h = History(clock=None)
    assert h.span() is None
    h.append_numbers("/a", [5.0, 6.0], [1.0, 2.0])
    h.append_payloads("/b", [3.0], [b"\x00\x01\x00\x00"])
    s = h.stats()
    assert (s.topics, s.samples, s.oldest, s.newest) == (2, 3, 3.0, 6.0)
    assert s.bytes_used == h.bytes_used() > 0
    assert h.topics() == ["/a", "/b"]
    h.clear()
    assert h.stats().samples == 0
    assert h.bytes_used() == 0


def test_two_publishers_with_skewed_clocks_stay_sorted_and_visible_at_once() -> None:
    """Interleaved samples 30 ms apart land sorted in full chunks; the newest is queryable immediately."""
    h = History(clock=None, chunk_samples=256)
    t0 = 1_700_000_000.0
    for step in range(3000):
        t = t0 + step * 0.005 - (0.030 if step % 2 else 0.0)
        h.append_numbers(T, [t], [t])
        newest = h.at(T, t + 1.0)
        assert newest is not None
        assert newest.time >= t  # the sample just sent (or a newer one) answers at once
    times, values = h.range(T, 0, 2e9)
    assert len(times) == 3000
    assert times.tolist() == sorted(times.tolist())
    assert values.tolist() == times.tolist()
    chunks = h._view(T).chunks  # a white-box look: no pile of tiny chunks from the reordering
    assert len(chunks) <= 3000 // 256 + 3


def test_a_quiet_topic_with_a_reorder_window_is_still_evicted_by_duration() -> None:
    """The last samples of a topic that had late data and then went quiet leave with the rest."""
    h = History(clock=None, max_seconds=10.0)
    h.append_numbers("/quiet", [1.0, 2.0], [1.0, 2.0])
    h.append_numbers("/quiet", [1.9], [1.9])  # late: the topic now keeps a reorder window
    h.append_numbers("/quiet", [2.1], [2.1])
    for second in range(3, 40):
        h.append_numbers("/busy", [float(second)], [1.0])
    assert h.count("/quiet") == 0
    assert h.stats().evicted == 4 + 37 - h.count("/busy")


def test_the_callers_arrays_can_be_reused_after_append() -> None:
    """A writer that refills its batch buffers in place does not change what the history holds."""
    h = History(clock=None)
    h.append_numbers(T, [5.0], [5.0])
    h.append_numbers(T, [4.0], [4.0])  # late: the reorder window is in use from here on
    t = np.array([6.0, 6.1])
    v = np.array([60.0, 61.0])
    h.append_numbers(T, t, v)
    t[:] = [100.0, 101.0]
    v[:] = [-1.0, -1.0]
    times, values = h.range(T, 0, 1000)
    assert times.tolist() == [4.0, 5.0, 6.0, 6.1]
    assert values.tolist() == [4.0, 5.0, 60.0, 61.0]


def _walked(h: History) -> tuple[int, int, float | None, float | None]:
    """The totals as a walk over every topic answers them: (topics, samples, oldest, newest)."""
    spans = [s for s in (h.span(topic) for topic in h.topics()) if s is not None]
    samples = sum(h.count(topic) for topic in h.topics())
    oldest = min((s[0] for s in spans), default=None)
    newest = max((s[1] for s in spans), default=None)
    return len(h.topics()), samples, oldest, newest


_ops = st.lists(
    st.one_of(
        st.tuples(st.just("numbers"), st.integers(0, 3), st.lists(_times, min_size=1, max_size=8)),
        st.tuples(st.just("payloads"), st.integers(0, 3), st.lists(_times, min_size=1, max_size=4)),
        st.tuples(st.just("drop"), st.integers(0, 3), st.just([])),
        st.tuples(st.just("clear"), st.just(0), st.just([])),
    ),
    min_size=1,
    max_size=40,
)


@settings(deadline=None, max_examples=150)
@given(ops=_ops, max_seconds=st.sampled_from([5.0, 20.0, 1000.0]), max_bytes=st.sampled_from([3000, 10**7]))
def test_span_and_stats_kept_as_samples_arrive_equal_a_walk_over_every_topic(
    ops: list[tuple[str, int, list[float]]], max_seconds: float, max_bytes: int
) -> None:
    """The span and stats kept as samples arrive equal a walk over every topic's after each append (in order
    or late, merged in place), duration trim, memory eviction, drop and clear."""
    h = History(clock=None, max_seconds=max_seconds, max_bytes=max_bytes, chunk_samples=4, chunk_bytes=64)
    for kind, k, times in ops:
        topic = f"/rosdashboard/{kind[0]}{k}"
        if kind == "numbers":
            h.append_numbers(topic, times, [float(i) for i in range(len(times))])
        elif kind == "payloads":
            h.append_payloads(topic, times, [bytes(8) for _ in times])
        elif kind == "drop":
            h.drop(f"/rosdashboard/n{k}")
        else:
            h.clear()
        topics, samples, oldest, newest = _walked(h)
        stats = h.stats()
        assert (stats.topics, stats.samples, stats.oldest, stats.newest) == (topics, samples, oldest, newest)
        assert h.span() == (None if oldest is None else (oldest, newest))


def test_span_and_stats_cost_the_same_at_3000_topics_as_at_10() -> None:
    """Reading the whole history's span and stats walks no topic: at 3000 topics it costs what it costs at
    10 (the status bar and the time bar read them twice a frame)."""
    import time

    def read_ns(topics: int) -> float:
        h = History(clock=None)
        for k in range(topics):
            h.append_numbers(f"/rosdashboard/t{k}", [1_700_000_000.0 + k], [1.0])
        samples = []
        for _ in range(300):
            start = time.perf_counter_ns()
            h.span()
            h.stats()
            samples.append(time.perf_counter_ns() - start)
        return float(np.median(samples))

    few, many = read_ns(10), read_ns(3000)
    assert many < 5 * few + 5_000, (few, many)
