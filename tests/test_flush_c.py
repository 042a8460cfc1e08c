"""The publisher thread's per-sample work in C (``dbglog/api/_flush.c``) equals its Python version."""

from __future__ import annotations

import math
import struct
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dbglog._ros._batch import SCALAR_TYPES, decode_batch, type_code
from dbglog.api import _hot, _pipe


class Chan:
    """What a batch reads of a channel: its type code and its tag's UTF-8 bytes."""

    __slots__ = ("code", "tag_bytes")

    def __init__(self, tag: str, std_type: str) -> None:
        self.code = type_code(std_type)
        self.tag_bytes = tag.encode()

    def __repr__(self) -> str:
        return f"Chan({self.tag_bytes!r}, {SCALAR_TYPES[self.code]})"


class Text(str):
    """A str subclass (its text is what `str()` gives)."""


class Index:
    """Not an int, but usable as one (``__index__``)."""

    def __init__(self, n: int) -> None:
        self.n = n

    def __index__(self) -> int:
        return self.n


FLT_MAX = struct.unpack("<f", struct.pack("<f", 3.4028234663852886e38))[0]
GOOD: dict[str, list[object]] = {
    "Float64": [0.0, -0.0, 1.5, -1e300, math.inf, -math.inf, math.nan, 5e-324, 3, True, np.float32(0.1)],
    "Float32": [0.1, -0.0, FLT_MAX, -FLT_MAX, math.inf, math.nan, 1e-45, 2, False],
    "Int8": [0, -128, 127], "Int16": [-(2**15), 2**15 - 1], "Int32": [-(2**31), 7],
    "Int64": [-(2**63), 2**63 - 1, True, Index(-5), np.int64(-3)],
    "UInt8": [0, 255], "UInt16": [65535], "UInt32": [2**32 - 1], "UInt64": [2**64 - 1, 2**63, Index(9)],
    "Bool": [True, False],
    "String": ["", "ascii", "été", "日本", "a\ud800b", "x" * 70_000, Text("sub"), "\x7f"],
}  # fmt: skip
BAD: dict[str, list[object]] = {
    "Float64": ["1.0", None, 10**400, [1.0]],
    "Float32": [1e39, -3.5e38, "x"],
    "Int64": [1.5, 2**63, -(2**63) - 1, None, "3"],
    "UInt64": [-1, 2**64, 0.0],
    "Bool": [None, 0.5],
}
TAGS = [Chan(f"t{i}/{std}", std) for i, std in enumerate(SCALAR_TYPES)] + [
    Chan("dup/Float64", "Float64"),
    Chan("é/名", "String"),
    Chan("", "Int64"),
]


def _items(draw: st.DrawFn, bad: bool) -> list[tuple[Chan, object, int]]:
    chans = draw(st.lists(st.sampled_from(TAGS), min_size=1, max_size=6, unique_by=id))
    n = draw(st.integers(0, 40))
    items = []
    for _ in range(n):
        ch = draw(st.sampled_from(chans))
        std = SCALAR_TYPES[ch.code]
        pool = BAD[std] if bad and std in BAD and draw(st.integers(0, 9)) == 0 else GOOD[std]
        value = draw(st.sampled_from(pool))
        items.append((ch, value, draw(st.integers(-(2**63), 2**63 - 1))))
    return items


@st.composite
def good_items(draw: st.DrawFn) -> list[tuple[Chan, object, int]]:
    """Samples whose values fit their tags."""
    return _items(draw, bad=False)


@st.composite
def any_items(draw: st.DrawFn) -> list[tuple[Chan, object, int]]:
    """Samples, some of whose values fit no slot."""
    return _items(draw, bad=True)


def _both(items: list[Any], writer: int | None, seq: int) -> tuple[Any, Any]:
    """Each implementation's result, or the exception type it raised."""
    out: list[Any] = []
    fns: tuple[Callable[..., Any], ...] = (_pipe.pack_batch, _hot.pack_batch)
    for fn in fns:
        try:
            out.append(fn(list(items), writer, seq, 0))
        except Exception as exc:
            out.append(("raised", type(exc).__name__))
    return out[0], out[1]


def _same(py: Any, c: Any) -> None:
    if py[0] == "raised" or c[0] == "raised":
        assert py[0] == c[0] == "raised", (py, c)
        return
    (o1, n1, m1), (o2, n2, m2) = py, c
    assert [id(x) for x in o1] == [id(x) for x in o2]
    assert [id(x) for x in n1] == [id(x) for x in n2]  # the very value objects
    assert m1 == m2


@settings(max_examples=300, deadline=None)
@given(good_items(), st.integers(0, 2**64 - 1), st.integers(0, 2**64 - 1))
def test_c_and_python_build_the_same_batch(items: list[Any], writer: int, seq: int) -> None:
    """Same channels in order, same newest values, same bytes; and the bytes decode to the samples."""
    py, c = _both(items, writer, seq)
    _same(py, c)
    order, newest, message = c
    assert order == list(dict.fromkeys(ch for ch, _, _ in items))
    assert newest == [[v for ch2, v, _ in items if ch2 is ch][-1] for ch in order]
    decoded = decode_batch(message)
    assert (decoded.writer, decoded.seq, decoded.samples) == (writer, seq, len(items))
    by_tag = {t.tag: t for t in decoded.tags}
    for ch in order:
        mine = [(v, t) for ch2, v, t in items if ch2 is ch]
        got = by_tag[ch.tag_bytes.decode()]
        assert got.times_ns.tolist() == [t for _, t in mine]
        std = SCALAR_TYPES[ch.code]
        values = got.values if isinstance(got.values, list) else got.values.tolist()
        for v, back in zip([v for v, _ in mine], values, strict=True):
            if std == "String":
                assert back == str(v).encode("utf-8", "replace").decode()
            elif std == "Float32":
                want = struct.unpack("<f", struct.pack("<f", float(v)))[0]
                assert back == want or (math.isnan(back) and math.isnan(want))
            elif std == "Float64":
                assert back == float(v) or (math.isnan(back) and math.isnan(float(v)))
            else:
                assert back == int(v)


@settings(max_examples=300, deadline=None)
@given(any_items())
def test_a_value_that_fits_no_slot_fails_both_alike(items: list[Any]) -> None:
    """A bad value raises in both (the flush then sends each sample on its topic), or the same bytes."""
    _same(*_both(items, 7, 1))


def test_each_bad_value_raises_in_both() -> None:
    """Every value of `BAD` is refused by both, and the items list is left as it was."""
    for std, values in BAD.items():
        for value in values:
            items = [(TAGS[0], 1.0, 5), (Chan("bad", std), value, 6)]
            kept = list(items)
            py, c = _both(items, 1, 0)
            assert py[0] == c[0] == "raised", (std, value, py, c)
            assert items == kept


def test_without_a_writer_no_message_is_built() -> None:
    """`writer` None: only the grouping (no batch publisher); a value is not even looked at."""
    a, b = Chan("a", "Int64"), Chan("b", "String")
    items = [(a, 1, 0), (b, "x", 1), (a, 2.5, 2)]  # 2.5 fits no Int64 slot: not packed, not refused
    fns: tuple[Callable[..., Any], ...] = (_pipe.pack_batch, _hot.pack_batch)
    for fn in fns:
        order, newest, message = fn(items, None, 0, 0)
        assert order == [a, b]
        assert newest == [2.5, "x"]
        assert message is None


def test_an_empty_batch() -> None:
    """No samples: an empty but valid batch, as `encode_batch` makes it."""
    py, c = _both([], 3, 4)
    _same(py, c)
    assert decode_batch(c[2]).samples == 0


def test_tag_count_limit_is_the_headers() -> None:
    """At most 65535 tags in one batch (the header's u16): the same limit in both."""
    fits = [(Chan(f"t{i}", "Float64"), 1.0, i) for i in range(65535)]
    py, c = _both(fits, 1, 1)
    _same(py, c)
    py, c = _both([*fits, (Chan("one more", "Float64"), 1.0, 0)], 1, 1)
    assert py[0] == c[0] == "raised"


@pytest.mark.parametrize("bad", [[("not a tuple",)], [(TAGS[0], 1.0)], [(object(), 1.0, 0)]])
def test_malformed_items_raise(bad: list[Any]) -> None:
    """Not (channel, value, time) tuples of a channel: both raise rather than send garbage."""
    py, c = _both(bad, 1, 0)
    assert py[0] == c[0] == "raised"


@pytest.mark.parametrize("take", [_pipe.take_items, _hot.take], ids=["python", "c"])
def test_take_pops_up_to_the_limit(take: Callable[[deque[Any], int], list[Any]]) -> None:
    """Up to `limit` from the left, the rest stays queued; an empty queue or a zero limit takes none."""
    queue: deque[Any] = deque(range(10))
    assert take(queue, 4) == [0, 1, 2, 3]
    assert list(queue) == [4, 5, 6, 7, 8, 9]
    assert take(queue, 0) == []
    assert take(queue, 100) == [4, 5, 6, 7, 8, 9]
    assert take(queue, 5) == []
    assert not queue


def test_take_of_a_queue_emptied_meanwhile() -> None:
    """A queue that shrinks while it is taken from (a reset on another thread) gives what was there."""

    class Shrinking(deque[int]):
        def popleft(self) -> int:
            value = super().popleft()
            if value == 2:
                self.clear()
            return value

    for take in (_pipe.take_items, _hot.take):
        assert take(Shrinking(range(10)), 8) == [0, 1, 2]  # type: ignore[arg-type]


@contextmanager
def _only_explicit_gil_handoffs() -> Iterator[list[int]]:
    """A thread that counts whenever it holds the GIL, which it gets only when another lets it go.

    The switch interval is set so long that the interpreter never forces a handoff meanwhile.
    """
    counter = [0]
    stop = threading.Event()

    def spin() -> None:
        while not stop.is_set():
            counter[0] += 1
            time.sleep(0)  # lets the GIL go: the main thread runs between two counts

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1000.0)
    thread = threading.Thread(target=spin, daemon=True)
    thread.start()
    try:
        time.sleep(0.05)
        yield counter
    finally:
        stop.set()
        sys.setswitchinterval(interval)
        thread.join(10)


@pytest.mark.parametrize("pack", [_pipe.pack_batch, _hot.pack_batch], ids=["python", "c"])
def test_a_long_batch_lets_other_threads_run(pack: Callable[..., Any]) -> None:
    """With `breathe_ns` the GIL is let go during a long batch. Without it (a flush on the caller's
    thread, which must not sleep) C never lets it go; Python's ``bytes.join`` of a big batch does."""
    chans = [Chan("a", "Float64"), Chan("s", "String"), Chan("i", "Int32")]
    items = [(chans[i % 3], "text" if i % 3 == 1 else i, i) for i in range(60_000)]
    with _only_explicit_gil_handoffs() as counter:
        before = counter[0]
        kept = pack(items, 1, 0, 0)
        held = counter[0] - before
        before = counter[0]
        breathing = pack(items, 1, 0, 1)
        let_go = counter[0] - before
    assert held == 0 or pack is _pipe.pack_batch
    assert let_go > max(10, 2 * held)
    assert kept == breathing
