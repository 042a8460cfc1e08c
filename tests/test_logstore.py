"""The Log console's store: decoding, bounds, time order, filters (checked against brute force), previews."""

from __future__ import annotations

import gc
import struct
import threading
import time
from dataclasses import dataclass

import numpy as np
import pytest
import re2
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dbglog._regex._compile import MAX_LINE
from dbglog._regex._propose import match_lines, propose
from dbglog.viewer._data._logstore import (
    DEBUG,
    ERROR,
    FATAL,
    INFO,
    WARN,
    FilterError,
    LogFilter,
    LogStore,
    level_name,
    level_of,
)
from tests._ros import wait_until

LOG = "rcl_interfaces/msg/Log"
STRING = "std_msgs/msg/String"


def _log_cdr(name: str, msg: str, level: int, *, file: str = "", function: str = "", line: int = 0) -> bytes:
    """A Log message serialized by rclpy itself (the bytes a subscription takes)."""
    from rcl_interfaces.msg import Log
    from rclpy.serialization import serialize_message

    m = Log()
    m.name, m.msg, m.level, m.file, m.function, m.line = name, msg, level, file, function, line
    data: bytes = serialize_message(m)
    return data


def _string_cdr(text: str) -> bytes:
    from rclpy.serialization import serialize_message
    from std_msgs.msg import String

    data: bytes = serialize_message(String(data=text))
    return data


# --- decoding ------------------------------------------------------------------------------------------


def test_push_decodes_log_messages_with_their_source_location() -> None:
    """Pushed Log payloads come out with level, node, message, file, function and line, by source time."""
    store = LogStore()
    payloads = [
        _log_cdr("planner", "distance 0.42 m", INFO, file="/src/plan.cpp", function="step", line=42),
        _log_cdr("driver", "motor stalled", ERROR, file="drive.py", function="on_tick", line=7),
        _log_cdr("planner", "", WARN),
    ]
    store.push(LOG, [10.0, 11.0, 12.0], payloads)
    assert store.pending == 3
    assert store.sync() == 3
    assert store.pending == 0
    first, second, third = (store.line(i) for i in range(3))
    assert (first.time, first.level, first.node, first.message) == (10.0, INFO, "planner", "distance 0.42 m")
    assert first.site == "/src/plan.cpp:step:42"
    assert (second.node, second.level, second.site) == ("driver", ERROR, "drive.py:on_tick:7")
    assert (third.message, third.site) == ("", "")
    assert store.nodes() == ["planner", "driver"]


def test_push_decodes_string_messages_without_level_or_node() -> None:
    """A String topic's lines have the text, no level, no node."""
    store = LogStore()
    store.push(STRING, [1.0, 2.0], [_string_cdr("hello"), _string_cdr("x=1.5\ny=2")])
    store.sync()
    line = store.line(1)
    assert (line.level, line.node, line.message) == (0, "", "x=1.5\ny=2")
    assert store.rows([1])[0][3] == "x=1.5 \u21b5 y=2"


def test_undecodable_payloads_are_skipped_and_counted() -> None:
    """Garbage bytes never stop the store: they are counted, the good lines stay."""
    store = LogStore()
    good = _log_cdr("a", "fine", INFO)
    store.push(LOG, [1.0, 2.0, 3.0], [b"\x00\x01\x00\x00\xff", good, b""])
    store.sync()
    assert len(store) == 1
    assert store.undecodable == 2
    assert store.line(0).message == "fine"


def _be_log_cdr(name: str, msg: str, level: int, file: str, function: str, line: int) -> bytes:
    """A Log message in big-endian CDR (what a big-endian machine's DDS sends; rclpy here writes little)."""
    out = bytearray(b"\x00\x00\x00\x00" + struct.pack(">iIB", 7, 9, level))

    def text(value: str) -> None:
        out.extend(b"\x00" * (-(len(out) - 4) % 4))  # aligned to 4 from the end of the header
        data = value.encode()
        out.extend(struct.pack(">I", len(data) + 1) + data + b"\x00")

    for value in (name, msg, file, function):
        text(value)
    out.extend(b"\x00" * (-(len(out) - 4) % 4))
    out.extend(struct.pack(">I", line))
    return bytes(out)


_words = st.text(st.characters(codec="utf-8", exclude_characters="\x00\x01\n\x1a\x1f"), max_size=11)


@settings(max_examples=60, deadline=None)
@given(
    lines=st.lists(
        st.tuples(
            _words.filter(bool),
            _words,
            st.sampled_from([DEBUG, INFO, WARN, ERROR, FATAL]),
            _words,
            _words,
            st.integers(0, 2**32 - 1),
        ),
        min_size=1,
        max_size=8,
    ),
    cut=st.integers(0, 200),
)
def test_log_payloads_decode_alike_in_either_byte_order_and_cut_ones_are_counted(
    lines: list[tuple[str, str, int, str, str, int]], cut: int
) -> None:
    """Every field of a Log line reads back the same from rclpy's little-endian bytes and from big-endian
    ones (names and messages of every length, so every padding); a payload cut short is counted, never
    raised, and the lines around it stay."""
    little = [_log_cdr(n, m, lv, file=f, function=fn, line=ln) for n, m, lv, f, fn, ln in lines]
    big = [_be_log_cdr(n, m, lv, f, fn, ln) for n, m, lv, f, fn, ln in lines]
    short = little[0][: min(cut, len(little[0]) - 1)]
    store = LogStore()
    store.push(LOG, np.arange(3 * len(lines) + 1, dtype=np.float64), [*little, short, *big, *little])
    store.sync()
    assert store.undecodable <= 1
    held = [store.line(i) for i in range(len(store))]
    expect = [(m, lv, n, f, fn, ln) for n, m, lv, f, fn, ln in lines]
    got = [(x.message, x.level, x.node, x.file, x.function, x.line) for x in held]
    if store.undecodable:
        assert got == expect * 3
    else:  # cut where the message had already ended: what the line kept reads alike
        assert got[: len(lines)] == expect
        assert got[len(lines) + 1 :] == expect * 2
        assert (got[len(lines)][2], got[len(lines)][0]) == (lines[0][0], lines[0][1])


def test_the_ids_shown_are_a_view_later_lines_leave_alone() -> None:
    """`select_within` gives its ids without copying them all; lines arriving later, late or evicting,
    do not change what was given."""
    store = LogStore(capacity=50)
    store.append(np.arange(40.0), [INFO] * 40, ["a"] * 40, [f"m {i}" for i in range(40)])
    ids, complete = store.select_within(LogFilter(min_level=INFO))
    given_ids = ids.tolist()
    assert complete
    assert not ids.flags.writeable
    store.append(np.arange(20.0) + 39.5, [INFO] * 20, ["a"] * 20, [f"late {i}" for i in range(20)])
    again, _ = store.select_within(LogFilter(min_level=INFO))
    assert ids.tolist() == given_ids
    assert len(again) == 50
    assert store.select(LogFilter()).flags.writeable  # select's answer is the caller's own copy


def test_sync_takes_at_most_the_lines_asked_for() -> None:
    """`sync(max_lines)` leaves the rest of the batches waiting for the next call."""
    store = LogStore()
    for k in range(5):
        store.push(LOG, [float(k)], [_log_cdr("n", f"line {k}", INFO)])
    assert store.sync(max_lines=2) == 2
    assert store.pending == 3
    assert store.sync() == 3


def test_waiting_batches_beyond_the_capacity_drop_the_oldest() -> None:
    """Pushed batches nobody syncs never grow beyond the capacity (the oldest go, counted as evicted)."""
    store = LogStore(capacity=10)
    for k in range(30):
        store.push(LOG, [float(k)], [_log_cdr("n", f"line {k}", INFO)])
    assert store.pending <= 10
    store.sync()
    assert [store.line(i).message for i in store.select(LogFilter())][-1] == "line 29"
    assert store.evicted + len(store) == 30


# --- the worker thread -------------------------------------------------------------------------------------


def _workers() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "dbglog-logs"]


def _batch(k: int, size: int) -> tuple[list[float], list[bytes]]:
    """Batch `k` of a stream: `size` lines, every 4th a WARN, numbered in their message."""
    numbers = range(k * size, (k + 1) * size)
    payloads = [
        _log_cdr(f"node{i % 3}", f"line {i} {'wall' if i % 5 == 0 else 'tick'}", WARN if i % 4 == 0 else INFO)
        for i in numbers
    ]
    return [float(i) for i in numbers], payloads


def test_a_line_pushed_to_a_worker_is_held_and_answered_after_sync() -> None:
    """With a worker, `sync` returns once every batch pushed before it is stored and every reader answered:
    the line is held, its reader shows it, and the count goes with the answer."""
    store = LogStore(worker=True)
    try:
        reader = store.reader()
        reader.ask(LogFilter(min_level=WARN))
        store.push(
            LOG, [5.0, 6.0], [_log_cdr("planner", "speed 1.5", INFO), _log_cdr("driver", "stall", WARN)]
        )
        store.sync()
        assert len(store) == 2
        assert store.line(1).message == "stall"
        shown = reader.shown()
        assert shown is not None
        assert shown.ids.tolist() == [1]
        assert (shown.complete, shown.held, shown.filt) == (True, 2, LogFilter(min_level=WARN))
        assert store.window(shown, shown.ids) == [(6.0, WARN, "driver", "stall")]
        assert store.marks()[0].tolist() == [6.0]
    finally:
        store.close()


def test_a_filter_changed_while_lines_arrive_answers_every_line() -> None:
    """A pushing thread streams lines while the reader's filter changes, several times: once the stream
    ends and the store has synced, the answer is exactly the filter's lines among all of them."""
    store = LogStore(worker=True)
    try:
        reader = store.reader()
        filters = [LogFilter(min_level=WARN), LogFilter(text="WALL"), LogFilter(include=r"line \d*7 ")]
        filters.append(LogFilter(hidden=frozenset({"node1"}), exclude="tick"))
        batches, size = 60, 50

        def stream() -> None:
            for k in range(batches):
                store.push(LOG, *_batch(k, size))
                time.sleep(0.002)

        pusher = threading.Thread(target=stream)
        pusher.start()
        for k in range(12):
            reader.ask(filters[k % len(filters)])
            store.step()
            time.sleep(0.01)
        pusher.join()
        reader.ask(filters[-1])
        store.sync()
        assert len(store) == batches * size

        def answered() -> bool:
            store.step()
            got = reader.shown()
            return got is not None and got.complete and got.filt == filters[-1]

        assert wait_until(answered, 10.0)
        shown = reader.shown()
        assert shown is not None
        want = [i for i in range(batches * size) if i % 3 != 1 and i % 5 == 0]  # node1 hidden, "tick" out
        assert shown.ids.tolist() == want
        assert shown.ids.tolist() == store.select(filters[-1]).tolist()
    finally:
        store.close()


def test_frames_with_nothing_new_give_no_new_answer_and_lines_come_without_frames() -> None:
    """A frame's `step` starts a turn only when something changed (no answer, so no redraw, for nothing),
    and lines pushed while no frame asks are taken in all the same."""
    store = LogStore(worker=True)
    try:
        reader = store.reader()
        store.push(LOG, *_batch(0, 20))
        assert wait_until(lambda: store.pending == 0 and store.published > 0, 10.0)  # no step, no sync
        store.step()
        shown = reader.shown()
        assert shown is not None
        assert len(shown.ids) == 20
        published = store.published
        for _ in range(20):
            store.step()
            time.sleep(0.005)
        assert store.published == published
        store.capacity = 10  # a change without a push: answered at the next frame
        store.step()
        assert wait_until(lambda: store.published > published, 10.0)
        store.step()
        shown = reader.shown()
        assert shown is not None
        assert shown.ids.tolist() == list(range(10, 20))
    finally:
        store.close()


def test_the_ui_thread_never_waits_for_a_turn_of_the_worker() -> None:
    """While the worker is in a turn (decoding, filtering: its writer lock held), taking the answer and
    reading the rows in view, the count, the marks and the cursor's index all return at once."""
    store = LogStore(worker=True)
    reader = store.reader()
    store.push(LOG, *_batch(0, 100))
    store.sync()
    shown = reader.shown()
    assert shown is not None
    in_turn, release = threading.Event(), threading.Event()

    def turn() -> None:
        with store._write:  # what a long turn of the worker holds
            in_turn.set()
            release.wait(30)

    busy = threading.Thread(target=turn)
    busy.start()
    try:
        assert in_turn.wait(10)
        got: list[object] = []

        def frame() -> None:
            store.step()
            got.extend(
                (
                    reader.shown(),
                    store.window(shown, shown.ids[-5:]),
                    len(store),
                    store.line(99).message,
                    store.marks()[0][-1],
                    store.index_at(50.5),
                    store.nodes(),
                )
            )

        ui = threading.Thread(target=frame)
        ui.start()
        ui.join(5)
        assert not ui.is_alive(), "a frame waited for the worker's turn"
        assert got[2:] == [100, "line 99 tick", 96.0, 50, ["node0", "node1", "node2"]]
    finally:
        release.set()
        busy.join()
        store.close()


def test_an_answer_given_stays_as_it_was_and_a_changed_store_refuses_its_window() -> None:
    """An answer is immutable: more lines, evictions and a late batch leave its ids alone; once a late batch
    rewrote the ids it refers to, `window` refuses it (None) until the next answer."""
    store = LogStore(capacity=300, worker=True)
    try:
        reader = store.reader()
        store.push(LOG, *_batch(0, 200))
        store.sync()
        first = reader.shown()
        assert first is not None
        ids = first.ids.tolist()
        assert ids == list(range(200))
        store.push(LOG, *_batch(2, 200))  # 400..599: 100 oldest evicted
        store.sync()
        assert first.ids.tolist() == ids
        assert store.window(first, first.ids[-3:]) is not None
        assert store.window(first, first.ids[:3]) is None  # evicted since
        late_times, late = _batch(1, 100)
        store.push(LOG, late_times, late)  # older than the newest: merged into the tail
        store.sync()
        assert store.window(first, first.ids[-3:]) is None
        second = reader.shown()
        assert second is not None
        assert store.window(second, second.ids[-1:]) == [(599.0, INFO, "node2", "line 599 tick")]
        assert first.ids.tolist() == ids
    finally:
        store.close()


def test_close_and_a_dropped_store_leave_no_thread() -> None:
    """`close` ends the worker (the store stays readable and syncs on the caller), and a store nobody holds
    any more takes its worker with it."""
    before = set(_workers())
    store = LogStore(worker=True)
    (worker,) = set(_workers()) - before
    store.close()
    assert not worker.is_alive()
    assert not store.threaded
    store.push(LOG, [1.0], [_log_cdr("n", "after close", INFO)])
    assert store.sync() == 1
    assert store.line(0).message == "after close"
    dropped = LogStore(worker=True)
    (worker,) = set(_workers()) - before
    dropped.push(LOG, *_batch(0, 10))
    del dropped
    gc.collect()
    assert wait_until(lambda: not worker.is_alive(), 10.0)
    assert set(_workers()) <= before


# --- bounds, ids, time order ----------------------------------------------------------------------------


def test_capacity_keeps_the_newest_lines_and_ids_keep_counting() -> None:
    """Beyond the capacity the oldest lines go; ids are never reused; lowering the capacity trims now."""
    store = LogStore(capacity=100)
    for k in range(25):
        store.append([float(i) for i in range(k * 10, k * 10 + 10)], [INFO] * 10, ["n"] * 10, ["m"] * 10)
    assert len(store) == 100
    assert (store.first_id, store.end_id) == (150, 250)
    assert store.evicted == 150
    assert store.line(150).time == 150.0
    with pytest.raises(IndexError):
        store.line(149)
    store.capacity = 10
    assert (len(store), store.first_id) == (10, 240)


def test_a_batch_larger_than_the_capacity_keeps_its_newest_lines() -> None:
    """One huge batch keeps only its newest `capacity` lines."""
    store = LogStore(capacity=5)
    store.append([0.5], [INFO], ["n"], ["old"])
    store.append([float(i) for i in range(20)], [INFO] * 20, ["n"] * 20, [f"m{i}" for i in range(20)])
    assert [store.line(i).message for i in store.select(LogFilter())] == [f"m{i}" for i in range(15, 20)]


def test_late_lines_are_sorted_in_by_time() -> None:
    """A batch older than the newest line held (a late node's transient-local burst) is merged in order."""
    store = LogStore()
    store.append([1.0, 3.0, 5.0], [INFO] * 3, ["a"] * 3, ["a1", "a3", "a5"])
    store.append([4.0, 2.0, 6.0], [WARN] * 3, ["b"] * 3, ["b4", "b2", "b6"])
    order = [store.line(i).message for i in store.select(LogFilter())]
    assert order == ["a1", "b2", "a3", "b4", "a5", "b6"]
    assert store.index_at(3.5) is not None
    assert store.line(store.index_at(3.5) or 0).message == "a3"
    assert store.marks()[0].tolist() == [2.0, 4.0, 6.0]


def test_index_at_and_until_cut_at_a_time() -> None:
    """The cursor: the last line at or before t, and a selection that ends there."""
    store = LogStore()
    store.append([1.0, 2.0, 2.0, 3.0], [INFO, ERROR, INFO, ERROR], ["n"] * 4, ["a", "b", "c", "d"])
    assert store.index_at(0.5) is None
    assert store.index_at(2.0) == 2
    assert store.select(LogFilter(), until=2.5).tolist() == [0, 1, 2]
    assert store.select(LogFilter(min_level=ERROR), until=2.5).tolist() == [1]
    assert store.select(LogFilter(), until=0.0).tolist() == []


def test_marks_are_the_warnings_errors_and_fatals() -> None:
    """Timeline marks: the times and levels of WARN and above, optionally only the worse ones."""
    store = LogStore()
    levels = [DEBUG, INFO, WARN, ERROR, FATAL, INFO]
    store.append([float(i) for i in range(6)], levels, ["n"] * 6, ["m"] * 6)
    times, marked = store.marks()
    assert times.tolist() == [2.0, 3.0, 4.0]
    assert marked.tolist() == [WARN, ERROR, FATAL]
    assert store.marks(ERROR)[0].tolist() == [3.0, 4.0]


def test_a_100_kb_line_is_cut_and_never_stalls() -> None:
    """A huge message keeps its first MAX_LINE bytes (whole characters), says what was cut, filters fast."""
    store = LogStore()
    big = "é" * 50_000 + " 12.5"  # 100 kB of two-byte characters
    start = time.perf_counter()
    store.push(LOG, [1.0], [_log_cdr("dump", big, INFO)])
    store.sync()
    ids = store.select(LogFilter(include=r"(a+)+$", text="é"))
    elapsed = time.perf_counter() - start
    line = store.line(0)
    assert len(line.message.encode()) <= MAX_LINE
    assert line.message == "é" * (MAX_LINE // 2)
    assert line.cut == len(big.encode()) - len(line.message.encode())
    assert ids.tolist() == []
    assert elapsed < 1.0


def test_levels_have_names() -> None:
    """Level names both ways; a String line's level 0 has no name."""
    assert level_of("warn") == level_of("WARNING") == WARN
    assert level_of("") == 0
    assert (level_name(FATAL), level_name(0)) == ("FATAL", "")
    with pytest.raises(ValueError, match="unknown level"):
        level_of("loud")


# --- filters --------------------------------------------------------------------------------------------


def _store(lines: list[tuple[float, int, str, str]], capacity: int = 1000) -> LogStore:
    store = LogStore(capacity=capacity)
    store.append(
        [t for t, *_ in lines], [lv for _, lv, *_ in lines], [n for *_, n, _ in lines], [m for *_, m in lines]
    )
    return store


def _messages(store: LogStore, ids: np.ndarray) -> list[str]:
    return [store.line(int(i)).message for i in ids]


def test_text_search_ignores_ascii_case_only() -> None:
    """Plain text search: ASCII letters in any case, everything else exactly, no regex meaning."""
    store = _store(
        [
            (1, INFO, "n", "Timeout on /scan"),
            (2, INFO, "n", "TIMEOUT"),
            (3, INFO, "n", "time out"),
            (4, INFO, "n", "Épée"),
            (5, INFO, "n", "a.b [x]"),
        ]
    )
    assert _messages(store, store.select(LogFilter(text="timeout"))) == ["Timeout on /scan", "TIMEOUT"]
    assert _messages(store, store.select(LogFilter(text="épée"))) == []
    assert _messages(store, store.select(LogFilter(text="Épée"))) == ["Épée"]
    assert _messages(store, store.select(LogFilter(text="[x]"))) == ["a.b [x]"]
    assert _messages(store, store.select(LogFilter(text="."))) == ["a.b [x]"]


def test_regex_anchors_mean_each_message() -> None:
    r"""^, $, \A and \z anchor at each message's start and end, never across messages."""
    store = _store(
        [(1, INFO, "n", "abc"), (2, INFO, "n", "xabc"), (3, INFO, "n", "ab\nc"), (4, INFO, "n", "c")]
    )
    assert _messages(store, store.select(LogFilter(include="^ab"))) == ["abc", "ab\nc"]
    assert _messages(store, store.select(LogFilter(include=r"\Aab"))) == ["abc", "ab\nc"]
    assert _messages(store, store.select(LogFilter(include=r"c\z"))) == ["abc", "xabc", "ab\nc", "c"]
    assert _messages(store, store.select(LogFilter(include=r"b\s*c"))) == ["abc", "xabc"]
    assert _messages(store, store.select(LogFilter(exclude="c$"))) == []
    assert _messages(store, store.select(LogFilter(include=r"[^a]c"))) == ["abc", "xabc", "ab\nc"]


def test_a_pattern_re2_refuses_raises_a_filter_error() -> None:
    """A bad include or exclude pattern says which one and RE2's reason; nothing is cached for it."""
    store = _store([(1, INFO, "n", "x")])
    with pytest.raises(FilterError, match=r"include: .*missing"):
        store.select(LogFilter(include="(x"))
    with pytest.raises(FilterError, match="exclude"):
        store.select(LogFilter(exclude=r"(a)\1"))
    assert store.select(LogFilter()).tolist() == [0]


_WORDS = ["error", "Error", "speed", "1.5", "-3", " ", "  ", "\n", "a", "b", "ab", "é", "x=2", "[z]", "ERROR"]
_PATTERNS = [
    "",
    "error",
    "(?i)error",
    "^a",
    "b$",
    r"\d+",
    r"\s",
    "[a-c]+",
    "x|z",
    ".",
    r"\Aa",
    r"b\z",
    "[^a]",
    r"e\w+r",
    "é",
    "a*",
]


_TIMES = [0.0, 1.0, 1.5, 2.0, 3.0, 10.0]
_LEVELS = [0, DEBUG, INFO, WARN, ERROR, FATAL]
_NODES = ["a", "b", "planner/local"]
_MAX_WORDS = 6
_LINE_CODES = len(_TIMES) * len(_LEVELS) * len(_NODES) * (_MAX_WORDS + 1) * len(_WORDS) ** _MAX_WORDS


def _line(code: int) -> tuple[float, int, str, str]:
    """The line numbered `code`: a time, a level, a node and up to six words (0 is the simplest line).

    One number a line rather than a draw for each part: the same lines at a fraction of Hypothesis's
    drawing cost (most of these tests' time went into drawing), and a smaller number is a simpler line."""
    code, t = divmod(code, len(_TIMES))
    code, level = divmod(code, len(_LEVELS))
    code, node = divmod(code, len(_NODES))
    code, count = divmod(code, _MAX_WORDS + 1)
    words = []
    for _ in range(count):
        code, word = divmod(code, len(_WORDS))
        words.append(_WORDS[word])
    return (_TIMES[t], _LEVELS[level], _NODES[node], "".join(words))


def _lines() -> st.SearchStrategy[list[tuple[float, int, str, str]]]:
    return st.lists(st.integers(0, _LINE_CODES - 1).map(_line), max_size=60)


@dataclass
class _Model:
    """What the store should hold: every line ever appended, stably sorted by time, the newest `capacity`."""

    capacity: int
    lines: list[tuple[float, int, str, str]]

    def held(self) -> list[tuple[float, int, str, str]]:
        ordered = sorted(self.lines, key=lambda x: x[0])  # stable: arrival order for equal times
        return ordered[-self.capacity :] if self.capacity else []


def _stored(message: str) -> bytes:
    data = message.encode()
    if len(data) > MAX_LINE:
        data = data[:MAX_LINE]
    return data.translate(bytes.maketrans(b"\x00\x01\n", b"\x1a\x1a\x1f"))


def _brute(line: tuple[float, int, str, str], filt: LogFilter) -> bool:
    _, level, node, message = line
    text = _stored(message)
    if level < filt.min_level or node in filt.hidden:
        return False
    if filt.text and filt.text.encode().lower() not in text.lower():
        return False
    if filt.include and re2.search(filt.include.encode(), text) is None:
        return False
    return not (filt.exclude and re2.search(filt.exclude.encode(), text) is not None)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    batches=st.lists(_lines(), min_size=1, max_size=5),
    capacity=st.integers(1, 80),
    filters=st.lists(
        st.builds(
            LogFilter,
            min_level=st.sampled_from([0, INFO, WARN, ERROR]),
            hidden=st.frozensets(st.sampled_from(["a", "b", "planner/local"]), max_size=2),
            include=st.sampled_from(_PATTERNS),
            exclude=st.sampled_from(_PATTERNS),
            text=st.sampled_from(["", "error", "ERR", "é", "[z]", " b", "x=", "1.5"]),
        ),
        min_size=1,
        max_size=3,
    ),
    until=st.sampled_from([None, 1.0, 1.7, 100.0]),
)
def test_filters_agree_with_brute_force(
    batches: list[list[tuple[float, int, str, str]]],
    capacity: int,
    filters: list[LogFilter],
    until: float | None,
) -> None:
    """Whatever arrives (late batches, evictions) and whatever the filters, the store shows exactly the held
    lines that match them one by one, in time order; cached and grown results equal fresh ones."""
    store = LogStore(capacity=capacity)
    model = _Model(capacity, [])
    for batch in batches:
        if batch:
            store.append(
                [t for t, *_ in batch],
                [lv for _, lv, *_ in batch],
                [n for *_, n, _ in batch],
                [m for *_, m in batch],
            )
        model.lines.extend(batch)
        for filt in filters:  # asked after every batch: the cache grows with the lines
            got = [store.line(int(i)) for i in store.select(filt, until=until)]
            want = [x for x in model.held() if _brute(x, filt) and (until is None or x[0] <= until)]
            assert [(g.time, g.level, g.node, g.message) for g in got] == [
                (t, lv, n, m.encode()[:MAX_LINE].decode("utf-8", "replace")) for t, lv, n, m in want
            ]
    fresh = LogStore(capacity=capacity)
    held = model.held()
    if held:
        fresh.append(
            [t for t, *_ in held], [lv for _, lv, *_ in held], [n for *_, n, _ in held], [m for *_, m in held]
        )
    for filt in filters:
        assert _messages(store, store.select(filt)) == _messages(fresh, fresh.select(filt))


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    batches=st.lists(_lines(), min_size=1, max_size=6),
    capacity=st.integers(1, 80),
    filt=st.builds(
        LogFilter,
        min_level=st.sampled_from([0, WARN]),
        include=st.sampled_from(_PATTERNS),
        exclude=st.sampled_from(_PATTERNS),
        text=st.sampled_from(["", "error", "b"]),
    ),
    asks=st.lists(st.integers(0, 3), min_size=6, max_size=6),
)
def test_answers_given_slice_by_slice_end_as_the_whole_answer(
    batches: list[list[tuple[float, int, str, str]]], capacity: int, filt: LogFilter, asks: list[int]
) -> None:
    """Newest lines first, a few at a time, with lines arriving meanwhile: the answer, once complete, is the
    brute-force one, and every partial answer is a correct newest part of it."""
    store = LogStore(capacity=capacity)
    store.first_slice = 3  # slices of 3 lines: many steps even for a few lines
    model = _Model(capacity, [])
    for batch, ask in zip(batches, asks, strict=False):
        if batch:
            store.append(
                [t for t, *_ in batch],
                [lv for _, lv, *_ in batch],
                [n for *_, n, _ in batch],
                [m for *_, m in batch],
            )
        model.lines.extend(batch)
        want = [x for x in model.held() if _brute(x, filt)]
        for _ in range(ask):
            ids, complete = store.select_within(filt, budget=0.0)
            got = [(g.time, g.level, g.node, g.message) for g in (store.line(int(i)) for i in ids)]
            expected = [(t, lv, n, m.encode()[:MAX_LINE].decode("utf-8", "replace")) for t, lv, n, m in want]
            assert got == expected[len(expected) - len(got) :]
            if complete:
                assert got == expected
    complete = False
    while not complete:
        ids, complete = store.select_within(filt, budget=0.0)
    want = [x for x in model.held() if _brute(x, filt)]
    assert [store.line(int(i)).message for i in ids] == [
        m.encode()[:MAX_LINE].decode("utf-8", "replace") for *_, m in want
    ]


def test_a_new_filter_answers_the_newest_lines_within_its_budget() -> None:
    """Over 100,000 lines a slow pattern answers the newest lines at once, and the rest over later calls."""
    n = 100_000
    store = _store([(float(i), INFO, "n", f"tick {i} load {i % 7}.{i % 10}") for i in range(n)], capacity=n)
    ids, complete = store.select_within(LogFilter(include=r"load [0-3]\.\d"), budget=0.005)
    assert not complete
    assert len(ids) > 0
    assert ids[-1] == store.end_id - 1 - min(k for k in range(7) if (n - 1 - k) % 7 < 4)
    calls = 1
    while not complete:
        ids, complete = store.select_within(LogFilter(include=r"load [0-3]\.\d"), budget=0.005)
        calls += 1
    assert calls > 2
    assert len(ids) == sum(1 for i in range(n) if i % 7 < 4)


def test_literal_patterns_and_alternations_match_like_re2() -> None:
    """Include/exclude patterns that are plain text (escaped punctuation, alternatives, (?i)) take a fast path
    with RE2's answer."""
    messages = ["Wall hit", "wall", "a.b", "axb", "Kelvin", "\u212aelvin", "ERROR x", "x|y", "timeout"]
    store = _store([(float(i), INFO, "n", m) for i, m in enumerate(messages)])
    for pattern in (
        "wall",
        "(?i)WALL",
        r"a\.b",
        "a.b",
        "ERROR|timeout",
        r"x\|y",
        "(?i)kelvin",
        "(?i)error|wall",
    ):
        want = [m for m in messages if re2.search(pattern, m)]
        assert _messages(store, store.select(LogFilter(include=pattern))) == want, pattern


def test_long_runs_of_matching_lines_are_found_whole() -> None:
    """Runs of consecutive matches (one DFA call each) and alternating lines: the brute-force answer."""
    messages = [
        f"tick {i} speed {i % 7}" if (i // 50) % 2 == 0 or i % 3 == 0 else f"idle {i}" for i in range(5000)
    ]
    store = _store([(float(i), INFO, "n", m) for i, m in enumerate(messages)], capacity=10_000)
    for pattern in ("speed", r"speed \d$", r"^tick\s\d+", "idle|tick 4"):
        want = [i for i, m in enumerate(messages) if re2.search(pattern, m)]
        assert store.select(LogFilter(include=pattern)).tolist() == want
        excluded = [i for i, m in enumerate(messages) if not re2.search(pattern, m)]
        assert store.select(LogFilter(exclude=pattern)).tolist() == excluded


def test_filters_grow_with_new_lines_and_forget_evicted_ones() -> None:
    """A filter asked again after more lines arrived answers for the new lines too, not for evicted ones."""
    store = LogStore(capacity=50)
    filt = LogFilter(text="warn", min_level=INFO)
    for k in range(20):
        store.append(
            [float(k * 10 + i) for i in range(10)],
            [INFO] * 10,
            ["n"] * 10,
            [f"warn {k * 10 + i}" if i % 2 else "ok" for i in range(10)],
        )
        ids = store.select(filt)
        assert all(store.has(int(i)) for i in ids)
        assert len(ids) == sum(
            1 for i in range(store.first_id, store.end_id) if "warn" in store.line(i).message
        )


# --- plot this number --------------------------------------------------------------------------------


def test_preview_agrees_with_the_proposer_over_stored_lines() -> None:
    """The preview of a proposal over the store equals `match_lines` over the same messages and nodes."""
    lines = []
    for i in range(3000):
        node = ("planner", "driver")[i % 2]
        if i % 5 == 0:
            msg = f"distance to wall: {i * 0.01:.2f} m (angle {-(i % 90)} deg)"
        elif i % 7 == 0:
            msg = f"distance to wall: nan m\n(angle {i} deg)"
        else:
            msg = f"tick {i}"
        lines.append((float(i), INFO if i % 3 else WARN, node, msg))
    store = _store(lines, capacity=10_000)
    proposal = propose("distance to wall: 0.42 m (angle -12.5 deg)", 0, node="planner")
    got = store.preview(proposal)
    rows, values = match_lines(proposal, [m for *_, m in lines], nodes=[n for _, _, n, _ in lines])
    assert got.ids.tolist() == rows.tolist()
    np.testing.assert_array_equal(got.values, values)
    assert got.times.tolist() == [float(r) for r in rows]
    assert got.count > 100
    every_node = store.preview(proposal, node="*")
    assert every_node.count > got.count
    warned = store.preview(proposal, min_level=WARN)
    assert set(warned.ids.tolist()) <= set(got.ids.tolist())
    assert 0 < warned.count < got.count


def test_numbers_of_a_line() -> None:
    """The numbers "plot this number" can capture, with their offsets in the message."""
    store = _store([(1.0, INFO, "n", "battery=87% 12.1V")])
    assert [(n.text, n.start) for n in store.numbers(0)] == [("87", 8), ("12.1", 12)]


def test_bytes_per_line_stay_small() -> None:
    """A 42-character line costs under 100 bytes all-in (columns, text, a cached filter)."""
    n = 20_000
    store = _store(
        [(float(i), INFO, f"node{i % 5}", f"distance to wall: {i * 0.01:10.2f} m ok!!") for i in range(n)],
        capacity=n,
    )
    store.select(LogFilter(text="wall"))
    assert store.bytes_used() / n < 100
