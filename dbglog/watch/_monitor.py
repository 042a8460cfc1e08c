"""The back ends that call a watch when its line runs: ``sys.monitoring`` (3.12+) or a local trace (3.11).

Both keep one table, code object -> line -> the watches there, and call each watch's ``hit(frame)``
before the line runs (as a debugger's logpoint sees it). They watch only while the table is not empty
and leave nothing behind once it is (docs/watch.md, *Cost*):

* `MonitoringBackend` (3.12+): a ``sys.monitoring`` tool id of its own (4, else 3: 0-2 and 5 are
  debuggers', coverage's, profilers' and optimizers'), LINE events enabled on the watched code objects
  only; a line of them that is not watched returns ``DISABLE`` at its first event. Arming a line calls
  ``restart_events()`` (lines it disabled before may be watched now): other tools' disabled lines then
  report once more. The tool id is freed when the last watch goes.
* `TraceBackend` (3.11): a global trace function in every thread (``threading.settrace`` for threads
  started later) that returns None for every frame whose code is not watched, so other frames pay only
  their call event; the watched code's frames get a local trace function. A thread already traced by
  someone else (a debugger, coverage) is left alone and reported; the trace function is removed from
  every thread when the last watch goes. Existing threads are reached through CPython 3.11's
  ``_PyEval_SetTrace`` (what 3.12's ``threading.settrace_all_threads`` calls), by ctypes.
"""

from __future__ import annotations

import ctypes
import sys
import threading
import types
from collections.abc import Callable, Iterator
from typing import Any, Final, Protocol

__all__ = [
    "Backend",
    "BackendError",
    "CodeEntry",
    "MonitoringBackend",
    "TraceBackend",
    "Watcher",
    "new_backend",
]

MONITORING_TOOL_IDS: Final = (4, 3)
"""``sys.monitoring`` tool ids tried, in order (0 debugger, 1 coverage, 2 profiler, 5 optimizer: theirs)."""
_TOOL_NAME: Final = "dbglog watch"


class BackendError(RuntimeError):
    """The back end cannot watch in this process (no free tool id, an unknown thread-state layout)."""


class Watcher(Protocol):
    """What a back end calls at a watched line: ``hit`` returns False once the watch is off."""

    def hit(self, frame: types.FrameType) -> bool:
        """Read the values at this hit; False when the watch wants no more hits."""


class CodeEntry:
    """One watched code object: its watched lines and how many events it cost."""

    __slots__ = ("events", "lines")

    def __init__(self) -> None:
        self.lines: dict[int, tuple[Watcher, ...]] = {}
        self.events = 0
        """Trace events in its frames (3.11: every line of them pays one), for the CPU share."""


class Backend(Protocol):
    """A way to be called when a line runs."""

    name: str
    event_ns: int
    """An estimate of what one event costs beyond the time measured in the watch (the call itself)."""
    skipped: list[str]
    """Threads left alone (traced by another tool), as names."""

    def watch(self, code: types.CodeType, line: int, watchers: tuple[Watcher, ...]) -> None:
        """Call `watchers` at `line` of `code` (an empty tuple stops watching the line)."""

    def entry(self, code: types.CodeType) -> CodeEntry | None:
        """The watched code object's entry."""

    def close(self) -> None:
        """Stop watching everything and release what was taken (idempotent)."""

    def after_fork(self) -> None:
        """In a forked child: drop every watch (the child is not watched)."""


def _hits(watchers: tuple[Watcher, ...], frame: types.FrameType) -> bool:
    alive = False
    for watcher in watchers:
        if watcher.hit(frame):
            alive = True
    return alive


class MonitoringBackend:
    """Watches lines with ``sys.monitoring`` LINE events on the watched code objects only (3.12+)."""

    name = "sys.monitoring"
    event_ns = 300
    """The callback's call, frame and table look-ups around a hit (measured ~250-350 ns on 3.12)."""

    def __init__(self) -> None:
        self.table: dict[types.CodeType, CodeEntry] = {}
        self.tool: int | None = None
        self.skipped: list[str] = []
        self._lock = threading.Lock()

    def _callback(self) -> Callable[[types.CodeType, int], object]:
        table = self.table
        disable = sys.monitoring.DISABLE  # type: ignore[attr-defined]
        getframe = sys._getframe

        def line_event(code: types.CodeType, line: int) -> object:
            try:
                entry = table.get(code)
                if entry is None:
                    return disable
                watchers = entry.lines.get(line)
                if watchers is None:
                    return disable
                entry.events += 1
                return None if _hits(watchers, getframe(1)) else disable
            except Exception:  # never into the program: this line just stops reporting
                return disable

        return line_event

    def _claim(self) -> int:
        mon: Any = sys.monitoring  # type: ignore[attr-defined]
        for tool in MONITORING_TOOL_IDS:
            if mon.get_tool(tool) is None:
                mon.use_tool_id(tool, _TOOL_NAME)
                mon.register_callback(tool, mon.events.LINE, self._callback())
                return tool
        taken = ", ".join(f"{t} ({mon.get_tool(t)})" for t in MONITORING_TOOL_IDS)
        raise BackendError(f"sys.monitoring has no free tool id for dbglog: {taken} are taken")

    def watch(self, code: types.CodeType, line: int, watchers: tuple[Watcher, ...]) -> None:
        """Call `watchers` at `line` of `code` (an empty tuple stops watching the line)."""
        mon: Any = sys.monitoring  # type: ignore[attr-defined]
        with self._lock:
            if watchers:
                if self.tool is None:
                    self.tool = self._claim()
                entry = self.table.get(code)
                if entry is None:
                    entry = self.table[code] = CodeEntry()
                entry.lines[line] = watchers
                mon.set_local_events(self.tool, code, mon.events.LINE)
                mon.restart_events()  # this line may have been disabled as not watched before
                return
            entry = self.table.get(code)
            if entry is None:
                return
            entry.lines.pop(line, None)
            if not entry.lines:
                del self.table[code]
                if self.tool is not None:
                    mon.set_local_events(self.tool, code, 0)
            if not self.table:
                self._release()

    def entry(self, code: types.CodeType) -> CodeEntry | None:
        """The watched code object's entry."""
        return self.table.get(code)

    def _release(self) -> None:
        tool, self.tool = self.tool, None
        if tool is None:
            return
        mon: Any = sys.monitoring  # type: ignore[attr-defined]
        for code in list(self.table):
            mon.set_local_events(tool, code, 0)
        self.table.clear()
        mon.register_callback(tool, mon.events.LINE, None)
        mon.free_tool_id(tool)

    def close(self) -> None:
        """Stop watching everything and free the tool id (idempotent)."""
        with self._lock:
            self._release()

    def after_fork(self) -> None:
        """In a forked child: drop every watch."""
        self._lock = threading.Lock()
        self._release()


# ---------------------------------------------------------------------------------------------------------
# 3.11: every thread's trace function, through the thread states.

_WORDS: Final = 48
"""Pointer-sized words of a thread state read when its layout is worked out (the fields are in the first
24 on CPython 3.11)."""


class _ThreadStates:
    """CPython 3.11's thread states, read and set with ctypes.

    The layout is not assumed: setting a probe trace function on this thread shows which words hold
    ``c_traceobj`` (the probe) and, two words before, ``c_tracefunc`` (sys.settrace's trampoline); the
    thread's ident shows where ``thread_id`` is. It is checked once, against the probe being removed.
    """

    def __init__(self) -> None:
        api = ctypes.pythonapi
        self._get = api.PyThreadState_Get
        self._get.restype = ctypes.c_void_p
        self._interp = api.PyInterpreterState_Get
        self._interp.restype = ctypes.c_void_p
        self._head = api.PyInterpreterState_ThreadHead
        self._head.argtypes = [ctypes.c_void_p]
        self._head.restype = ctypes.c_void_p
        self._next = api.PyThreadState_Next
        self._next.argtypes = [ctypes.c_void_p]
        self._next.restype = ctypes.c_void_p
        self._set = api._PyEval_SetTrace
        self._set.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
        self._set.restype = ctypes.c_int
        self.obj_at, self.func_at, self.ident_at, self.trampoline = self._layout()

    def _words(self, tstate: int) -> list[int]:
        return list((ctypes.c_size_t * _WORDS).from_address(tstate))

    def _layout(self) -> tuple[int, int, int, int]:
        if sys.gettrace() is not None:
            raise BackendError(
                "the watch agent's own thread is traced: cannot work out the thread-state layout"
            )
        me = self._get()

        def probe(frame: types.FrameType, event: str, arg: object) -> None:
            return None

        before = self._words(me)
        sys.settrace(probe)
        try:
            during = self._words(me)
        finally:
            sys.settrace(None)
        after = self._words(me)
        objs = [i for i, w in enumerate(during) if w == id(probe) and before[i] == 0 and after[i] == 0]
        idents = [i for i, w in enumerate(during) if w == threading.get_ident()]
        if len(objs) != 1 or objs[0] < 2 or not idents:
            raise BackendError("unknown CPython thread-state layout: threads cannot be traced")
        obj_at = objs[0]
        func_at = obj_at - 2
        if during[func_at] == 0 or before[func_at] != 0 or after[func_at] != 0:
            raise BackendError("unknown CPython thread-state layout: threads cannot be traced")
        return obj_at, func_at, idents[0], during[func_at]

    def states(self) -> Iterator[int]:
        """Every thread state of this interpreter (hold the GIL; the list may change between steps)."""
        ts = self._head(self._interp())
        while ts:
            yield ts
            ts = self._next(ts)

    def read(self, tstate: int) -> tuple[int, int, int]:
        """Return (c_tracefunc, c_traceobj, thread ident) of a thread state."""
        words = (ctypes.c_size_t * _WORDS).from_address(tstate)
        return words[self.func_at], words[self.obj_at], words[self.ident_at]

    def set(self, tstate: int, tracer: object | None) -> None:
        """Set (or, with None, remove) a thread state's Python trace function."""
        if tracer is None:
            self._set(tstate, None, None)
        else:
            self._set(tstate, self.trampoline, id(tracer))


class TraceBackend:
    """Watches lines with a global trace function that traces only the watched code's frames (3.11)."""

    name = "settrace"
    event_ns = 600
    """One call of the local trace function with CPython's locals sync around it (measured ~570 ns a
    traced line on 3.11)."""

    def __init__(self) -> None:
        self.table: dict[types.CodeType, CodeEntry] = {}
        self.skipped: list[str] = []
        self._lock = threading.Lock()
        self._states: _ThreadStates | None = None
        self._installed = False
        self._local, self._global = self._tracers()

    def _tracers(self) -> tuple[Any, Any]:
        table = self.table

        def local(frame: types.FrameType, event: str, arg: object) -> Any:
            entry = table.get(frame.f_code)
            if entry is None:
                return None  # no longer watched: this frame stops being traced
            entry.events += 1
            if event == "line":
                watchers = entry.lines.get(frame.f_lineno)
                if watchers is not None:
                    try:  # noqa: SIM105  (free when nothing is raised; suppress() costs a call per hit)
                        _hits(watchers, frame)
                    except Exception:  # noqa: S110  (never into the program)
                        pass
            return local

        def global_(frame: types.FrameType, event: str, arg: object) -> Any:
            return local if frame.f_code in table else None

        return local, global_

    def _own_threads(self) -> set[int]:
        own = {threading.get_ident()}
        for thread in threading.enumerate():
            if thread.name.startswith("dbglog") and thread.ident is not None:
                own.add(thread.ident)
        return own

    def _names(self) -> dict[int, str]:
        return {t.ident: t.name for t in threading.enumerate() if t.ident is not None}

    def _install(self) -> None:
        if self._states is None:
            self._states = _ThreadStates()
        states = self._states
        own = self._own_threads()
        names = self._names()
        self.skipped = []
        live = set(sys._current_frames())
        for ts in states.states():
            func, obj, ident = states.read(ts)
            if ident in own or ident not in live:
                continue
            if func or obj:
                self.skipped.append(names.get(ident, f"thread {ident}"))
                continue
            states.set(ts, self._global)
        if threading.gettrace() is None:
            threading.settrace(self._global)
        self._installed = True

    def _uninstall(self) -> None:
        if not self._installed or self._states is None:
            return
        self._installed = False
        states = self._states
        live = set(sys._current_frames())
        for ts in states.states():
            _func, obj, ident = states.read(ts)
            if obj == id(self._global) and ident in live:
                states.set(ts, None)
        if threading.gettrace() is self._global:
            threading.settrace(None)
        for frame in _all_frames():
            if frame.f_trace is self._local:
                frame.f_trace = None

    def watch(self, code: types.CodeType, line: int, watchers: tuple[Watcher, ...]) -> None:
        """Call `watchers` at `line` of `code` (an empty tuple stops watching the line)."""
        with self._lock:
            if watchers:
                entry = self.table.get(code)
                if entry is None:
                    entry = self.table[code] = CodeEntry()
                entry.lines[line] = watchers
                if not self._installed:
                    self._install()
                for frame in _all_frames():  # frames already running the code: trace them from now on
                    if frame.f_code is code and frame.f_trace is None:
                        frame.f_trace = self._local
                return
            entry = self.table.get(code)
            if entry is None:
                return
            entry.lines.pop(line, None)
            if not entry.lines:
                del self.table[code]
            if not self.table:
                self._uninstall()

    def entry(self, code: types.CodeType) -> CodeEntry | None:
        """The watched code object's entry."""
        return self.table.get(code)

    def close(self) -> None:
        """Stop watching everything; remove the trace function from every thread (idempotent)."""
        with self._lock:
            self.table.clear()
            self._uninstall()

    def after_fork(self) -> None:
        """In a forked child: drop every watch (only the forking thread is left)."""
        self._lock = threading.Lock()
        self.table.clear()
        if sys.gettrace() is self._global:
            sys.settrace(None)
        if threading.gettrace() is self._global:
            threading.settrace(None)
        self._installed = False


def _all_frames() -> Iterator[types.FrameType]:
    for top in list(sys._current_frames().values()):
        frame: types.FrameType | None = top
        while frame is not None:
            yield frame
            frame = frame.f_back


def new_backend() -> Backend:
    """Return the back end of this Python: ``sys.monitoring`` on 3.12+, the trace back end on 3.11."""
    if hasattr(sys, "monitoring"):
        return MonitoringBackend()
    return TraceBackend()
