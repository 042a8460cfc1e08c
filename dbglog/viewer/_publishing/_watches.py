"""The viewer's watches: one `WatchClient` that keeps a dashboard's watches armed, never on the UI thread.

The client is made on the service's own thread (its ROS context takes a while to start); the queries of the
"Watch a variable…" dialog (the process's files, source, names) are `Future`s the UI polls each frame;
arming and disarming happen on the service's threads; and each watch's state in every process is summed
up, a few times a second, as a `WatchReport` the UI reads (and shows on the widget: `WatchReport.over`).
The client re-arms a watch in a process that restarts (docs/watch.md, *In the viewer*).
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
import time
from collections.abc import Callable, Hashable, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Final, Generic, TypeVar

from dbglog._ros._tags import topic_for_tag
from dbglog.viewer._data._model import Status
from dbglog.watch.client import (
    DISCOVERY_S,
    Names,
    Process,
    Source,
    Watch,
    WatchClient,
    WatchError,
    WatchEvent,
    WatchSpec,
    WatchStatus,
)

__all__ = ["POLL_S", "WatchReport", "WatchService", "summarize"]

_log = logging.getLogger(__name__)

POLL_S: Final = 0.2
"""How often the service reads its watches' states and the processes (seconds)."""
_QUERY_TIMEOUT_S: Final = 5.0
_ANSWER_POLL_S: Final = 0.03
"""How often the watches are read while one waits for a process's answer."""
_ANSWER_WAIT_S: Final = 2.0
"""A watch is read that often for this long after it was armed or its report last said it waits."""
_SCALAR_TYPES: Final = ("Float64", "Int64", "Bool", "String")

T = TypeVar("T")
K = TypeVar("K", bound=Hashable)

_LABELS: Final[dict[str, tuple[Status, str]]] = {
    "starting": (Status.WAITING, "arming"),
    "asking": (Status.WAITING, "arming"),
    "none": (Status.WAITING, "no process"),
    "no_file": (Status.WAITING, "no file"),
    "gone": (Status.STALE, "gone"),
    "no_line": (Status.ERROR, "no line"),
    "expr_error": (Status.ERROR, "expr error"),
    "refused": (Status.ERROR, "refused"),
    "cpu": (Status.ERROR, "cpu limit"),
    "done": (Status.STALE, "done"),
    "failed": (Status.ERROR, "no watch"),
}
"""A watch's state (when not armed) -> the widget's status and what its pill says."""


@dataclass(frozen=True, slots=True)
class WatchReport:
    """A watch's state over every process, as a widget shows it (a `StatusNote` of its frame)."""

    state: str
    """``armed`` (in at least one process, and values come), ``starting`` (the client is being made),
    ``asking`` (no answer yet), ``none`` (no watchable process), ``no_file`` (none has loaded the file
    yet), ``no_line`` (the line has no code), ``expr_error`` (an expression is refused, or cannot be read
    at any hit), ``refused``, ``cpu`` (disarmed by the CPU rule), ``done``, ``gone`` (the process exited:
    armed again when it starts again), ``failed`` (no client: ROS did not start), ``off`` (not armed: a
    recording is shown)."""
    message: str = ""
    """What a person reads in the widget's tooltip."""
    topics: tuple[str, ...] = ()
    """Its tags' topics (each expression's, then a dict's keys), in the processes' robot namespaces."""

    def over(self, status: Status, reason: str) -> tuple[Status, str, str]:
        """The widget's status, pill text and reason, given those of its series.

        Armed, the series tell (live, stale; ``armed`` while no value came yet); otherwise the watch's state
        does (``gone`` grey, ``no line`` and ``expr error`` red, ``no process`` orange).
        """
        why = "\n".join(t for t in (self.message, reason) if t)
        if self.state == "armed":
            if status is Status.WAITING:
                return Status.WAITING, "armed", "\n".join(t for t in (self.message, "no hit yet") if t)
            return status, status.value, why
        if self.state == "off":
            return status, status.value, why
        shown, label = _LABELS.get(self.state, (Status.ERROR, self.state))
        return shown, label, self.message


def summarize(
    spec: WatchSpec,
    statuses: Sequence[WatchStatus],
    *,
    failing: Mapping[str, str] | None = None,
    noted: Mapping[str, str] | None = None,
    names: Mapping[str, str] | None = None,
    topics: Sequence[str] = (),
) -> WatchReport:
    """Sum up a watch's states in every process it was sent to (one `WatchStatus` each).

    Armed anywhere with values coming wins; then the errors (a refused expression, a line without code,
    the CPU rule); then a process that exited; then the processes still answering or without the file.

    Args:
        spec: the watch.
        statuses: its state in each process.
        failing: agent -> the expression error of a process where the watch is armed but no hit gives a
            value (a missing name, a property).
        noted: agent -> an expression error seen at some hits of a process where values do come.
        names: agent -> how to name that process (``loop.py (pid 4812)``).
        topics: its tags' topics, for the report.
    """
    failing, noted, names = failing or {}, noted or {}, names or {}
    where = f"{os.path.basename(spec.file)}:{spec.line}"

    def who(agents: Sequence[WatchStatus]) -> str:
        return ", ".join(names.get(s.agent) or f"pid {s.pid}" for s in agents)

    by_state: dict[str, list[WatchStatus]] = {}
    for status in statuses:
        by_state.setdefault(status.state, []).append(status)
    armed = by_state.get("armed", [])
    working = [s for s in armed if s.agent not in failing]
    if working:
        inside = working[0].message  # "in step"
        text = f"watch armed at {where}{' ' + inside if inside else ''} in {who(working)}"
        notes = [f"at some hits: {noted[s.agent]}" for s in working if s.agent in noted]
        return WatchReport("armed", "\n".join([text, *notes[:2]]), tuple(topics))
    if armed:
        first = armed[0]
        return WatchReport("expr_error", f"{failing[first.agent]} (in {who(armed)})", tuple(topics))
    for state in ("expr_error", "refused", "no_line", "cpu", "done"):
        if state in by_state:
            first = by_state[state][0]
            text = first.message or state.replace("_", " ")
            return WatchReport(state, f"{text} (in {who(by_state[state])})", tuple(topics))
    if "gone" in by_state:
        text = f"{who(by_state['gone'])} exited: the watch is armed again when the program starts again"
        return WatchReport("gone", text, tuple(topics))
    if "asking" in by_state:
        return WatchReport("asking", f"arming {where} in {who(by_state['asking'])}", tuple(topics))
    node = f" with the node {spec.node}" if spec.node else ""
    if "no_file" in by_state:
        text = (
            f"no watchable process{node} has loaded {spec.file} yet: the watch is armed once one does "
            f"(asked {who(by_state['no_file'])})"
        )
        return WatchReport("no_file", text, tuple(topics))
    text = (
        f"no watchable process{node} yet: the watch is armed in one that has {where} once it starts "
        "(a Python program is watchable when run with dbglog run, or with DBGLOG_WATCH=1)"
    )
    return WatchReport("none", text, tuple(topics))


class _Kept:
    """One watch the service keeps armed, and what its events told (the service's thread)."""

    __slots__ = ("error", "failing", "noted", "report_at", "spec", "stats", "topics", "watch")

    def __init__(self, spec: WatchSpec) -> None:
        self.spec = spec
        self.watch: Watch | None = None
        self.error: WatchError | None = None
        """Why the client refused to arm it (an expression not allowed: checked here first)."""
        self.failing: dict[str, str] = {}
        """Agent -> an expression error, while no hit since gave values."""
        self.noted: dict[str, str] = {}
        """Agent -> an expression error seen at a hit (values came at other hits)."""
        self.stats: dict[str, dict[str, int]] = {}
        self.topics: list[str] = []
        self.report_at = time.monotonic()
        """Until when (minus `_ANSWER_WAIT_S`) its answers are looked for often: armed, or last waiting."""


class WatchService(Generic[K]):
    """The viewer's watches and its queries to watchable processes, all off the UI thread.

    Args:
        make_client: makes the `WatchClient` (called once, on the service's thread).
        poll_s: how often the watches' states and the processes are read.
    """

    def __init__(
        self, make_client: Callable[[], WatchClient] = WatchClient, *, poll_s: float = POLL_S
    ) -> None:
        self._make = make_client
        self.poll_s = poll_s
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._wake = threading.Event()
        """Set when the wanted watches change (or the service stops): the next turn comes at once."""
        self._ready = threading.Event()
        self._client: WatchClient | None = None
        self._failure = ""
        self._started_at = 0.0
        self._thread: threading.Thread | None = None
        self._pool = ThreadPoolExecutor(max_workers=3, thread_name_prefix="dbglog-watch-query")
        self._wanted: dict[K, WatchSpec] = {}
        """What the dashboard wants armed, by key (the UI sets it: `keep`)."""
        self._kept: dict[K, _Kept] = {}
        """What is armed (the service's thread only)."""
        self._reports: dict[K, WatchReport] = {}
        self._processes: list[Process] = []
        self._discovering = True
        self.version = 0
        """Goes up whenever a report or the list of processes changes (the UI redraws then)."""

    # -- lifecycle ------------------------------------------------------------------------------------------

    def start(self) -> None:
        """Start the service's thread, which makes the client (idempotent; returns at once)."""
        if self._thread is not None or self._stop.is_set():
            return
        self._thread = threading.Thread(target=self._run, name="dbglog-watch-keeper", daemon=True)
        self._thread.start()

    @property
    def started(self) -> bool:
        """Whether `start` was called."""
        return self._thread is not None

    @property
    def ready(self) -> bool:
        """Whether the client is up (processes are being discovered)."""
        return self._ready.is_set() and self._client is not None

    @property
    def failure(self) -> str:
        """Why the client could not be made (``""``: it could, or is being made)."""
        return self._failure

    def close(self, timeout: float = 3.0) -> None:
        """Disarm every watch and close the client, waiting at most `timeout` seconds (idempotent).

        A process whose watcher left without disarming drops the watch itself a few seconds later.
        """
        if self._stop.is_set():
            return
        self._stop.set()
        self._wake.set()
        thread = self._thread
        if thread is not None:
            thread.join(timeout)
        self._pool.shutdown(wait=False, cancel_futures=True)

    # -- what the UI reads (no waiting) ---------------------------------------------------------------------

    def processes(self) -> list[Process]:
        """The watchable processes known now (empty until the client is up)."""
        with self._lock:
            return list(self._processes)

    def discovering(self) -> bool:
        """Whether processes already running may still be on their way (the client just started)."""
        with self._lock:
            return not self.failure and self._discovering

    def report(self, key: K) -> WatchReport:
        """Watch `key`'s state now (``starting`` until the service has read it)."""
        if self._failure:
            return WatchReport("failed", self._failure)
        with self._lock:
            found = self._reports.get(key)
        return found if found is not None else WatchReport("starting", "starting the watch client")

    # -- what the UI asks for (answers come later) ----------------------------------------------------------

    def keep(self, wanted: Mapping[K, WatchSpec]) -> None:
        """Keep exactly these watches armed: new keys are armed, keys no longer given disarmed (soon)."""
        with self._lock:
            if wanted.keys() == self._wanted.keys():
                return
            self._wanted = dict(wanted)
        self._wake.set()
        self.start()

    def files(self, process: Process, *, everything: bool = False) -> Future[list[str]]:
        """The source files of the user's tree that `process` loaded, or every one (a `Future`: poll it)."""
        return self._query(lambda c: c.files(process, everything=everything, timeout=_QUERY_TIMEOUT_S))

    def source(self, process: Process, file: str, line: int, *, context: int = 10) -> Future[Source]:
        """Lines of `file` around `line` as `process` reads them (a `Future`)."""
        return self._query(lambda c: c.source(process, file, line, context=context, timeout=_QUERY_TIMEOUT_S))

    def names(self, process: Process, file: str, line: int) -> Future[Names]:
        """The names an expression at `line` of `file` can read in `process` (a `Future`)."""
        return self._query(lambda c: c.names(process, file, line, timeout=_QUERY_TIMEOUT_S))

    def _query(self, ask: Callable[[WatchClient], T]) -> Future[T]:
        self.start()

        def run() -> T:
            self._ready.wait(60.0)
            client = self._client
            if client is None:
                raise WatchError(self._failure or "the watch client did not start", "failed")
            return ask(client)

        return self._pool.submit(run)

    # -- the service's thread -------------------------------------------------------------------------------

    def _run(self) -> None:
        self._started_at = time.monotonic()
        try:
            client = self._make()
        except Exception as exc:  # no ROS here: every watch says so, the viewer goes on
            with self._lock:
                self._failure = f"cannot start watching: {exc}"
                self.version += 1
            self._ready.set()
            return
        self._client = client
        self._ready.set()
        try:
            while True:
                try:
                    self._turn(client)
                except Exception:  # a turn's trouble (a graph hiccup) must not end the service
                    _log.debug("watch service turn failed", exc_info=True)
                waiting = any(  # an answer on its way: look again soon
                    kept.report_at > time.monotonic() - _ANSWER_WAIT_S for kept in self._kept.values()
                )
                self._wake.wait(min(self.poll_s, _ANSWER_POLL_S) if waiting else self.poll_s)
                self._wake.clear()
                if self._stop.is_set():
                    break
        finally:
            with contextlib.suppress(Exception):
                client.close()  # disarms every watch (each process answers within milliseconds)

    def _turn(self, client: WatchClient) -> None:
        """Arm what is wanted and not armed, disarm what is no longer wanted, and sum up every watch."""
        with self._lock:
            wanted = dict(self._wanted)
        for key in [k for k in self._kept if k not in wanted]:
            kept = self._kept.pop(key)
            if kept.watch is not None:
                self._pool.submit(kept.watch.disarm)  # waits for the processes' answers
        for key, spec in wanted.items():
            if key not in self._kept:
                kept = self._kept[key] = _Kept(spec)
                try:
                    kept.watch = client.arm(spec)
                except WatchError as exc:
                    kept.error = exc
        processes = client.processes()
        discovering = time.monotonic() - self._started_at < DISCOVERY_S or client.discovering()
        names = {p.agent: _process_name(p) for p in processes}
        robots = {p.agent: p.robot for p in processes}
        reports = {key: self._summed(kept, names, robots) for key, kept in self._kept.items()}
        now = time.monotonic()
        for key, report in reports.items():
            if report.state in ("starting", "asking"):
                self._kept[key].report_at = now
        with self._lock:
            if reports != self._reports or processes != self._processes or discovering != self._discovering:
                self._reports, self._processes, self._discovering = reports, processes, discovering
                self.version += 1

    def _summed(self, kept: _Kept, names: Mapping[str, str], robots: Mapping[str, str]) -> WatchReport:
        if kept.error is not None:
            state = "expr_error" if kept.error.state == "expr_error" else "refused"  # checked before sending
            return WatchReport(state, str(kept.error))
        watch = kept.watch
        if watch is None:
            return WatchReport("starting", "starting the watch client")
        for event in watch.events():
            _take_event(kept, event, robots)
        statuses = watch.status()
        for agent, status in statuses.items():
            _take_stats(kept, agent, status, len(kept.spec.exprs))
        for agent, tags in watch.tags().items():
            robot = robots.get(agent)
            if robot is None:
                continue
            for tag in tags:
                topic = topic_for_tag(tag, robot) if tag else ""
                if topic and topic not in kept.topics:
                    kept.topics.append(topic)
        # A dict's own tag carries nothing once its keys' tags are known: those are shown instead.
        topics = [t for t in kept.topics if not any(o.startswith(t + "/") for o in kept.topics)]
        known = {s.agent: names.get(s.agent, f"pid {s.pid}") for s in statuses.values()}
        return summarize(
            kept.spec,
            list(statuses.values()),
            failing=kept.failing,
            noted=kept.noted,
            names=known,
            topics=topics,
        )


def _take_event(kept: _Kept, event: WatchEvent, robots: Mapping[str, str]) -> None:
    """An event of the watch: an expression error, a (re-)arm, a dict key's tag (its topic is shown too)."""
    if event.kind == "error" and event.expr is not None:
        kept.failing[event.agent] = f"expression error: {event.message}"
        kept.noted[event.agent] = event.message
    elif event.kind == "status" and event.state == "armed":
        kept.failing.pop(event.agent, None)
    elif event.kind == "tag" and event.expr is not None and event.expr >= 0:
        tag, _, kind = event.message.rpartition(" (")  # "watch/cfg/gain (std_msgs/msg/Float64)"
        robot = robots.get(event.agent)
        if robot is not None and kind.rstrip(")").rsplit("/", 1)[-1] in _SCALAR_TYPES:
            topic = topic_for_tag(tag, robot)
            if topic not in kept.topics:
                kept.topics.append(topic)


def _take_stats(kept: _Kept, agent: str, status: WatchStatus, exprs: int) -> None:
    """A process's counters: hits that gave values since the last look clear its expression error."""
    stats = status.stats
    before = kept.stats.get(agent)
    kept.stats[agent] = stats
    if not stats or before is None or agent not in kept.failing:
        return
    sent = stats.get("sent", 0) - before.get("sent", 0)
    errors = stats.get("errors", 0) - before.get("errors", 0)
    if sent > 0 and errors < sent * exprs:
        kept.failing.pop(agent, None)


def _process_name(process: Process) -> str:
    """How a report names a process: its name and pid (``loop.py (pid 4812)``, ``/talker (pid 12)``)."""
    return f"{process.name} (pid {process.pid})"
