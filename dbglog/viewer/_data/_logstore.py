"""The Log console's store: log lines decoded into columns, bounded, with fast filters cached per filter.

Pure: numpy, google-re2 and the ground floor's CDR readers and pattern proposals; no ROS, no Dear PyGui.
Any thread may `push` raw CDR batches (the engine's ROS thread does). A store made with ``worker=True``
decodes them, stores them and answers its readers' filters on a thread of its own, so the UI thread only
takes the newest answers (`step`) and reads the rows it shows; without a worker the owner does that work
in `step` or `sync`. Nothing from a line is ever evaluated; patterns are RE2 (linear time). Layout, threads
and measured figures: ``docs/logs.md``.
"""

from __future__ import annotations

import collections
import logging
import struct
import threading
import time
import weakref
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Final

import numpy as np
import numpy.typing as npt
import re2

from dbglog._regex._compile import MAX_LINE, RegexError, compile_regex, re2_options
from dbglog._regex._propose import NumberSpan, Proposal, find_numbers, match_joined
from dbglog._ros._cdr import read_log, read_string
from dbglog._ros._loglevels import (
    DEBUG,
    ERROR,
    FATAL,
    INFO,
    LEVEL_NAMES,
    WARN,
    level_name,
    level_of,
    node_matches,
)

__all__ = [
    "DEBUG",
    "DEFAULT_CAPACITY",
    "ERROR",
    "FATAL",
    "INFO",
    "LEVEL_NAMES",
    "LOG_TYPES",
    "WARN",
    "FilterError",
    "LogFilter",
    "LogLine",
    "LogReader",
    "LogStore",
    "Matches",
    "Shown",
    "level_name",
    "level_of",
]

LOG_TYPE: Final = "rcl_interfaces/msg/Log"
STRING_TYPE: Final = "std_msgs/msg/String"
LOG_TYPES: Final = (LOG_TYPE, STRING_TYPE)
"""The message types a store reads lines from (a String line has no level, node or source location)."""
DEFAULT_CAPACITY: Final = 100_000
"""Lines kept by default; the oldest go first."""
MAX_NODES: Final = 65_000
"""Distinct logger names kept apart; later ones share the name `OTHER_NODE` (node ids are 16 bits)."""
OTHER_NODE: Final = "\u2026"
_RUN_AFTER: Final = 4
"""Adjacent matching lines after which one DFA call takes the rest of the run of matching lines."""
_MAX_SLICE: Final = 1 << 20
_MAX_CACHED: Final = 12
"""Filter results (masks) kept: switching back to a recent filter costs nothing."""
_SLACK: Final = 8
"""Columns hold ``capacity + capacity / _SLACK`` rows: the oldest rows are dropped in one move per slack."""
_LEVEL_AT: Final = 12
"""Payload offset of a Log's level (after the header and the stamp)."""
_SANITIZE: Final = bytes.maketrans(b"\x00\x01\n", b"\x1a\x1a\x1f")
"""Stored text: NUL and \\x01 (the preview's framing) become SUB, a line break becomes \\x1f (shown as ↵)."""
_U32: Final = (struct.Struct("<I"), struct.Struct(">I"))
_NAME_AT: Final = 16
"""Payload offset of a Log's name length (after the header, the stamp and the level)."""
_MATCH_OPTIONS = re2_options(32 << 20)
_MATCH_OPTIONS.never_nl = True  # a pattern never matches a line break, so never spans two stored lines
_UNANCHORED = re2._Anchor.UNANCHORED
_ANCHOR_START = re2._Anchor.ANCHOR_START
_LETTERS: Final = frozenset(range(ord("a"), ord("z") + 1))
WORKER_LINES: Final = 20_000
"""Lines the worker decodes before it answers its readers again (a long history fills in over a few turns)."""
WORKER_BUDGET_S: Final = 0.01
"""Time the worker gives each reader's older lines per turn (new lines are always answered whole)."""
WORKER_IDLE_S: Final = 0.05
"""How often the worker looks for pushed lines when no frame asks (`step` starts a turn at once)."""
SYNC_TIMEOUT_S: Final = 60.0
"""`sync` waits at most this long for the worker to take in what was pushed before it."""

_log = logging.getLogger(__name__)


class FilterError(ValueError):
    """An include or exclude pattern that RE2 refuses; the message says which one and why."""


@dataclass(frozen=True, slots=True)
class LogFilter:
    """Which lines the console shows: every condition must hold."""

    min_level: int = 0
    """Lines at this level or above (0: every line, String lines included)."""
    hidden: frozenset[str] = frozenset()
    """Logger names whose lines are hidden (the per-node toggles)."""
    include: str = ""
    """RE2: a line's message must contain a match (empty: any)."""
    exclude: str = ""
    """RE2: a line's message must not contain a match (empty: none excluded)."""
    text: str = ""
    """Plain text the message must contain, ignoring ASCII case (empty: any)."""


@dataclass(frozen=True, slots=True)
class LogLine:
    """One stored line, decoded for display."""

    id: int
    """Its position since the store began (ids of evicted lines are never reused)."""
    time: float
    """Source time, seconds since the epoch."""
    level: int
    node: str
    message: str
    """The message text (at most `MAX_LINE` bytes of it are kept)."""
    file: str = ""
    function: str = ""
    line: int = 0
    cut: int = 0
    """Bytes of the message that were not kept (0 for a line kept whole)."""

    @property
    def site(self) -> str:
        """``file:function:line`` where the line was logged (``""`` when unknown)."""
        if not (self.file or self.function or self.line):
            return ""
        return f"{self.file}:{self.function}:{self.line}"


@dataclass(frozen=True, slots=True)
class Matches:
    """The stored lines a proposed pattern matches (`LogStore.preview`): ids, times and the values taken."""

    ids: npt.NDArray[np.int64]
    times: npt.NDArray[np.float64]
    values: npt.NDArray[np.float64]

    @property
    def count(self) -> int:
        """How many lines match."""
        return len(self.ids)


@dataclass(eq=False, slots=True)
class _Decoded:
    """A pushed batch, decoded by the owner's `sync`, before its lines are added."""

    msg_type: str
    times: npt.NDArray[np.float64]
    levels: npt.NDArray[np.uint8]
    nodes: npt.NDArray[np.uint16]
    sites: npt.NDArray[np.uint32]
    texts: list[bytes]
    cut: npt.NDArray[np.int64]
    undecodable: int


@dataclass(eq=False, slots=True)
class _Mask:
    """One pattern's answer for the rows ``[a, b)`` (grown at both ends as needed)."""

    rows: npt.NDArray[np.bool_]
    a: int
    b: int


class _Ids:
    """Ascending line ids, grown at both ends (older ids before, newer ids after)."""

    __slots__ = ("buf", "start", "stop")

    def __init__(self) -> None:
        self.buf = np.zeros(256, dtype=np.int64)
        self.start = self.stop = 128

    def values(self) -> npt.NDArray[np.int64]:
        return self.buf[self.start : self.stop]

    def _room(self, before: int, after: int) -> None:
        if self.start >= before and len(self.buf) - self.stop >= after:
            return
        n = self.stop - self.start
        size = max(2 * len(self.buf), n + 2 * (before + after) + 256)
        buf = np.zeros(size, dtype=np.int64)
        start = before + (size - n - before - after) // 2
        buf[start : start + n] = self.values()
        self.buf, self.start, self.stop = buf, start, start + n

    def append(self, new: npt.NDArray[np.int64]) -> None:
        self._room(0, len(new))
        self.buf[self.stop : self.stop + len(new)] = new
        self.stop += len(new)

    def prepend(self, new: npt.NDArray[np.int64]) -> None:
        self._room(len(new), 0)
        self.buf[self.start - len(new) : self.start] = new
        self.start -= len(new)

    def drop_below(self, first_id: int) -> None:
        self.start += int(np.searchsorted(self.values(), first_id, side="left"))

    def cut_at(self, first_id: int) -> None:
        self.stop = self.start + int(np.searchsorted(self.values(), first_id, side="left"))
        self.buf = self.buf.copy()  # the ids given out (views) stay as they were: appends go to a new buffer


@dataclass(eq=False, slots=True)
class _Selection:
    """The ids a filter shows among rows ``[a, b)``: grown upwards as lines arrive, downwards on demand."""

    key: tuple[object, ...]
    a: int
    b: int
    ids: _Ids = field(default_factory=_Ids)


@dataclass(eq=False, slots=True)
class _Slot:
    """Where a filter's cached answer lives: the store's own (`select`) or a reader's."""

    sel: _Selection | None = None


@dataclass(frozen=True, slots=True)
class Shown:
    """A reader's answer, as the store stood when it was given (immutable: a frame may keep it)."""

    filt: LogFilter
    """The filter asked (a pattern RE2 refused was left out of the answer: `error`)."""
    ids: npt.NDArray[np.int64]
    """The ids of the lines it shows, oldest first (read-only)."""
    complete: bool
    """Whether every held line was answered (False while older lines are still being filtered)."""
    error: str
    """The patterns RE2 refused, each named with its reason (``""`` when none)."""
    generation: int
    """The store's `generation` the ids refer to (`LogStore.window` reads rows only for the same one)."""
    held: int
    """Lines the store held then."""


@dataclass(frozen=True, slots=True)
class _Published:
    """What a turn of the worker (or of `LogStore.step`) answered: every reader's answer and the count."""

    serial: int
    held: int
    answers: dict[int, Shown]
    version: int
    """The store's `version` they answer (a later change, even without a push, asks for a turn)."""


class LogReader:
    """One console's view of a store: it asks a filter (`ask`) and reads the answer given (`shown`).

    Made by `LogStore.reader`; the store holds it weakly, so a reader dropped stops costing anything.
    """

    __slots__ = ("__weakref__", "_slot", "_store", "asked", "key")

    def __init__(self, store: LogStore, key: int) -> None:
        self._store = store
        self.key = key
        self.asked = LogFilter()
        """The filter whose answer is wanted."""
        self._slot = _Slot()

    def ask(self, filt: LogFilter) -> None:
        """Ask for the lines `filt` shows (a store with a worker answers on its thread; never blocks)."""
        if filt != self.asked:
            self.asked = filt
            self._store._wake()

    def shown(self) -> Shown | None:
        """The newest answer taken by `LogStore.step` (or `sync`); None before the first."""
        return self._store._current.answers.get(self.key)


class _Worker:
    """The thread that decodes, stores and answers for one store (holding it only weakly between turns)."""

    __slots__ = ("stop", "thread", "wake")

    def __init__(self, store: LogStore) -> None:
        self.wake = threading.Event()
        self.stop = threading.Event()
        self.thread = threading.Thread(
            target=_work, args=(weakref.ref(store), self.wake, self.stop), name="dbglog-logs", daemon=True
        )


def _work(ref: weakref.ref[LogStore], wake: threading.Event, stop: threading.Event) -> None:
    """The worker's loop: a turn when a frame took the answers (`step`), a reader asked, `sync` waits, or
    every `WORKER_IDLE_S` while lines wait; it ends with its store.

    A push does not wake it: in the viewer a turn follows the console's `step`, so it runs while the UI
    thread renders (Dear PyGui's render releases the GIL) instead of taking the GIL from the frame's Python.
    """
    while True:
        wake.wait(WORKER_IDLE_S)
        wake.clear()
        store = ref()
        if stop.is_set() or store is None:
            return
        try:
            if store._has_work() and store._serve(WORKER_LINES, WORKER_BUDGET_S):
                wake.set()  # more to do (a long history, a new filter's older lines): go on
        except Exception:  # a bug here must not end the thread: the next lines still come
            _log.exception("the log store's worker failed a turn")
        del store  # not held between turns: a store nobody uses goes, and its worker with it


def _stop_worker(wake: threading.Event, stop: threading.Event) -> None:
    stop.set()
    wake.set()


class LogStore:
    """Log lines in columns: time, level, node (interned), message, source location; bounded.

    Example:
        >>> store = LogStore(capacity=1000)
        >>> store.append([1.0, 2.0], [20, 40], ["planner", "driver"], ["speed 1.5", "stalled"])
        >>> store.select(LogFilter(min_level=40)).tolist()
        [1]

    Args:
        capacity: the most lines kept (the oldest are dropped first); settable later.
    """

    first_slice = 4096
    """`select_within` answers this many of the newest lines first, then slices sized to its time budget."""

    def __init__(self, capacity: int = DEFAULT_CAPACITY, *, worker: bool = False) -> None:
        if capacity < 1:
            raise ValueError(f"a log store keeps at least one line, not {capacity}")
        self._capacity = int(capacity)
        self._alloc = 0
        self._lo = 0
        """First live row."""
        self._n = 0
        """End of the rows (exclusive)."""
        self._base = 0
        """Id of row 0."""
        self._times = np.zeros(0, dtype=np.float64)
        self._levels = np.zeros(0, dtype=np.uint8)
        self._nodes = np.zeros(0, dtype=np.uint16)
        self._sites = np.zeros(0, dtype=np.uint32)
        self._starts = np.zeros(1, dtype=np.int64)
        """Offset in `_text` of each row's message; ``_starts[_n]`` is the end. Each message ends with \\n."""
        self._text = bytearray()
        self._node_names: list[str] = []
        self._node_ids: dict[bytes, int] = {}
        self._site_list: list[tuple[str, str, int]] = [("", "", 0)]
        self._site_ids: dict[bytes, int] = {}
        self._cut: dict[int, int] = {}
        """Line id -> bytes of its message not kept (only for lines longer than `MAX_LINE`)."""
        self._masks: collections.OrderedDict[tuple[str, str], _Mask] = collections.OrderedDict()
        self._own = _Slot()
        """The cached answer of `select` and `select_within` (readers have their own)."""
        self._marks = _Selection(("marks",), 0, 0)
        """The ids of the held WARN, ERROR and FATAL lines (kept as lines are added)."""
        self._pending: collections.deque[tuple[int, str, npt.NDArray[np.float64], list[bytes]]] = (
            collections.deque()
        )
        self._pending_lines = 0
        self._pushed = 0
        """Batches pushed so far (each waiting batch carries its number)."""
        self._push_lock = threading.Lock()
        """Guards the waiting batches and the readers' list (held for a few statements, by any thread)."""
        self._write = threading.RLock()
        """Held to change the store or its cached answers (the worker's turn, `select`, `preview`, `append`):
        whoever holds it sees rows that do not change under it."""
        self._read = threading.RLock()
        """Held by a writer only while it changes the rows, and by the readers of rows (`line`, `rows`, ...):
        short both ways. Taken after `_write`, never before it."""
        self._readers: list[weakref.ref[LogReader]] = []
        self._reader_keys = 0
        self._ready = self._current = _Published(0, 0, {}, 0)
        """The newest answers given (`_ready`), and those the owner took (`_current`: `step`, `sync`)."""
        self._done = threading.Condition(threading.Lock())
        self._answered = 0
        """The number of the newest batch the worker took in and answered for (what `sync` waits for)."""
        self._worker: _Worker | None = None
        self.version = 0
        """Changes whenever lines are added or dropped (a reader redraws when it changes)."""
        self._added = 0
        self._evicted = 0
        self.dropped = 0
        """Lines dropped before decoding, over `capacity` waiting (counted in `added` and `evicted` too)."""
        self.undecodable = 0
        """Payloads that were not a readable Log or String (skipped)."""
        self.msg_type = ""
        """The type of the lines pushed so far (``rcl_interfaces/msg/Log`` or ``std_msgs/msg/String``)."""
        self.generation = 0
        """Changes when line ids start meaning other lines (a late batch merged in, `clear`): an answer
        given before refers to the old ones."""
        self._grow(min(self._capacity, 4096))
        if worker:
            self.start()

    # --- the worker -----------------------------------------------------------------------------------

    def start(self) -> None:
        """Start the store's worker thread: from now on it decodes what is pushed and answers the readers."""
        if self._worker is not None:
            return
        worker = self._worker = _Worker(self)
        weakref.finalize(self, _stop_worker, worker.wake, worker.stop)
        worker.thread.start()
        worker.wake.set()  # lines pushed before

    def close(self) -> None:
        """Stop the worker thread and wait for it to end; the store stays readable (the owner may `sync`)."""
        worker, self._worker = self._worker, None
        if worker is None:
            return
        _stop_worker(worker.wake, worker.stop)
        if worker.thread is not threading.current_thread():
            worker.thread.join()
        with self._done:
            self._done.notify_all()  # a `sync` waiting for it syncs by itself

    @property
    def threaded(self) -> bool:
        """Whether a worker thread decodes and answers (`start`); else the owner does, in `step`/`sync`."""
        return self._worker is not None

    def _wake(self) -> None:
        worker = self._worker
        if worker is not None:
            worker.wake.set()

    def _on_worker(self) -> bool:
        worker = self._worker
        return worker is not None and worker.thread is threading.current_thread()

    # --- size ---------------------------------------------------------------------------------------

    @property
    def capacity(self) -> int:
        """The most lines kept; lowering it drops the oldest lines now."""
        return self._capacity

    @capacity.setter
    def capacity(self, value: int) -> None:
        if value < 1:
            raise ValueError(f"a log store keeps at least one line, not {value}")
        if int(value) == self._capacity:
            return
        with self._write, self._read:
            self._capacity = int(value)
            self._evict()

    def __len__(self) -> int:
        """Lines held; with a worker, as of the answers `step` or `sync` took (they go together)."""
        if self._worker is not None:
            return self._current.held
        return self._n - self._lo

    @property
    def added(self) -> int:
        """Lines stored so far (dropped ones included)."""
        return self._added + self.dropped

    @property
    def evicted(self) -> int:
        """Lines dropped because the store was full (dropped ones included)."""
        return self._evicted + self.dropped

    @property
    def first_id(self) -> int:
        """The id of the oldest line held (== `end_id` when empty)."""
        return self._base + self._lo

    @property
    def end_id(self) -> int:
        """One past the id of the newest line."""
        return self._base + self._n

    @property
    def pending(self) -> int:
        """Lines pushed and not yet decoded (the worker, or `sync`, takes them)."""
        return self._pending_lines

    @property
    def published(self) -> int:
        """Changes whenever new answers are given (a console redraws when it changes)."""
        return self._ready.serial

    def bytes_used(self) -> int:
        """Bytes the store holds: its columns, its text, cached filter results and interned names."""
        with self._write, self._read:
            columns = sum(
                a.nbytes for a in (self._times, self._levels, self._nodes, self._sites, self._starts)
            )
            masks = sum(m.rows.nbytes for m in self._masks.values())
            selections = sum(s.ids.buf.nbytes for s in self._selections())
            names = sum(len(n) + 60 for n in self._node_names) + sum(
                len(f) + len(g) + 120 for f, g, _ in self._site_list
            )
            text = self._text.__sizeof__()
            return columns + masks + selections + names + text + 90 * len(self._cut)

    # --- writing ------------------------------------------------------------------------------------

    def push(self, msg_type: str, times: npt.ArrayLike, payloads: list[bytes]) -> None:
        """Queue serialized Log or String messages with their source times (any thread; never blocks long).

        The worker, or the owner's next `sync`, decodes them (decoding on the engine's ROS thread instead was
        measured to make it lose lines in DDS under load: ``docs/logs.md``). While more than `capacity` lines
        wait, the oldest waiting batches are dropped (they would be evicted anyway).
        """
        if not payloads:
            return
        with self._push_lock:
            self._pushed += 1
            self._pending.append((self._pushed, msg_type, np.asarray(times, dtype=np.float64), payloads))
            self._pending_lines += len(payloads)
            while self._pending_lines - len(self._pending[0][3]) >= self._capacity:
                dropped = self._pending.popleft()
                self._pending_lines -= len(dropped[3])
                self.dropped += len(dropped[3])

    def sync(self, max_lines: int | None = None) -> int:
        """Take in the lines pushed so far; return how many lines were added.

        Without a worker, decode the waiting batches here. With one, wait (at most `SYNC_TIMEOUT_S`) until it
        took in and answered every batch pushed before the call, then take its answers as `step` does.

        Args:
            max_lines: without a worker, stop after about this many lines (the rest wait for the next call).

        Raises:
            TimeoutError: the worker did not take the lines in time.
        """
        if self._worker is not None and not self._on_worker():
            added = self._added
            with self._push_lock:
                target = self._pushed
            self._wake()
            with self._done:
                done = self._done.wait_for(
                    lambda: self._answered >= target or self._worker is None, SYNC_TIMEOUT_S
                )
            if not done:
                raise TimeoutError(f"the log store's worker did not take the lines in {SYNC_TIMEOUT_S:g} s")
            if self._worker is not None:
                self._current = self._ready
                return self._added - added
        return self._take_in(max_lines)

    def step(self, max_lines: int | None = None, budget: float | None = 0.03) -> None:
        """Bring the readers' answers up to date, for a frame (the owner; never waits on a worker).

        With a worker, take the newest answers it gave (and the count of lines held with them). Without
        one, decode up to `max_lines` waiting lines and answer every reader here, the older lines of a new
        filter within about `budget` seconds (the newest first; ask again for the rest).
        """
        if self._worker is not None:
            self._current = self._ready
            self._wake()  # the next turn: while this frame renders
            return
        self._serve(max_lines, budget)
        self._current = self._ready

    def reader(self) -> LogReader:
        """A new reader of this store (a console): it asks a filter and is answered at each turn."""
        with self._push_lock:
            self._reader_keys += 1
            made = LogReader(self, self._reader_keys)
            self._readers.append(weakref.ref(made))
        self._wake()
        return made

    def _has_work(self) -> bool:
        """Whether a turn would change anything: lines wait, the store changed since the answers (lines
        added, evicted, cleared), or a reader's answer is missing, for another filter, or incomplete."""
        if self._pending_lines or self.version != self._ready.version:
            return True
        answers = self._ready.answers
        for reader in self._live_readers():
            shown = answers.get(reader.key)
            if shown is None or shown.filt != reader.asked or not shown.complete:
                return True
        return False

    def _live_readers(self) -> list[LogReader]:
        with self._push_lock:
            live = [r for r in (ref() for ref in self._readers) if r is not None]
            if len(live) != len(self._readers):
                self._readers = [weakref.ref(r) for r in live]
        return live

    def _selections(self) -> list[_Selection]:
        """Every cached answer: the store's own, the readers', the timeline marks."""
        slots = [self._own, *(r._slot for r in self._live_readers())]
        return [s.sel for s in slots if s.sel is not None] + [self._marks]

    def _take_in(self, max_lines: int | None) -> int:
        """Decode waiting batches into the store (up to about `max_lines` lines); return the lines added."""
        added = 0
        with self._write:
            while max_lines is None or added < max_lines:
                with self._push_lock:
                    if not self._pending:
                        break
                    _serial, msg_type, times, payloads = self._pending.popleft()
                    self._pending_lines -= len(payloads)
                batch = self._decode(msg_type, times, payloads)
                with self._read:
                    added += self._append_decoded(batch)
        return added

    def _serve(self, max_lines: int | None, budget: float | None) -> bool:
        """One turn: take in waiting lines, answer every reader, publish the answers; return whether more
        is left to do (lines waiting, or a reader's answer incomplete)."""
        self._take_in(max_lines)
        with self._write:
            answers = {}
            more = False
            for reader in self._live_readers():
                shown = self._answer(reader, budget)
                answers[reader.key] = shown
                more = more or not shown.complete or shown.filt != reader.asked
            with self._push_lock:
                answered = self._pending[0][0] - 1 if self._pending else self._pushed
                more = more or bool(self._pending)
            self._ready = _Published(self._ready.serial + 1, self._n - self._lo, answers, self.version)
        with self._done:
            self._answered = max(self._answered, answered)
            self._done.notify_all()
        return more

    def _answer(self, reader: LogReader, budget: float | None) -> Shown:
        """A reader's answer (within `budget` for older lines); a pattern RE2 refuses is named, left out."""
        asked = filt = reader.asked
        errors: list[str] = []
        while True:  # each refusal leaves one pattern out: at most two
            try:
                ids, complete = self._select(reader._slot, filt, None, budget)
                break
            except FilterError as exc:
                errors.append(str(exc))
                if str(exc).startswith("include"):
                    filt = replace(filt, include="")
                else:
                    filt = replace(filt, exclude="")
        return Shown(asked, ids, complete, "; ".join(errors), self.generation, self._n - self._lo)

    def _append_decoded(self, batch: _Decoded) -> int:
        self.undecodable += batch.undecodable
        if batch.msg_type not in LOG_TYPES:
            return 0
        if self.msg_type and batch.msg_type != self.msg_type:
            self.clear()  # the topic changed its type: its lines start again
        self.msg_type = batch.msg_type
        self._add(batch.times, batch.levels, batch.nodes, batch.sites, batch.texts, batch.cut)
        return len(batch.texts)

    def _decode(self, msg_type: str, times: npt.NDArray[np.float64], payloads: list[bytes]) -> _Decoded:
        """Read a batch of payloads into columns, interning new logger names and source locations."""
        n = len(payloads)
        undecodable = 0
        if msg_type not in LOG_TYPES:
            empty = np.zeros(0, dtype=np.int64)
            return _Decoded(
                msg_type,
                times[:0],
                empty.astype(np.uint8),
                empty.astype(np.uint16),
                empty.astype(np.uint32),
                [],
                empty,
                n,
            )
        level_list: list[int] = []
        node_list: list[int] = []
        site_list: list[int] = []
        texts: list[bytes] = []
        keep = np.ones(n, dtype=bool)
        cuts: list[tuple[int, int]] = []
        append = texts.append
        if msg_type == LOG_TYPE:
            # One pass with list appends, little-endian CDR read inline (~0.9 µs a line; numpy item stores and
            # a read_log call a line took ~1.5); anything else goes through read_log.
            node_ids, site_ids = self._node_ids, self._site_ids
            node_of, site_of = node_ids.get, site_ids.get
            add_level, add_node, add_site = level_list.append, node_list.append, site_list.append
            u32 = _U32[0].unpack_from
            for i, raw in enumerate(payloads):
                size = len(raw)
                if size >= _NAME_AT + 4 and raw[0] == 0 and raw[1] == 1:
                    (name_len,) = u32(raw, _NAME_AT)
                    msg_at = 4 + ((_NAME_AT + 4 + name_len - 1) & ~3)
                    (msg_len,) = u32(raw, msg_at) if msg_at + 4 <= size else (0,)
                    msg_end = msg_at + 4 + msg_len
                    if name_len < 1 or msg_len < 1 or msg_end > size:
                        keep[i] = False
                        undecodable += 1
                        continue
                    level = raw[_LEVEL_AT]
                    name = raw[_NAME_AT + 4 : _NAME_AT + 3 + name_len]
                    msg = raw[msg_at + 4 : msg_end - 1]
                else:  # big-endian CDR (or too short to tell)
                    read = read_log(raw)
                    if read is None:
                        keep[i] = False
                        undecodable += 1
                        continue
                    level, name, msg = read
                    msg_at = 4 + ((_NAME_AT + 4 + len(name)) & ~3)
                    msg_end = msg_at + 5 + len(msg)
                node = node_of(name)
                if node is None:
                    node = self._intern_node(name)
                tail_at = 4 + ((msg_end - 1) & ~3)
                tail = raw[tail_at:]
                site = site_of(tail)
                if site is None:
                    site = self._intern_site(raw, tail_at, tail)
                add_level(level)
                add_node(node)
                add_site(site)
                if len(msg) > MAX_LINE:
                    cuts.append((len(texts), len(msg) - MAX_LINE))
                    msg = _cut_utf8(msg)
                append(msg.translate(_SANITIZE))
        else:
            for i, raw in enumerate(payloads):
                data = read_string(raw)
                if data is None:
                    keep[i] = False
                    undecodable += 1
                    continue
                if len(data) > MAX_LINE:
                    cuts.append((len(texts), len(data) - MAX_LINE))
                    data = _cut_utf8(data)
                append(data.translate(_SANITIZE))
        if not keep.all():
            times = times[keep]
        kept = len(texts)
        levels = np.array(level_list, dtype=np.uint8) if level_list else np.zeros(kept, dtype=np.uint8)
        nodes = np.array(node_list, dtype=np.uint16) if node_list else np.zeros(kept, dtype=np.uint16)
        sites = np.array(site_list, dtype=np.uint32) if site_list else np.zeros(kept, dtype=np.uint32)
        cut = np.zeros(len(texts), dtype=np.int64)
        for index, extra in cuts:
            cut[index] = extra
        return _Decoded(msg_type, times, levels, nodes, sites, texts, cut, undecodable)

    def append(
        self,
        times: npt.ArrayLike,
        levels: npt.ArrayLike,
        nodes: Sequence[str],
        messages: Sequence[str],
        *,
        sites: Sequence[tuple[str, str, int]] | None = None,
    ) -> None:
        """Add decoded lines (owner thread): times, levels, logger names, messages, and optionally
        each line's (file, function, line)."""
        n = len(messages)
        time_array = np.asarray(times, dtype=np.float64)
        level_array = np.asarray(levels, dtype=np.int64)
        if not (len(time_array) == len(level_array) == len(nodes) == n) or (
            sites is not None and len(sites) != n
        ):
            raise ValueError("append needs one time, level, node (and site) per message")
        with self._write:
            self._append_lines(n, time_array, level_array, nodes, messages, sites)

    def _append_lines(
        self,
        n: int,
        time_array: npt.NDArray[np.float64],
        level_array: npt.NDArray[np.int64],
        nodes: Sequence[str],
        messages: Sequence[str],
        sites: Sequence[tuple[str, str, int]] | None,
    ) -> None:
        node_ids = np.zeros(n, dtype=np.uint16)
        for i, name in enumerate(nodes):
            key = name.encode("utf-8", "replace")
            found = self._node_ids.get(key)
            node_ids[i] = self._intern_node(key) if found is None else found
        site_ids = np.zeros(n, dtype=np.uint32)
        if sites is not None:
            for i, (file, function, line) in enumerate(sites):
                key = f"{file}\x00{function}\x00{line}".encode("utf-8", "replace")
                found = self._site_ids.get(key)
                if found is None:
                    found = len(self._site_list)
                    self._site_list.append((file, function, int(line)))
                    self._site_ids[key] = found
                site_ids[i] = found
        texts: list[bytes] = []
        cut = np.zeros(n, dtype=np.int64)
        for i, message in enumerate(messages):
            data = message.encode("utf-8", "replace")
            if len(data) > MAX_LINE:
                cut[i] = len(data) - MAX_LINE
                data = _cut_utf8(data)
            texts.append(data.translate(_SANITIZE))
        with self._read:
            self._add(
                time_array,
                np.clip(level_array, 0, 255).astype(np.uint8),
                node_ids,
                site_ids,
                texts,
                cut,
            )

    def _intern_node(self, name: bytes) -> int:
        if len(self._node_names) >= MAX_NODES:
            text = OTHER_NODE
            found = self._node_ids.get(text.encode())
            if found is not None:
                self._node_ids[name] = found
                return found
            name = text.encode()
        else:
            text = name.decode("utf-8", "replace")
        node = len(self._node_names)
        self._node_names.append(text)
        self._node_ids[name] = node
        return node

    def _intern_site(self, raw: bytes, at: int, tail: bytes) -> int:
        site = _read_site(raw, at)
        found = len(self._site_list)
        self._site_list.append(site)
        self._site_ids[tail] = found
        return found

    def _add(
        self,
        times: npt.NDArray[np.float64],
        levels: npt.NDArray[np.uint8],
        nodes: npt.NDArray[np.uint16],
        sites: npt.NDArray[np.uint32],
        texts: list[bytes],
        cut: npt.NDArray[np.int64],
    ) -> None:
        """Append a batch in time order (a batch older than the newest line is merged into the tail).

        The caller holds `_write` and `_read`."""
        k = len(texts)
        if k == 0:
            return
        self._added += k
        if k > 1 and np.any(times[1:] < times[:-1]):
            order = np.argsort(times, kind="stable")
            times, levels, nodes, sites, cut = (
                times[order],
                levels[order],
                nodes[order],
                sites[order],
                cut[order],
            )
            texts = [texts[i] for i in order.tolist()]
        if self._n > self._lo and times[0] < self._times[self._n - 1]:
            times, levels, nodes, sites, texts, cut = self._take_tail(times, levels, nodes, sites, texts, cut)
        if len(texts) > self._capacity:  # only the newest fit; everything held is older still
            drop = len(texts) - self._capacity
            self._evicted += drop
            times, levels, nodes, sites = times[drop:], levels[drop:], nodes[drop:], sites[drop:]
            texts, cut = texts[drop:], cut[drop:]
            self._drop_front(self._n - self._lo)
        k = len(texts)
        self._reserve(k)
        n = self._n
        self._times[n : n + k] = times
        self._levels[n : n + k] = levels
        self._nodes[n : n + k] = nodes
        self._sites[n : n + k] = sites
        lengths = np.fromiter(map(len, texts), dtype=np.int64, count=k) + 1
        self._starts[n + 1 : n + k + 1] = self._starts[n] + np.cumsum(lengths)
        self._text += b"\n".join(texts)
        self._text += b"\n"
        for i in np.flatnonzero(cut).tolist():
            self._cut[self._base + n + i] = int(cut[i])
        self._n = n + k
        self._marks.ids.append(np.flatnonzero(levels >= WARN).astype(np.int64) + (self._base + n))
        self._marks.b = self._n
        self._evict()
        self.version += 1

    def _take_tail(
        self,
        times: npt.NDArray[np.float64],
        levels: npt.NDArray[np.uint8],
        nodes: npt.NDArray[np.uint16],
        sites: npt.NDArray[np.uint32],
        texts: list[bytes],
        cut: npt.NDArray[np.int64],
    ) -> tuple[
        npt.NDArray[np.float64],
        npt.NDArray[np.uint8],
        npt.NDArray[np.uint16],
        npt.NDArray[np.uint32],
        list[bytes],
        npt.NDArray[np.int64],
    ]:
        """Remove the held lines newer than the batch's oldest and return them merged with the batch."""
        lo, n = self._lo, self._n
        k0 = lo + int(np.searchsorted(self._times[lo:n], times[0], side="right"))
        starts = self._starts
        text = self._text
        tail_texts = [bytes(text[starts[r] : starts[r + 1] - 1]) for r in range(k0, n)]
        tail_cut = np.array([self._cut.pop(self._base + r, 0) for r in range(k0, n)], dtype=np.int64)
        all_times = np.concatenate((self._times[k0:n], times))
        order = np.argsort(all_times, kind="stable")
        merged = (
            all_times[order],
            np.concatenate((self._levels[k0:n], levels))[order],
            np.concatenate((self._nodes[k0:n], nodes))[order],
            np.concatenate((self._sites[k0:n], sites))[order],
        )
        joined = tail_texts + texts
        merged_texts = [joined[i] for i in order.tolist()]
        merged_cut = np.concatenate((tail_cut, cut))[order]
        # Rows from k0 on are rewritten: forget what was computed about them.
        del text[int(starts[k0]) :]
        self._n = k0
        self.generation += 1
        selections = self._selections()
        ranges: list[_Mask | _Selection] = [*self._masks.values(), *selections]
        for ranged in ranges:
            if ranged.b > k0:
                ranged.b = max(k0, ranged.a) if ranged.a < k0 else k0
                ranged.a = min(ranged.a, ranged.b)
        for sel in selections:
            sel.ids.cut_at(self._base + k0)
            if sel.a >= k0:  # nothing below the rewritten rows was computed: start again there
                sel.ids.drop_below(self._base + sel.a)
        return (*merged, merged_texts, merged_cut)

    def _reserve(self, k: int) -> None:
        """Make room for `k` more rows after `_n` (dropping evicted rows from the front, or growing)."""
        if self._n + k <= self._alloc:
            return
        self._compact()
        if self._n + k > self._alloc:
            need = self._n + k
            self._grow(max(need, min(2 * self._alloc, self._capacity + self._capacity // _SLACK)))

    def _compact(self) -> None:
        """Move the live rows to row 0 (ids do not change)."""
        lo, n = self._lo, self._n
        if lo == 0:
            return
        live = n - lo
        for column in (self._times, self._levels, self._nodes, self._sites):
            column[:live] = column[lo:n]
        shift = int(self._starts[lo])
        self._starts[: live + 1] = self._starts[lo : n + 1] - shift
        del self._text[:shift]
        for mask in self._masks.values():
            mask.rows[:live] = mask.rows[lo:n]
        ranges: list[_Mask | _Selection] = [*self._masks.values(), *self._selections()]
        for ranged in ranges:
            ranged.a, ranged.b = max(0, ranged.a - lo), max(0, ranged.b - lo)
        self._base += lo
        self._lo, self._n = 0, live

    def _grow(self, alloc: int) -> None:
        alloc = max(alloc, self._n + 1)
        live = self._n
        for name in ("_times", "_levels", "_nodes", "_sites"):
            old = getattr(self, name)
            new = np.zeros(alloc, dtype=old.dtype)
            new[:live] = old[:live]
            setattr(self, name, new)
        starts = np.zeros(alloc + 1, dtype=np.int64)
        starts[: live + 1] = self._starts[: live + 1]
        self._starts = starts
        for mask in self._masks.values():
            rows = np.zeros(alloc, dtype=bool)
            rows[:live] = mask.rows[:live]
            mask.rows = rows
        self._alloc = alloc

    def _evict(self) -> None:
        """Drop the oldest lines beyond the capacity."""
        over = (self._n - self._lo) - self._capacity
        if over <= 0:
            return
        self._drop_front(over)
        if self._capacity + self._capacity // _SLACK < self._alloc // 2:
            self._compact()
            self._grow(self._capacity + self._capacity // _SLACK)
        self.version += 1

    def _drop_front(self, count: int) -> None:
        """Drop the `count` oldest lines."""
        if count <= 0:
            return
        self._lo += count
        self._evicted += count
        self._marks.ids.drop_below(self._base + self._lo)
        if self._cut:
            first = self._base + self._lo
            for line_id in [i for i in self._cut if i < first]:
                del self._cut[line_id]

    def clear(self) -> None:
        """Forget every line (ids go on from where they were)."""
        with self._write, self._read:
            self._base += self._n
            self._lo = self._n = 0
            self._starts[0] = 0
            self._text = bytearray()
            self._cut.clear()
            self._masks.clear()
            for slot in (self._own, *(r._slot for r in self._live_readers())):
                slot.sel = None
            self._marks = _Selection(("marks",), 0, 0)
            self.generation += 1
            self.version += 1

    # --- reading (any thread: each call holds `_read` briefly) ----------------------------------------

    def _row(self, line_id: int) -> int:
        row = line_id - self._base
        if not self._lo <= row < self._n:
            raise IndexError(f"line {line_id} is not held (held: {self.first_id}..{self.end_id - 1})")
        return row

    def has(self, line_id: int) -> bool:
        """Whether line `line_id` is still held."""
        with self._read:
            return self._lo <= line_id - self._base < self._n

    def line(self, line_id: int) -> LogLine:
        """Return one line, decoded (its message with its line breaks back).

        Raises:
            IndexError: the line is not held (evicted, or not yet added).
        """
        with self._read:
            row = self._row(line_id)
            file, function, lineno = self._site_list[int(self._sites[row])]
            return LogLine(
                line_id,
                float(self._times[row]),
                int(self._levels[row]),
                self._node_name(int(self._nodes[row])),
                self._message(row).replace("\x1f", "\n"),
                file,
                function,
                lineno,
                self._cut.get(line_id, 0),
            )

    def _message(self, row: int, limit: int | None = None) -> str:
        start, end = int(self._starts[row]), int(self._starts[row + 1]) - 1
        if limit is not None:
            end = min(end, start + limit)
        return bytes(self._text[start:end]).decode("utf-8", "replace")

    def rows(
        self, ids: Sequence[int] | npt.NDArray[np.int64], limit: int = 400
    ) -> list[tuple[float, int, str, str]]:
        """Return (time, level, node, message) of each id for drawing: at most `limit` bytes of a message,
        its line breaks as ``↵``."""
        with self._read:
            return self._rows(ids, limit)

    def _rows(
        self, ids: Sequence[int] | npt.NDArray[np.int64], limit: int
    ) -> list[tuple[float, int, str, str]]:
        out = []
        for line_id in ids:
            row = self._row(int(line_id))
            text = self._message(row, limit).replace("\x1f", " \u21b5 ")
            out.append(
                (
                    float(self._times[row]),
                    int(self._levels[row]),
                    self._node_name(int(self._nodes[row])),
                    text,
                )
            )
        return out

    def window(
        self, shown: Shown, ids: npt.NDArray[np.int64], limit: int = 400
    ) -> list[tuple[float, int, str, str]] | None:
        """`rows` of some of an answer's `ids` (those in view), or None when the store has changed under
        the answer since (a late batch merged in, the lines cleared or evicted): wait for the next one."""
        with self._read:
            if self.generation != shown.generation or (len(ids) and int(ids[0]) < self._base + self._lo):
                return None
            return self._rows(ids, limit)

    def _node_name(self, node: int) -> str:
        names = self._node_names
        return names[node] if node < len(names) else ""

    def times(self, ids: Sequence[int] | npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        """Return the source time of each id."""
        with self._read:
            rows = np.asarray(ids, dtype=np.int64) - self._base
            return self._times[rows].copy()

    def numbers(self, line_id: int) -> list[NumberSpan]:
        """Return the numbers of a line's message (what "plot this number" can capture), in order."""
        return find_numbers(self.line(line_id).message)

    def nodes(self) -> list[str]:
        """Return every logger name seen so far, in the order they first logged."""
        return list(self._node_names)

    def node_counts(self) -> dict[str, int]:
        """Return how many held lines each logger wrote."""
        with self._read:
            lo, n = self._lo, self._n
            counts = np.bincount(self._nodes[lo:n], minlength=len(self._node_names))
        out: dict[str, int] = {}
        for name, count in zip(self._node_names, counts.tolist(), strict=False):
            out[name] = out.get(name, 0) + int(count)
        return out

    def index_at(self, t: float) -> int | None:
        """Return the id of the last line at or before source time `t`, None when every line is later."""
        with self._read:
            lo, n = self._lo, self._n
            k = int(np.searchsorted(self._times[lo:n], t, side="right"))
            return None if k == 0 else self._base + lo + k - 1

    def span(self) -> tuple[float, float] | None:
        """Return (oldest, newest) source time held, None when empty."""
        with self._read:
            if self._n == self._lo:
                return None
            return float(self._times[self._lo]), float(self._times[self._n - 1])

    def marks(self, min_level: int = WARN) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.uint8]]:
        """Return the times and levels of held lines at `min_level` or above (timeline marks), in order."""
        with self._read:
            rows = self._marks.ids.values() - self._base
            levels = self._levels[rows]
            if min_level > WARN:
                keep = levels >= min_level
                rows, levels = rows[keep], levels[keep]
            return self._times[rows], levels

    # --- filtering ------------------------------------------------------------------------------------

    def select(self, filt: LogFilter, *, until: float | None = None) -> npt.NDArray[np.int64]:
        """Return the ids of the lines `filt` shows, oldest first (only those at or before `until`).

        Results are cached per filter and grown as lines arrive, so asking again costs only the new lines.

        Raises:
            FilterError: the include or exclude pattern does not compile with RE2.
        """
        return self.select_within(filt, until=until, budget=None)[0].copy()

    def select_within(
        self, filt: LogFilter, *, until: float | None = None, budget: float | None = 0.03
    ) -> tuple[npt.NDArray[np.int64], bool]:
        """Like `select`, newest lines first, within about `budget` seconds; also say whether it is complete.

        A new filter over many lines is answered for the newest lines at once and for the older ones over the
        next calls. Lines that arrive meanwhile are always answered. A console asks through a `LogReader`
        instead (its own cached answer, given by the worker).

        Returns:
            ``(ids, complete)``: ids as in `select`, of the lines answered so far, as a read-only view that
            later calls leave as it is (no copy of every id per call); and whether every held line has been
            answered (when False, ask again).
        """
        with self._write:
            return self._select(self._own, filt, until, budget)

    def _select(
        self, slot: _Slot, filt: LogFilter, until: float | None, budget: float | None
    ) -> tuple[npt.NDArray[np.int64], bool]:
        """`select_within` for the answer cached in `slot` (the caller holds `_write`)."""
        key = (filt.min_level, filt.hidden, filt.include, filt.exclude, filt.text)
        sel = slot.sel
        lo, n = self._lo, self._n
        if sel is None or sel.key != key:
            for kind, pattern in (("include", filt.include), ("exclude", filt.exclude)):
                if pattern:
                    _compiled(kind, pattern)  # raises FilterError before anything is kept
            sel = slot.sel = _Selection(key, n, n)
        sel.ids.drop_below(self._base + lo)  # evicted lines
        if sel.b < lo:
            sel.a = sel.b = lo
        sel.a = max(sel.a, lo)
        if sel.b < n:  # new lines: always answered
            sel.ids.append(self._evaluate(filt, sel.b, n))
            sel.b = n
        deadline = None if budget is None else time.perf_counter() + budget
        step = self.first_slice
        while sel.a > lo:
            r0 = max(lo, sel.a - step)
            started = time.perf_counter()
            sel.ids.prepend(self._evaluate(filt, r0, sel.a))
            sel.a = r0
            if deadline is not None:
                now = time.perf_counter()
                if now >= deadline:
                    break
                per_row = (now - started) / max(1, step)
                step = int(min(_MAX_SLICE, max(self.first_slice, (deadline - now) / max(per_row, 1e-9) / 2)))
            else:
                step = _MAX_SLICE
        ids = sel.ids.values()
        if until is not None:
            last = self.index_at(until)
            ids = ids[: int(np.searchsorted(ids, -1 if last is None else last, side="right"))]
        ids = ids[:]
        ids.flags.writeable = False
        return ids, sel.a <= lo

    def _evaluate(self, filt: LogFilter, r0: int, r1: int) -> npt.NDArray[np.int64]:
        """The ids of the rows of ``[r0, r1)`` that pass `filt`."""
        keep = np.ones(r1 - r0, dtype=bool)
        if filt.min_level > 0:
            keep &= self._levels[r0:r1] >= filt.min_level
        if filt.hidden:
            shown = np.ones(max(1, len(self._node_names)), dtype=bool)
            for k, name in enumerate(self._node_names):
                if name in filt.hidden:
                    shown[k] = False
            keep &= shown[self._nodes[r0:r1]]
        for kind, pattern, want in (
            ("text", filt.text, True),
            ("include", filt.include, True),
            ("exclude", filt.exclude, False),
        ):
            if pattern and keep.any():
                rows = self._mask(kind, pattern, r0, r1)
                keep &= rows if want else ~rows
        return (np.flatnonzero(keep) + (r0 + self._base)).astype(np.int64)

    def _mask(self, kind: str, pattern: str, r0: int, r1: int) -> npt.NDArray[np.bool_]:
        """Whether each row of ``[r0, r1)`` matches (cached per pattern, grown to cover what is asked)."""
        key = (kind, pattern)
        mask = self._masks.get(key)
        if mask is None:
            mask = _Mask(np.zeros(self._alloc, dtype=bool), r1, r1)
            self._masks[key] = mask
            while len(self._masks) > _MAX_CACHED:
                self._masks.popitem(last=False)
        else:
            self._masks.move_to_end(key)
        if mask.b <= self._lo or mask.a == mask.b:
            mask.a = mask.b = max(r1, self._lo)
        mask.a = max(mask.a, self._lo)
        if mask.b < r1:
            mask.rows[mask.b : r1] = self._find(kind, pattern, mask.b, r1)
            mask.b = r1
        if mask.a > r0:
            mask.rows[r0 : mask.a] = self._find(kind, pattern, r0, mask.a)
            mask.a = r0
        return mask.rows[r0:r1]

    def _find(self, kind: str, pattern: str, r0: int, r1: int) -> npt.NDArray[np.bool_]:
        """Whether each row of ``[r0, r1)`` matches the text search or the include/exclude pattern."""
        if kind == "text":
            return self._find_text(pattern.encode("utf-8", "replace"), r0, r1, fold=True)
        literals = _literals(pattern)
        if literals is None:
            return self._find_regex(_compiled(kind, pattern), r0, r1)
        found = np.zeros(r1 - r0, dtype=bool)
        words, fold = literals
        for word in words:
            found |= self._find_text(word, r0, r1, fold=fold)
        return found

    def _find_text(self, needle: bytes, r0: int, r1: int, *, fold: bool) -> npt.NDArray[np.bool_]:
        """Rows of ``[r0, r1)`` holding `needle` (ASCII case ignored with `fold`): numpy, not line by line."""
        want = needle.translate(_SANITIZE)
        if fold:
            want = want.lower()
        out = np.zeros(r1 - r0, dtype=bool)
        if r1 <= r0 or not want:
            out[:] = bool(r1 > r0)
            return out
        b0, b1 = int(self._starts[r0]), int(self._starts[r1])
        if len(want) > b1 - b0:
            return out
        buf = np.frombuffer(self._text, dtype=np.uint8, count=b1 - b0, offset=b0)
        try:
            folded = [fold and c in _LETTERS for c in want]
            order = sorted(range(len(want)), key=lambda k: _FREQUENCY.get(want[k] | 0x20, 0))
            first = order[0]
            c = want[first]
            window = buf[first : len(buf) - len(want) + 1 + first]
            candidates = np.flatnonzero(((window | 0x20) if folded[first] else window) == c)
            del window
            for k in order[1:]:
                if not len(candidates):
                    break
                c = want[k]
                got = buf[candidates + k]
                candidates = candidates[((got | 0x20) if folded[k] else got) == c]
            starts = self._starts[r0 : r1 + 1] - b0
            if len(candidates) > r1 - r0:  # many hits: mark bytes, then one "any" per line
                hit = np.zeros(b1 - b0, dtype=bool)
                hit[candidates] = True
                out = np.logical_or.reduceat(hit, starts[:-1])
                out &= starts[1:] > starts[:-1]
            elif len(candidates):
                out[np.searchsorted(starts, candidates, side="right") - 1] = True
        finally:
            del buf  # release the export of the bytearray before it may grow again
        return out

    def _find_regex(
        self, compiled: tuple[re2._Regexp, re2._Regexp], r0: int, r1: int
    ) -> npt.NDArray[np.bool_]:
        """Rows of ``[r0, r1)`` whose message contains a match: one RE2 call per matching line (it ends at the
        line's end: no search for the next line), or, after `_RUN_AFTER` adjacent ones, one for the rest of
        the run of matching lines."""
        out = np.zeros(r1 - r0, dtype=bool)
        if r1 <= r0:
            return out
        lines, runs = compiled
        match, run = lines._regexp.Match, runs._regexp.Match
        data = self._text
        pos, end = int(self._starts[r0]), int(self._starts[r1])
        hits: list[int] = []
        hit = hits.append
        spans: list[tuple[int, int]] = []
        adjacent = 0
        while pos < end:
            if adjacent >= _RUN_AFTER:  # matches come in a run: one call takes the rest of it
                stop = run(_ANCHOR_START, data, pos, end)[0][1]
                if stop > pos:
                    spans.append((pos, stop))
                    pos = stop
                adjacent = 0
                continue
            found = match(_UNANCHORED, data, pos, end)[0]
            start = found[0]
            if start < 0:
                break
            adjacent = adjacent + 1 if start == pos else 1
            hit(start)
            pos = found[1] + 1
        starts = self._starts[r0 : r1 + 1]
        if hits:
            out[np.searchsorted(starts, np.asarray(hits, dtype=np.int64))] = True
        for a, b in spans:
            i, j = np.searchsorted(starts, (a, b))
            out[int(i) : int(j)] = True
        return out

    # --- plot this number ------------------------------------------------------------------------------

    def preview(self, proposal: Proposal, *, node: str | None = None, min_level: int = 0) -> Matches:
        """Return every held line the proposed pattern matches and the value it takes from each.

        Args:
            proposal: from ``propose`` (its pattern; its node filter unless `node` is given).
            node: only lines of this logger (exact name or fnmatch glob); default: the proposal's node.
            min_level: only lines at this level or above.
        """
        with self._write:  # (the rows do not change under it; readers of rows go on)
            return self._preview(proposal, node, min_level)

    def _preview(self, proposal: Proposal, node: str | None, min_level: int) -> Matches:
        lo, n = self._lo, self._n
        empty = Matches(np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0))
        if n == lo:
            return empty
        b0, b1 = int(self._starts[lo]), int(self._starts[n])
        # The matcher's framing, b"\x00" + text + b"\x01" per line, with each line's own breaks back.
        framed = self._text[b0:b1].replace(b"\n", b"\x01\x00")  # two copies in all, the rest in place
        if framed.find(b"\x1f") >= 0:
            framed = framed.replace(b"\x1f", b"\n")
        framed[:0] = b"\x00"
        del framed[-1]
        starts = (self._starts[lo:n] - b0) + np.arange(n - lo, dtype=np.int64)
        rows, values = match_joined(proposal, framed, starts)
        del framed
        rows = rows + lo
        want = proposal.node if node is None else node
        if want:
            ids = [k for k, name in enumerate(self._node_names) if node_matches(name, want)]
            keep = np.isin(self._nodes[rows], np.asarray(ids, dtype=np.uint16))
            rows, values = rows[keep], values[keep]
        if min_level > 0:
            keep = self._levels[rows] >= min_level
            rows, values = rows[keep], values[keep]
        return Matches(rows + self._base, self._times[rows].copy(), values)

    def messages(self, ids: Iterable[int]) -> list[str]:
        """Return the message of each id (its line breaks back)."""
        with self._read:
            return [self._message(self._row(int(i))).replace("\x1f", "\n") for i in ids]


# --- helpers -------------------------------------------------------------------------------------------

_FREQUENCY: Final[dict[int, int]] = {c: 100 - k for k, c in enumerate(b" etaoinsrhldcumfpgwybvkxjqz")}
"""Common bytes first: the text search filters on the rarest byte of the needle first."""


def _cut_utf8(data: bytes) -> bytes:
    """The first `MAX_LINE` bytes of `data`, without the part of a UTF-8 character the cut splits."""
    if len(data) <= MAX_LINE or (data[MAX_LINE] & 0xC0) != 0x80:
        return data[:MAX_LINE]
    end = MAX_LINE
    while end > MAX_LINE - 4 and (data[end - 1] & 0xC0) == 0x80:
        end -= 1
    return data[: end - 1] if data[end - 1] >= 0xC0 else data[:end]


def _read_site(raw: bytes, at: int) -> tuple[str, str, int]:
    """Read a Log's file, function and line from payload offset `at` (None-safe: unknown parts empty)."""
    u32 = _U32[0] if raw[:2] == b"\x00\x01" else _U32[1]
    try:
        (n,) = u32.unpack_from(raw, at)
        file = raw[at + 4 : at + 4 + n - 1].decode("utf-8", "replace")
        at = 4 + ((at + 4 + n - 4 + 3) & ~3)
        (m,) = u32.unpack_from(raw, at)
        function = raw[at + 4 : at + 4 + m - 1].decode("utf-8", "replace")
        at = 4 + ((at + 4 + m - 4 + 3) & ~3)
        (line,) = u32.unpack_from(raw, at)
    except struct.error:
        return ("", "", 0)
    return file, function, int(line)


_COMPILED: dict[tuple[str, str], tuple[re2._Regexp, re2._Regexp]] = {}


def _compiled(kind: str, pattern: str) -> tuple[re2._Regexp, re2._Regexp]:
    """The line and run regexes of an include or exclude `pattern` (cached)."""
    key = (kind, pattern)
    found = _COMPILED.get(key)
    if found is not None:
        return found
    try:
        compile_regex(pattern)  # the bridge's checks and messages (RE2 syntax, program size)
    except RegexError as exc:
        raise FilterError(f"{kind}: {exc}") from None
    body = _line_anchors(pattern)
    try:
        # Each stored message is one line of the text; with never_nl a match never spans two of them.
        lines = re2.compile(rf"(?m)^[^\n]*?(?:{body})[^\n]*", options=_MATCH_OPTIONS)
        runs = re2.compile(rf"(?m)(?:^[^\n]*?(?:{body})[^\n]*$\C)+", options=_MATCH_OPTIONS)
    except re2.error as exc:
        raise FilterError(f"{kind}: {exc}") from None
    if len(_COMPILED) > 256:
        _COMPILED.clear()
    _COMPILED[key] = (lines, runs)
    return lines, runs


_META: Final = frozenset(".^$*+?()[]{}|\\")
_FOLDS_BEYOND_ASCII: Final = frozenset("ksKS")
"""ASCII letters RE2's case folding also matches outside ASCII (K: the Kelvin sign, S: the long s)."""


def _literals(pattern: str) -> tuple[list[bytes], bool] | None:
    """The alternatives of a pattern made only of literal text (``wall``, ``a\\.b|timeout``, ``(?i)error``)
    and whether it ignores case; None for anything else (those patterns go to RE2)."""
    fold = pattern.startswith("(?i)")
    body = pattern[4:] if fold else pattern
    words: list[str] = []
    word: list[str] = []
    i = 0
    while i < len(body):
        ch = body[i]
        if ch == "\\":
            if i + 1 >= len(body) or body[i + 1].isalnum() or not body[i + 1].isascii():
                return None  # \d, \b, \x41 ...: a class or an escape, not literal text
            word.append(body[i + 1])
            i += 2
            continue
        if ch == "|":
            words.append("".join(word))
            word = []
        elif ch in _META or ch in "\n\x00\x01" or (fold and (not ch.isascii() or ch in _FOLDS_BEYOND_ASCII)):
            return None
        else:
            word.append(ch)
        i += 1
    words.append("".join(word))
    if any(not w for w in words):
        return None  # an empty alternative matches everywhere
    return [w.encode("utf-8") for w in words], fold


def _line_anchors(pattern: str) -> str:
    r"""`pattern` with ``\A`` and ``\z`` written ``^`` and ``$``: in multi-line mode both then mean the start
    and the end of each stored line, as they do for one message on its own."""
    out: list[str] = []
    i = 0
    while i < len(pattern):
        ch = pattern[i]
        if ch == "\\" and i + 1 < len(pattern):
            nxt = pattern[i + 1]
            out.append({"A": "^", "z": "$"}.get(nxt, ch + nxt))
            i += 2
            continue
        out.append(ch)
        i += 1
    return "".join(out)
