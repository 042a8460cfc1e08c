"""The viewer's time-indexed history: every topic's past, in columnar chunks, within one budget.

Numeric topics keep (source time, value) columns; any other topic keeps its serialized CDR payloads, so a
binding made later can re-extract its field, regex and transforms from the past. One writer thread
appends; any thread queries without a lock (docs/history.md).
"""

from __future__ import annotations

import bisect
import itertools
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal, TypeAlias

import numpy as np
import numpy.typing as npt

__all__ = [
    "DEFAULT_MAX_BYTES",
    "DEFAULT_MAX_SECONDS",
    "DEFAULT_REORDER_WINDOW",
    "History",
    "HistoryStats",
    "Sample",
]

DEFAULT_MAX_SECONDS = 1800.0
"""Keep 30 minutes by default."""
DEFAULT_MAX_BYTES = 512 * 1024 * 1024
"""And at most 512 MiB."""
DEFAULT_REORDER_WINDOW = 0.25
"""Samples up to 0.25 s late (two publishers, a DDS reorder) are sorted in at no extra cost."""
_PENDING_MAX = 1024
"""The reorder window holds at most this many samples (a 10 kHz topic does not copy 2500 per append)."""
DEFAULT_CHUNK_SAMPLES = 65536
DEFAULT_CHUNK_BYTES = 4 * 1024 * 1024
_FIRST_CAPACITY = 256
"""A new topic's first chunk; it doubles up to the chunk size, so a 1 Hz tag costs kilobytes."""
_CHUNK_OVERHEAD = 400
"""Bytes counted per chunk for its Python objects (array headers, the chunk, its view)."""
_SMALL = 16
"""Batches up to this size are checked in plain Python (cheaper than numpy calls)."""
_BLOCK = 32
"""Closed numeric chunks keep the min and max of every block of this many samples (for plots)."""
_BLOCKS_PER_PIXEL = 4
"""Decimate from block summaries when a pixel column spans at least this many blocks."""
_PAYLOAD_OVERHEAD = 41
"""Bytes counted per payload held as a Python `bytes` in an open chunk (object header + list slot)."""

Kind: TypeAlias = Literal["numbers", "payloads"]
Value: TypeAlias = float | int | bool | bytes
_F64 = npt.NDArray[np.float64]
_Arr = npt.NDArray[np.generic]


@dataclass(frozen=True, slots=True)
class Sample:
    """One held sample: its index since the topic's first sample, source time and value."""

    index: int
    """Position counted from the first sample the topic ever had (evicted ones included)."""
    time: float
    """Source time, seconds since the epoch."""
    value: Value
    """The number (int/bool kept exact) or, for a payload topic, the CDR bytes."""


@dataclass(frozen=True, slots=True)
class HistoryStats:
    """What the history holds, for the status bar."""

    topics: int
    samples: int
    bytes_used: int
    oldest: float | None
    newest: float | None
    evicted: int
    """Samples dropped by the budget so far (duration and memory)."""
    late_dropped: int
    """Samples that arrived already older than the duration budget, never stored."""
    max_bytes: int = DEFAULT_MAX_BYTES
    """The memory cap."""
    max_seconds: float = DEFAULT_MAX_SECONDS
    """The duration budget."""


_Summary: TypeAlias = tuple[int, int, int, float, float, int, int]
"""What `History.stats` and `History.span` answer, kept as samples arrive and leave, read in O(1): topics,
samples, bytes used, oldest and newest source time held (inf and -inf when empty), evicted, late dropped.
A plain tuple: the writer makes one per append."""
_EMPTY_SUMMARY: _Summary = (0, 0, 0, math.inf, -math.inf, 0, 0)


class _Chunk:
    """An immutable view of one chunk: times ``[start:n]`` sorted, and their values or payloads.

    The arrays may be longer than ``n`` (an open chunk); the writer only ever writes past every ``n``
    it has published, so a reader holding this view never sees a half-written sample.
    """

    __slots__ = ("blob", "data", "hi", "lo", "n", "nb", "offsets", "start", "times")

    def __init__(
        self,
        times: _F64,
        data: _Arr | list[bytes] | None,
        start: int,
        n: int,
        blob: bytes = b"",
        offsets: npt.NDArray[np.int64] | None = None,
    ) -> None:
        self.times = times
        self.data = data
        """Values array (numbers), a list of payloads (open payload chunk) or None (closed: blob)."""
        self.start = start
        self.n = n
        self.blob = blob
        self.offsets = offsets
        self.lo: _F64 | None = None
        """Closed numeric chunks: min of each block of `_BLOCK` samples from index 0 (NaN-ignoring)."""
        self.hi: _F64 | None = None
        self.nb = 0
        """Open numeric chunk (writer side): blocks whose min/max are filled in, ``n // _BLOCK``."""

    def update_blocks(self) -> None:
        """Fill in the min/max of the blocks an open numeric chunk has completed since the last call."""
        nb1 = self.n // _BLOCK
        if self.lo is None or self.hi is None or nb1 <= self.nb or not isinstance(self.data, np.ndarray):
            return
        seg = self.data[self.nb * _BLOCK : nb1 * _BLOCK].astype(np.float64, copy=False).reshape(-1, _BLOCK)
        with np.errstate(invalid="ignore"):
            self.lo[self.nb : nb1] = np.fmin.reduce(seg, axis=1)
            self.hi[self.nb : nb1] = np.fmax.reduce(seg, axis=1)
        self.nb = nb1

    def summarize(self) -> None:
        """Compute the block minima and maxima of a closed numeric chunk."""
        if isinstance(self.data, np.ndarray) and self.n:
            vals = self.data[: self.n].astype(np.float64, copy=False)
            starts = np.arange(0, self.n, _BLOCK)
            with np.errstate(invalid="ignore"):
                self.lo = np.fmin.reduceat(vals, starts)
                self.hi = np.fmax.reduceat(vals, starts)

    @property
    def size(self) -> int:
        return self.n - self.start

    @property
    def first(self) -> float:
        return float(self.times[self.start])

    @property
    def last(self) -> float:
        return float(self.times[self.n - 1])

    def value(self, i: int) -> Value:
        """Return the value at absolute position `i` of this chunk."""
        if self.offsets is not None:
            return self.blob[int(self.offsets[i]) : int(self.offsets[i + 1])]
        if isinstance(self.data, list):
            return self.data[i]
        if self.data is None:
            raise IndexError(i)
        v: Value = self.data[i].item()
        return v

    def payloads(self, i: int, j: int) -> list[bytes]:
        """Return the payloads at absolute positions ``[i:j]``."""
        if self.offsets is not None:
            offs = self.offsets[i : j + 1].tolist()
            blob = self.blob
            return [blob[a:b] for a, b in itertools.pairwise(offs)]
        return self.data[i:j] if isinstance(self.data, list) else []

    def nbytes(self) -> int:
        """Memory held by this closed chunk (allocated capacity, not just the live samples)."""
        total = self.times.nbytes + _CHUNK_OVERHEAD
        if self.offsets is not None:
            total += len(self.blob) + self.offsets.nbytes
        elif isinstance(self.data, np.ndarray):
            total += self.data.nbytes
        if self.lo is not None and self.hi is not None:
            total += self.lo.nbytes + self.hi.nbytes
        return total


class _View:
    """One topic's published state: chunks in time order (disjoint), their first times, counts."""

    __slots__ = ("before", "chunks", "count", "firsts")

    def __init__(self, chunks: tuple[_Chunk, ...], firsts: list[float], before: list[int]) -> None:
        self.chunks = chunks
        self.firsts = firsts
        self.before = before
        """``before[i]``: the index of chunk i's first sample (``before[-1]``: one past the newest)."""
        self.count = before[-1] - before[0]


_EMPTY_VIEW = _View((), [], [0])


class _Track:
    """One topic's writer-side state (only touched under the history's lock)."""

    __slots__ = (
        "closed",
        "closed_bytes",
        "closed_cache",
        "dropped",
        "dtype",
        "kind",
        "msg_type",
        "nbytes",
        "newest",
        "open",
        "open_bytes",
        "pending",
        "pending_bytes",
        "reorders",
        "view",
    )

    def __init__(self, kind: Kind, dtype: np.dtype[np.generic] | None, msg_type: str) -> None:
        self.kind: Kind = kind
        self.dtype = dtype
        self.msg_type = msg_type
        self.closed: list[_Chunk] = []
        self.closed_bytes = 0
        self.closed_cache: tuple[tuple[_Chunk, ...], list[float], list[int]] | None = None
        """The closed chunks' part of the view, rebuilt only when they change."""
        self.open: _Chunk | None = None
        self.open_bytes = 0
        """Payload bytes in the open chunk's list."""
        self.dropped = 0
        self.nbytes = 0
        self.newest = -math.inf
        """The newest source time ever written to the chunks: a batch from here on is appended in place."""
        self.pending: _Chunk | None = None
        """The reorder window: the newest samples, sorted, in small arrays replaced (never written) on
        each append; they move to the chunks once older than the window."""
        self.pending_bytes = 0
        self.reorders = False
        """Set once a late sample is seen: from then on the topic keeps a reorder window."""
        self.view = _EMPTY_VIEW

    def closed_changed(self) -> None:
        self.closed_cache = None
        self.closed_bytes = sum(c.nbytes() for c in self.closed)

    def publish(self) -> None:
        if self.closed_cache is None:
            firsts = [c.first for c in self.closed]
            before = [self.dropped]
            for c in self.closed:
                before.append(before[-1] + c.size)
            self.closed_cache = (tuple(self.closed), firsts, before)
        chunks, firsts, before = self.closed_cache
        o = self.open
        if o is not None and o.size:
            view = _Chunk(o.times, o.data, o.start, o.n)
            view.lo, view.hi = o.lo, o.hi  # filled for every block below n // _BLOCK
            chunks = (*chunks, view)
            firsts = [*firsts, o.first]
            before = [*before, before[-1] + o.size]
        p = self.pending
        if p is not None:
            chunks = (*chunks, p)
            firsts = [*firsts, p.first]
            before = [*before, before[-1] + p.size]
        self.view = _View(chunks, firsts, before)

    def oldest_chunk(self) -> _Chunk | None:
        if self.closed:
            return self.closed[0]
        return self.open if self.open is not None and self.open.size else None

    def recount(self) -> int:
        """Recompute this track's bytes (closed chunks' sum is kept up to date); return the change."""
        total = self.closed_bytes + self.pending_bytes
        o = self.open
        if o is not None:
            total += o.times.nbytes + _CHUNK_OVERHEAD
            if isinstance(o.data, list):
                total += self.open_bytes + _PAYLOAD_OVERHEAD * len(o.data)
            elif o.data is not None:
                total += o.data.nbytes
            if o.lo is not None and o.hi is not None:
                total += o.lo.nbytes + o.hi.nbytes
        delta = total - self.nbytes
        self.nbytes = total
        return delta


def _envelope(pieces: Sequence[tuple[_F64, _F64, _F64]], edges: _F64) -> tuple[_F64, _F64]:
    """Bin (time, min, max) pieces into columns starting at `edges`: each column's min and max.

    Works on each piece's own arrays (views: no large temporary copies) and merges the columns that
    straddle two pieces.
    """
    bins_l: list[npt.NDArray[np.intp]] = []
    t_l: list[_F64] = []
    lo_l: list[_F64] = []
    hi_l: list[_F64] = []
    for times, lo, hi in pieces:
        if not len(times):
            continue
        b0 = max(int(np.searchsorted(edges, times[0], side="right")) - 1, 0)
        b1 = int(np.searchsorted(edges, times[-1], side="right"))
        idx = np.searchsorted(times, edges[b0:b1], side="left")
        idx[0] = 0
        bounds = np.append(idx, len(times))
        nonempty = np.flatnonzero(bounds[1:] > bounds[:-1])
        starts = idx[nonempty]
        bins_l.append(nonempty + b0)
        t_l.append(times[starts])
        with np.errstate(invalid="ignore"):
            lo_l.append(np.fmin.reduceat(lo, starts))
            hi_l.append(np.fmax.reduceat(hi, starts))
    if not bins_l:
        return np.empty(0), np.empty(0)
    bins, first_t = np.concatenate(bins_l), np.concatenate(t_l)
    lows, highs = np.concatenate(lo_l), np.concatenate(hi_l)
    if len(bins) > 1 and not (bins[1:] > bins[:-1]).all():  # a column split across pieces
        u = np.flatnonzero(np.r_[True, bins[1:] != bins[:-1]])
        first_t = first_t[u]
        with np.errstate(invalid="ignore"):
            lows, highs = np.fmin.reduceat(lows, u), np.fmax.reduceat(highs, u)
    vals = np.empty(2 * len(lows))
    vals[0::2] = lows
    vals[1::2] = highs
    return np.repeat(first_t, 2), vals


def _open_chunk(times: _F64, data: _Arr | list[bytes], n: int) -> _Chunk:
    """Make an open chunk holding `n` samples; a numeric one gets its block min/max arrays."""
    chunk = _Chunk(times, data, 0, n)
    if isinstance(data, np.ndarray):
        chunk.lo = np.empty(len(times) // _BLOCK + 1)
        chunk.hi = np.empty(len(times) // _BLOCK + 1)
        chunk.update_blocks()
    return chunk


def _check_time(t: float) -> None:
    if t != t:  # NaN: every comparison would be False and the answer meaningless
        raise ValueError("history: a query time is NaN")


def _value_dtype(values: _Arr, topic: str) -> np.dtype[np.generic]:
    kind = values.dtype.kind
    if kind == "f":
        return np.dtype(np.float64)
    if kind == "i":
        return np.dtype(np.int64)
    if kind == "u":
        return np.dtype(np.uint64)
    if kind == "b":
        return np.dtype(np.bool_)
    raise ValueError(f"history of {topic!r}: values must be numbers or bools, not {values.dtype}")


class History:
    """Every topic's recent past, time-indexed, within a duration and a memory budget.

    Args:
        max_seconds: keep samples whose source time is within this many seconds of the newest.
        max_bytes: memory cap over all topics; the oldest chunks go first.
        chunk_samples: samples per full chunk (the unit of eviction).
        chunk_bytes: payload bytes that close a payload chunk early.
        reorder_window: once a topic has had a late sample, its newest samples within this many
            seconds are kept apart, so a later sample up to this much late is sorted in cheaply; an
            older one rewrites the chunks it overlaps.
        clock: wall clock (epoch seconds) that bounds "the newest" for the duration budget, so one
            publisher with a clock in the future cannot evict everyone's past; None trusts the data
            (replay of a recording).

    Example:
        >>> h = History(clock=None)
        >>> h.append_numbers("/a", np.array([1.0, 2.0]), np.array([10.0, 20.0]))
        >>> h.at("/a", 1.5)
        Sample(index=0, time=1.0, value=10.0)
    """

    def __init__(
        self,
        *,
        max_seconds: float = DEFAULT_MAX_SECONDS,
        max_bytes: int = DEFAULT_MAX_BYTES,
        chunk_samples: int = DEFAULT_CHUNK_SAMPLES,
        chunk_bytes: int = DEFAULT_CHUNK_BYTES,
        reorder_window: float = DEFAULT_REORDER_WINDOW,
        clock: Callable[[], float] | None = time.time,
    ) -> None:
        if not max_seconds > 0:
            raise ValueError(f"history max_seconds must be > 0, not {max_seconds}")
        if max_bytes < 1:
            raise ValueError(f"history max_bytes must be >= 1, not {max_bytes}")
        if chunk_samples < 2:
            raise ValueError(f"history chunk_samples must be >= 2, not {chunk_samples}")
        if chunk_bytes < 1:
            raise ValueError(f"history chunk_bytes must be >= 1, not {chunk_bytes}")
        if not reorder_window >= 0:
            raise ValueError(f"history reorder_window must be >= 0, not {reorder_window}")
        self._window = float(reorder_window)
        self.max_seconds = float(max_seconds)
        self.max_bytes = int(max_bytes)
        self._chunk = int(chunk_samples)
        self._chunk_bytes = int(chunk_bytes)
        self._clock = clock
        self._lock = threading.Lock()
        self._tracks: dict[str, _Track] = {}
        self._bytes = 0
        self._newest = -np.inf
        self._horizon = -np.inf
        self._evicted = 0
        self._late = 0
        self._trim_step = min(1.0, self.max_seconds / 100)
        self._samples = 0
        self._oldest = math.inf
        self._newest_held = -math.inf
        self._walk = False
        """Samples left (a trim, an eviction, a dropped topic): the oldest and newest are walked for again."""
        self._summary = _EMPTY_SUMMARY
        """Replaced (never changed) by the writer after each write: readers take it without the lock."""

    # --- writer side (one thread: the engine's ROS thread) ----------------------------------------

    def append_numbers(self, topic: str, times: npt.ArrayLike, values: npt.ArrayLike) -> None:
        """Append a batch of numeric samples (arrival order; times need not be sorted).

        Args:
            topic: the topic name.
            times: source times, epoch seconds.
            values: numbers or bools; ints are kept as int64/uint64, exact beyond 2**53.
        """
        t = np.asarray(times, dtype=np.float64).ravel()
        v = np.asarray(values).ravel()
        if len(t) != len(v):
            raise ValueError(f"history of {topic!r}: {len(t)} times but {len(v)} values")
        if not len(t):
            return
        dtype = _value_dtype(v, topic)
        with self._lock:
            track = self._track(topic, "numbers", dtype, "")
            if track.dtype != dtype:
                raise ValueError(
                    f"history of {topic!r} holds {track.dtype} values, not {dtype}: drop() it when its "
                    "type changes"
                )
            v = v.astype(dtype, copy=False)
            if not self._append_in_place(track, t, v):
                self._append(track, t, v)
            self._summarize()

    def append_payloads(
        self, topic: str, times: npt.ArrayLike, payloads: Sequence[bytes], *, msg_type: str = ""
    ) -> None:
        """Append a batch of serialized (CDR) messages with their source times, in arrival order.

        Args:
            topic: the topic name.
            times: source times, epoch seconds.
            payloads: one `bytes` per message, as `take_message(cls, raw=True)` returns it.
            msg_type: the ROS type, e.g. ``std_msgs/msg/String``, kept for whoever reads them back.
        """
        t = np.asarray(times, dtype=np.float64).ravel()
        if len(t) != len(payloads):
            raise ValueError(f"history of {topic!r}: {len(t)} times but {len(payloads)} payloads")
        if not len(t):
            return
        items = list(payloads) if set(map(type, payloads)) == {bytes} else [bytes(p) for p in payloads]
        with self._lock:
            track = self._track(topic, "payloads", None, msg_type)
            if msg_type:
                track.msg_type = msg_type
            self._append(track, t, items)
            self._summarize()

    def drop(self, topic: str) -> None:
        """Forget a topic's history (e.g. when its type changes)."""
        with self._lock:
            track = self._tracks.pop(topic, None)
            if track is not None:
                self._bytes -= track.nbytes
                self._samples -= track.view.count
                self._walk = True
            self._summarize()

    def clear(self) -> None:
        """Forget everything."""
        with self._lock:
            self._tracks.clear()
            self._bytes = 0
            self._newest = self._horizon = -np.inf
            self._samples, self._oldest, self._newest_held, self._walk = 0, math.inf, -math.inf, False
            self._summarize()

    def _track(self, topic: str, kind: Kind, dtype: np.dtype[np.generic] | None, msg_type: str) -> _Track:
        track = self._tracks.get(topic)
        if track is None:
            track = self._tracks[topic] = _Track(kind, dtype, msg_type)
        elif track.kind != kind:
            raise ValueError(f"history of {topic!r} holds {track.kind}, not {kind}: drop() it first")
        return track

    def _publish(self, track: _Track, newest: float | None) -> None:
        """Publish a track's new view and keep the totals: samples, the oldest and newest time held.

        Args:
            track: the track written to.
            newest: the newest time just written to it; None after samples left (a trim, an eviction):
                the oldest, or a whole topic's newest, may have gone, and are walked for in `_summarize`.
        """
        before = track.view.count
        track.publish()
        view = track.view
        self._samples += view.count - before
        if newest is None:
            self._walk = True
        elif view.firsts:
            if view.firsts[0] < self._oldest:
                self._oldest = view.firsts[0]
            if newest > self._newest_held:
                self._newest_held = newest

    def _summarize(self) -> None:
        """Replace the summary readers take (walking every topic only after samples left)."""
        if self._walk:
            views = [t.view for t in self._tracks.values() if t.view.chunks]
            self._oldest = min((v.chunks[0].first for v in views), default=math.inf)
            self._newest_held = max((v.chunks[-1].last for v in views), default=-math.inf)
            self._walk = False
        self._summary = (
            len(self._tracks),
            self._samples,
            self._bytes,
            self._oldest,
            self._newest_held,
            self._evicted,
            self._late,
        )

    def _append(self, track: _Track, t: _F64, data: _Arr | list[bytes]) -> None:
        n = len(t)
        if n <= _SMALL:  # the engine's usual batch: plain Python is cheaper than numpy calls here
            tl = t.tolist()
            if not all(map(math.isfinite, tl)):
                raise ValueError(f"history: source times must be finite, got {tl}")
            ordered = all(a <= b for a, b in itertools.pairwise(tl))
            first, last = tl[0], tl[-1]
        else:
            if not np.isfinite(t).all():
                raise ValueError(f"history: source times must be finite, got {t[~np.isfinite(t)][0]}")
            ordered = not (t[1:] < t[:-1]).any()
            first, last = float(t[0]), float(t[-1])
        if not ordered:  # an unsorted batch: sort it, ties keep arrival order
            order = np.argsort(t, kind="stable")
            t = t[order]
            data = [data[i] for i in order] if isinstance(data, list) else data[order]
            first, last = float(t[0]), float(t[-1])
        if first < self._horizon:  # already older than the budget: never stored
            keep = int(np.searchsorted(t, self._horizon, side="left"))
            self._late += keep
            if keep == n:
                return
            t, data = t[keep:], data[keep:]
            first = float(t[0])
        if first < track.newest:  # older than what the chunks hold: rewrite what it overlaps (rare)
            self._flush(track)
            self._merge(track, t, data)
        elif track.reorders:
            self._reorder(track, t, data)
        else:
            self._extend(track, t, data)
        self._publish(track, last)
        self._bytes += track.recount()
        if last > self._newest:
            self._newest = last
        self._enforce()

    def _append_in_place(self, track: _Track, t: _F64, v: _Arr) -> bool:
        """Write a small, sorted, in-order numeric batch into the open chunk's room; False: use `_append`.

        The engine's usual batch (a few samples of one topic a cycle) takes this path: it skips what
        `_append` checks and rebuilds for the general case (sorting, late samples, growing or closing a
        chunk, memory recount: an in-place write past the published ``n`` changes no allocation).
        """
        n = len(t)
        o = track.open
        if n > _SMALL or o is None or o.data is None or track.reorders or o.n + n > len(o.times):
            return False
        tl = t.tolist()
        first, last = tl[0], tl[-1]
        # Finite ends of a sorted batch bound every time between them (a NaN breaks the order).
        if not (math.isfinite(first) and math.isfinite(last)) or first < max(track.newest, self._horizon):
            return False
        if n > 1 and not all(a <= b for a, b in itertools.pairwise(tl)):
            return False
        o.data[o.n : o.n + n] = v
        o.times[o.n : o.n + n] = t
        o.n += n
        o.update_blocks()
        track.newest = last
        self._publish(track, last)
        if last > self._newest:
            self._newest = last
        self._enforce()
        return True

    def _reorder(self, track: _Track, t: _F64, data: _Arr | list[bytes]) -> None:
        """Sort a batch into the reorder window; move what is older than the window to the chunks."""
        p = track.pending
        if p is not None:
            t = np.concatenate([p.times, t])
            if isinstance(data, list):
                data = (p.data if isinstance(p.data, list) else []) + data
            elif isinstance(p.data, np.ndarray):
                data = np.concatenate([p.data, data])
            if t[p.n - 1] > t[p.n]:
                order = np.argsort(t, kind="stable")  # ties: the held sample stays first
                t = t[order]
                data = [data[i] for i in order] if isinstance(data, list) else data[order]
        self._hold(track, t, data)

    def _hold(self, track: _Track, t: _F64, data: _Arr | list[bytes]) -> None:
        """Keep the sorted samples within the reorder window of the newest apart; extend the rest."""
        n = len(t)
        k = max(int(np.searchsorted(t, t[-1] - self._window, side="right")), n - _PENDING_MAX)
        if k > 0:
            self._extend(track, t[:k], data[:k])
        if k < n:
            rest_t = t[k:].copy()  # never a view of the caller's arrays
            rest = data[k:] if isinstance(data, list) else data[k:].copy()
            track.pending = _Chunk(rest_t, rest, 0, n - k)
            if isinstance(rest, list):
                track.pending_bytes = rest_t.nbytes + sum(map(len, rest)) + _PAYLOAD_OVERHEAD * len(rest)
            else:
                track.pending_bytes = rest_t.nbytes + rest.nbytes
        else:
            track.pending, track.pending_bytes = None, 0

    def _flush(self, track: _Track) -> None:
        """Move the whole reorder window to the chunks."""
        p = track.pending
        if p is not None and p.data is not None:
            track.pending, track.pending_bytes = None, 0
            self._extend(track, p.times, p.data)

    def _new_open(self, track: _Track, need: int) -> _Chunk:
        cap = min(self._chunk, max(_FIRST_CAPACITY, 1 << (need - 1).bit_length()))
        times = np.empty(cap, dtype=np.float64)
        data: _Arr | list[bytes] = [] if track.kind == "payloads" else np.empty(cap, dtype=track.dtype)
        track.open_bytes = 0
        return _open_chunk(times, data, 0)

    def _close_open(self, track: _Track) -> None:
        o = track.open
        if o is not None and o.size:
            if isinstance(o.data, list):
                lens = np.fromiter(map(len, o.data[o.start : o.n]), dtype=np.int64, count=o.size)
                offsets = np.zeros(o.size + 1, dtype=np.int64)
                np.cumsum(lens, out=offsets[1:])
                closed = _Chunk(
                    o.times[o.start : o.n].copy(), None, 0, o.size, b"".join(o.data[o.start : o.n]), offsets
                )
            elif o.n < len(o.times) and o.data is not None:  # closed early: shrink to the live samples
                closed = _Chunk(o.times[o.start : o.n].copy(), o.data[o.start : o.n].copy(), 0, o.size)
            else:
                closed = o
            closed.summarize()
            track.closed.append(closed)
            track.closed_bytes += closed.nbytes()
            track.closed_cache = None
        track.open = None

    def _extend(self, track: _Track, t: _F64, data: _Arr | list[bytes]) -> None:
        """Append samples no older than the track's newest: in place past every published ``n``."""
        done = 0
        total = len(t)
        if total:
            track.newest = max(track.newest, float(t[-1]))
        while done < total:
            o = track.open
            if o is None:
                o = track.open = self._new_open(track, total - done)
            cap = len(o.times)
            if o.n == cap or (track.kind == "payloads" and track.open_bytes >= self._chunk_bytes):
                if cap < self._chunk and track.open_bytes < self._chunk_bytes:  # grow (copy, never in place)
                    live = o.size
                    new_cap = min(self._chunk, max(2 * cap, live + total - done))
                    times = np.empty(new_cap, dtype=np.float64)
                    times[:live] = o.times[o.start : o.n]
                    if isinstance(o.data, list):
                        new_data: _Arr | list[bytes] = o.data[o.start : o.n]
                        track.open_bytes = sum(map(len, new_data))
                    else:
                        new_data = np.empty(new_cap, dtype=track.dtype)
                        if o.data is not None:
                            new_data[:live] = o.data[o.start : o.n]
                    o = track.open = _open_chunk(times, new_data, live)
                else:
                    full = o.n == cap
                    self._close_open(track)
                    o = track.open = self._new_open(track, self._chunk if full else total - done)
                    continue
            k = min(len(o.times) - o.n, total - done)
            if isinstance(o.data, list):
                limit = self._chunk_bytes - track.open_bytes
                part = data[done : done + k]
                size = 0
                for j, p in enumerate(part):
                    size += len(p)
                    if size >= limit:
                        k = j + 1
                        break
                o.data.extend(part[:k])
                track.open_bytes += sum(map(len, part[:k]))
            elif o.data is not None:
                o.data[o.n : o.n + k] = data[done : done + k]
            o.times[o.n : o.n + k] = t[done : done + k]
            o.n += k
            o.update_blocks()
            done += k

    def _merge(self, track: _Track, t: _F64, data: _Arr | list[bytes]) -> None:
        """Merge samples older than the track's newest: rebuild the chunks they overlap (copies).

        Only the part newer than ``t[0]`` is sorted; the first affected chunk's older head is copied as is.
        """
        chunks = list(track.closed)
        if track.open is not None and track.open.size:
            chunks.append(track.open)
        lasts = [c.last for c in chunks]
        i = bisect.bisect_right(lasts, float(t[0]))  # chunks ending at or before t[0] stay as they are
        affected = chunks[i:]
        p = 0
        if affected:
            c0 = affected[0]
            p = c0.start + int(np.searchsorted(c0.times[c0.start : c0.n], t[0], side="right"))
        spans = [(c, p if k == 0 else c.start) for k, c in enumerate(affected)]
        tail = np.concatenate([c.times[a : c.n] for c, a in spans] + [t])
        order = np.argsort(tail, kind="stable")  # ties: what was held first stays first
        head_t = [affected[0].times[affected[0].start : p]] if affected else []
        times = np.concatenate([*head_t, tail[order]])
        merged: _Arr | list[bytes]
        if isinstance(data, list):
            items: list[bytes] = []
            for c, a in spans:
                items.extend(c.payloads(a, c.n))
            items.extend(data)
            head = affected[0].payloads(affected[0].start, p) if affected else []
            merged = head + [items[j] for j in order]
        else:
            parts = [c.data[a : c.n] for c, a in spans if isinstance(c.data, np.ndarray)]
            heads = [c.data[c.start : p] for c in affected[:1] if isinstance(c.data, np.ndarray)]
            merged = np.concatenate([*heads, np.concatenate([*parts, data])[order]])
        if i < len(track.closed):
            track.closed = chunks[:i]
            track.closed_changed()
        track.open = None
        track.newest = chunks[i - 1].last if i > 0 else -math.inf
        if self._window > 0:
            track.reorders = True
            self._hold(track, times, merged)  # the newest part becomes the reorder window
        else:
            self._extend(track, times, merged)

    def _enforce(self) -> None:
        """Apply the budget: trim by duration (at most every 1 s of data), then evict by memory."""
        newest = self._newest
        if self._clock is not None:
            newest = min(newest, self._clock() + 1.0)
        horizon = newest - self.max_seconds
        if horizon >= self._horizon + self._trim_step:
            self._horizon = horizon
            for track in self._tracks.values():
                if self._trim(track, horizon):
                    self._publish(track, None)
                    self._bytes += track.recount()
        while self._bytes > self.max_bytes:
            victim: _Track | None = None
            oldest = np.inf
            for track in self._tracks.values():
                c = track.oldest_chunk()
                if c is not None and c.last < oldest:
                    victim, oldest = track, c.last
            if victim is None:
                break
            self._drop_oldest(victim)
            self._publish(victim, None)
            self._bytes += victim.recount()

    def _trim(self, track: _Track, horizon: float) -> bool:
        changed = False
        if track.pending is not None and track.pending.first < horizon:  # a topic that went quiet
            self._flush(track)
            changed = True
        while track.closed and track.closed[0].last < horizon:
            gone = track.closed.pop(0)
            track.closed_bytes -= gone.nbytes()
            track.dropped += gone.size
            self._evicted += gone.size
            changed = True
        chunk = track.closed[0] if track.closed else track.open
        if chunk is not None and chunk.size and chunk.first < horizon:
            cut = int(np.searchsorted(chunk.times[chunk.start : chunk.n], horizon, side="left"))
            new = _Chunk(chunk.times, chunk.data, chunk.start + cut, chunk.n, chunk.blob, chunk.offsets)
            new.lo, new.hi, new.nb = chunk.lo, chunk.hi, chunk.nb
            if track.closed:
                track.closed[0] = new
            else:
                track.open = new
            track.dropped += cut
            self._evicted += cut
            changed = True
        if changed:
            track.closed_cache = None
        return changed

    def _drop_oldest(self, track: _Track) -> None:
        if track.closed:
            gone = track.closed.pop(0)
            track.closed_bytes -= gone.nbytes()
        elif track.open is not None:
            gone, track.open = track.open, None
        else:
            return
        track.closed_cache = None
        track.dropped += gone.size
        self._evicted += gone.size

    # --- reader side (any thread, no lock: views are immutable) -----------------------------------

    def _view(self, topic: str) -> _View:
        track = self._tracks.get(topic)
        return _EMPTY_VIEW if track is None else track.view

    def topics(self) -> list[str]:
        """Return the topics with a history, sorted."""
        return sorted(self._tracks)

    def kind(self, topic: str) -> Kind | None:
        """Return ``"numbers"`` or ``"payloads"`` (None for a topic without history)."""
        track = self._tracks.get(topic)
        return None if track is None else track.kind

    def msg_type(self, topic: str) -> str:
        """Return the ROS type given with the topic's payloads (``""`` if none)."""
        track = self._tracks.get(topic)
        return "" if track is None else track.msg_type

    def count(self, topic: str) -> int:
        """Return how many samples of `topic` are held."""
        return self._view(topic).count

    def span(self, topic: str | None = None) -> tuple[float, float] | None:
        """Return (oldest, newest) source time held, for one topic or all; None when empty. O(1): the
        history keeps its oldest and newest time as samples arrive and leave."""
        if topic is None:
            _topics, samples, _bytes, oldest, newest, _evicted, _late = self._summary
            return (oldest, newest) if samples else None
        view = self._view(topic)
        return (view.chunks[0].first, view.chunks[-1].last) if view.chunks else None

    def bytes_used(self) -> int:
        """Return the memory the history holds, all chunks' allocations counted."""
        return self._bytes

    def stats(self) -> HistoryStats:
        """Return counts, bytes and span in one consistent read (O(1), without waiting for the writer)."""
        topics, samples, bytes_used, oldest, newest, evicted, late = self._summary
        return HistoryStats(
            topics=topics,
            samples=samples,
            bytes_used=bytes_used,
            oldest=oldest if samples else None,
            newest=newest if samples else None,
            evicted=evicted,
            late_dropped=late,
            max_bytes=self.max_bytes,
            max_seconds=self.max_seconds,
        )

    def at(self, topic: str, t: float) -> Sample | None:
        """Return the state at time `t`: the last sample with time <= t (None before the first)."""
        _check_time(t)
        v = self._view(topic)
        i = bisect.bisect_right(v.firsts, t) - 1
        if i < 0:
            return None
        c = v.chunks[i]
        j = c.start + int(np.searchsorted(c.times[c.start : c.n], t, side="right")) - 1
        return Sample(v.before[i] + j - c.start, float(c.times[j]), c.value(j))

    def prev_time(self, topic: str, t: float) -> float | None:
        """Return the time of the newest sample strictly before `t` (for stepping back)."""
        _check_time(t)
        v = self._view(topic)
        i = bisect.bisect_left(v.firsts, t) - 1
        if i < 0:
            return None
        c = v.chunks[i]
        j = c.start + int(np.searchsorted(c.times[c.start : c.n], t, side="left")) - 1
        return float(c.times[j])

    def next_time(self, topic: str, t: float) -> float | None:
        """Return the time of the oldest sample strictly after `t` (for stepping forward)."""
        _check_time(t)
        v = self._view(topic)
        k = bisect.bisect_right(v.firsts, t)
        if k > 0:
            c = v.chunks[k - 1]
            j = c.start + int(np.searchsorted(c.times[c.start : c.n], t, side="right"))
            if j < c.n:
                return float(c.times[j])
        return v.firsts[k] if k < len(v.firsts) else None

    def _slices(self, v: _View, t0: float, t1: float) -> list[tuple[_Chunk, int, int]]:
        _check_time(t0)
        _check_time(t1)
        out: list[tuple[_Chunk, int, int]] = []
        if t1 < t0:
            return out
        i0 = max(bisect.bisect_left(v.firsts, t0) - 1, 0)
        i1 = bisect.bisect_right(v.firsts, t1)
        for c in v.chunks[i0:i1]:
            ts = c.times[c.start : c.n]
            a = c.start + int(np.searchsorted(ts, t0, side="left"))
            b = c.start + int(np.searchsorted(ts, t1, side="right"))
            if b > a:
                out.append((c, a, b))
        return out

    def range(self, topic: str, t0: float, t1: float) -> tuple[_F64, _Arr]:
        """Return copies of the times and values with ``t0 <= time <= t1`` of a numeric topic.

        Values keep their dtype (float64, int64, uint64 or bool).
        """
        track = self._tracks.get(topic)
        if track is not None and track.kind != "numbers":
            raise ValueError(f"history of {topic!r} holds payloads: use payloads()")
        parts = self._slices(self._view(topic), t0, t1)
        if not parts:
            dtype = np.float64 if track is None or track.dtype is None else track.dtype
            return np.empty(0), np.empty(0, dtype=dtype)
        times = np.concatenate([c.times[a:b] for c, a, b in parts])
        values = np.concatenate([c.data[a:b] for c, a, b in parts if isinstance(c.data, np.ndarray)])
        return times, values

    def payloads(self, topic: str, t0: float, t1: float) -> tuple[_F64, list[bytes]]:
        """Return the times and CDR payloads with ``t0 <= time <= t1`` of a payload topic."""
        track = self._tracks.get(topic)
        if track is not None and track.kind != "payloads":
            raise ValueError(f"history of {topic!r} holds numbers: use range()")
        parts = self._slices(self._view(topic), t0, t1)
        if not parts:
            return np.empty(0), []
        items: list[bytes] = []
        for c, a, b in parts:
            items.extend(c.payloads(a, b))
        return np.concatenate([c.times[a:b] for c, a, b in parts]), items

    def decimate(self, topic: str, t0: float, t1: float, pixels: int) -> tuple[_F64, _F64]:
        """Return a min/max envelope of a numeric topic over ``[t0, t1]`` for a plot `pixels` wide.

        At most ``2 * pixels + 2`` points: each pixel column that holds samples gives its minimum and
        its maximum (NaN only if all its samples are NaN), both at the time of its first sample, so the
        line drawn through them covers every sample's value; with few samples they come back as they are.
        The samples just outside the range are added so the line reaches the plot's edges. When a column
        spans many samples (``_BLOCKS_PER_PIXEL`` blocks of ``_BLOCK`` or more) closed chunks answer with
        their precomputed block minima/maxima: a block is drawn in the column of its first sample, so a
        value may land up to one block (< 1/4 pixel) from its exact column, never lost.
        """
        if pixels < 1:
            raise ValueError(f"decimate needs at least 1 pixel, not {pixels}")
        if not t0 <= t1:
            raise ValueError(f"decimate needs t0 <= t1, not {t0} > {t1}")
        track = self._tracks.get(topic)
        if track is not None and track.kind != "numbers":
            raise ValueError(f"history of {topic!r} holds payloads: only numbers can be plotted")
        v = self._view(topic)
        parts = self._slices(v, t0, t1)
        blocks = sum(b - a for _, a, b in parts) >= pixels * _BLOCK * _BLOCKS_PER_PIXEL
        pieces: list[tuple[_F64, _F64, _F64]] = []  # (times, minima, maxima) views, in time order
        for c, a, b in parts:
            if not isinstance(c.data, np.ndarray):
                continue
            if blocks and c.lo is not None and c.hi is not None and b - a >= 2 * _BLOCK:
                fa, fb = -(-a // _BLOCK), b // _BLOCK  # whole blocks [fa, fb); raw samples either side
                lo_i, hi_i = fa * _BLOCK, fb * _BLOCK
                head = c.data[a:lo_i].astype(np.float64, copy=False)
                tail = c.data[hi_i:b].astype(np.float64, copy=False)
                pieces.append((c.times[a:lo_i], head, head))
                pieces.append((c.times[lo_i:hi_i:_BLOCK], c.lo[fa:fb], c.hi[fa:fb]))
                pieces.append((c.times[hi_i:b], tail, tail))
            else:
                raw = c.data[a:b].astype(np.float64, copy=False)
                pieces.append((c.times[a:b], raw, raw))
        if not blocks and sum(len(p[0]) for p in pieces) <= 2 * pixels:
            times = np.concatenate([p[0] for p in pieces]) if pieces else np.empty(0)
            vals = np.concatenate([p[1] for p in pieces]) if pieces else np.empty(0)
        else:
            if blocks and len(pieces) > 1:  # block summaries are small: one pass beats many small ones
                pieces = [
                    (
                        np.concatenate([p[0] for p in pieces]),
                        np.concatenate([p[1] for p in pieces]),
                        np.concatenate([p[2] for p in pieces]),
                    )
                ]
            times, vals = _envelope(pieces, np.linspace(t0, t1, pixels + 1)[:-1])
        before = self.at(topic, float(np.nextafter(t0, -np.inf)))
        after_t = self.next_time(topic, t1)
        after = self.at(topic, after_t) if after_t is not None else None
        if before is None and after is None:
            return times, vals
        edge_t = [s.time for s in (before, after) if s is not None]
        edge_v = [float(s.value) for s in (before, after) if s is not None and not isinstance(s.value, bytes)]
        head_n = 1 if before is not None else 0
        return (
            np.concatenate([edge_t[:head_n], times, edge_t[head_n:]]),
            np.concatenate([edge_v[:head_n], vals, edge_v[head_n:]]),
        )
