"""The watchers' API: find watchable processes, read their source, arm and disarm watches (docs/watch.md).

``dbglog watch`` and the viewer's "Watch a variable…" dialog both use `WatchClient`. It has its own ROS
context and node (``dbglog_watcher_<pid>_<hex>``) and one thread that takes announcements, answers and
events; its methods may be called from any thread. `WatchClient.files`, `source` and `names` wait for the
process's answer (up to `timeout`): call them off a UI thread. `WatchClient.arm` returns at once; the
`Watch` then follows every watchable process, arming in each that has the line, re-arming in a process
that restarts, and reporting what happens as `WatchEvent` objects (poll `Watch.events`).

Example:
    >>> with WatchClient() as client:
    ...     procs = client.wait_for_processes()
    ...     print(client.source(procs[0], "controller.py", 42).lines)
    ...     watch = client.arm(WatchSpec("controller.py", 42, ("error", "self.gain")))
    ...     ...
    ...     watch.disarm()
"""

from __future__ import annotations

import contextlib
import os
import socket
import threading
import time
import uuid
from collections import deque
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any, Final, Self

from dbglog._ros._tags import topic_for_tag
from dbglog._ros._watch import agents_qos, is_agent_node, message_qos, watch_topics, watcher_node_name
from dbglog.watch._expr import ExprError, parse_expr
from dbglog.watch._protocol import (
    DEFAULT_MAX_CPU,
    MAX_CPU_LIMIT,
    MAX_EXPRESSIONS,
    MIN_CPU_LIMIT,
    ArmSpec,
    ProtocolError,
    dumps,
    loads,
)

__all__ = [
    "DEFAULT_MAX_CPU",
    "DISCOVERY_S",
    "ArmedWatch",
    "Names",
    "Process",
    "Sample",
    "Source",
    "Watch",
    "WatchClient",
    "WatchError",
    "WatchEvent",
    "WatchSpec",
    "WatchStatus",
]

DISCOVERY_S: Final = 2.0
"""Seconds after start within which the processes already running have been discovered (localhost)."""
RETRY_S: Final = 0.5
"""A request not answered within this is sent again (the first may go out before the process's
subscription is matched)."""
CLOSING_S: Final = 2.0
"""After a disarm, values of hits from before it are still taken for this long."""
FRESH_S: Final = 3.5
"""A process off the node graph counts as there while its last announcement (every 3 s) is this fresh."""
UNSEEN_S: Final = 7.0
"""A process announced but never seen on the node graph yet counts as there for this long after its
last announcement."""
_GRAPH_POLL_S: Final = 0.25
_TICK_S: Final = 0.05
_MAX_QUEUED: Final = 100_000
_UNCLAIMED_S: Final = 5.0
"""How long batches received while a process is still being asked are kept for the watch it arms: its
first hits' batch can arrive before its answer (two topics), and no watch claimed those values then."""
_UNCLAIMED_MAX: Final = 2_000


class WatchError(Exception):
    """A request that failed: the process is gone, did not answer, or refused (the message says why)."""

    def __init__(self, message: str, state: str = "refused") -> None:
        super().__init__(message)
        self.state = state
        """``no_file``, ``no_line``, ``expr_error``, ``refused``, ``gone`` or ``timeout``."""


@dataclass(frozen=True, slots=True)
class ArmedWatch:
    """A watch armed in a process, as its announcement lists it."""

    file: str
    line: int
    exprs: tuple[str, ...]
    when: str | None
    tags: tuple[str, ...]
    watchers: int


@dataclass(frozen=True, slots=True)
class Process:
    """A watchable process, from its announcement."""

    agent: str
    """The agent's id: one process run (a restarted program is a new process)."""
    node: str
    """The agent's node name (``dbglog_watch_<pid>_<hex>``)."""
    pid: int
    host: str
    program: tuple[str, ...]
    """Its ``sys.argv``."""
    executable: str
    python: str
    cwd: str
    nodes: tuple[str, ...]
    """The rclpy nodes an executor of it spins (fully qualified)."""
    backend: str
    watches: tuple[ArmedWatch, ...]
    robot: str = ""
    """The robot namespace of its tags (``""``: the root; ``/robot1``): a watch's tag ``watch/x`` is on
    ``topic_for_tag("watch/x", robot)``."""

    @property
    def name(self) -> str:
        """A short name: its first node, else its program."""
        if self.nodes:
            return self.nodes[0]
        for arg in self.program:
            if arg and not arg.startswith("-"):
                return os.path.basename(arg)
        return f"pid {self.pid}"

    def has_node(self, node: str) -> bool:
        """True when one of its nodes is `node` (with or without its namespace)."""
        want = node.strip()
        return any(n == want or n.rsplit("/", 1)[-1] == want.lstrip("/") for n in self.nodes)


@dataclass(frozen=True, slots=True)
class Source:
    """Lines of a file around a line, as the process reads it now."""

    path: str
    """The file's path in the process."""
    first: int
    """The number of `lines`' first line."""
    lines: tuple[str, ...]
    total: int
    """Lines in the file."""


@dataclass(frozen=True, slots=True)
class Names:
    """The names an expression at a line can read."""

    path: str
    locals: tuple[str, ...]
    """The innermost function's locals (arguments, cell and free variables included)."""
    globals: tuple[str, ...]
    """The module's global names."""


@dataclass(frozen=True, slots=True)
class WatchSpec:
    """What to watch: a line and expressions, with options.

    Args:
        file: a path, or a unique suffix of one, as the process loaded it (``node.py``, ``pkg/node.py``).
        line: the line number; values are read before the line runs.
        exprs: the expressions (docs/watch.md, *Expressions*).
        when: publish only the hits where this expression is true.
        throttle: at most one published hit per this many seconds; None: every hit up to 1 kHz; 0: every
            hit, uncapped.
        count: each process stops after this many published hits.
        label: the tag is ``watch/<label>`` (``watch/<label>/<expr>`` with several expressions); by
            default ``watch/<expr as a path>``.
        node: only processes with an rclpy node of this name.
        max_cpu: the share of one CPU above which a watch disarms itself.
    """

    file: str
    line: int
    exprs: tuple[str, ...]
    when: str | None = None
    throttle: float | None = None
    count: int | None = None
    label: str | None = None
    node: str | None = None
    max_cpu: float = DEFAULT_MAX_CPU

    def check(self) -> None:
        """Check the spec here, before any process sees it.

        Raises:
            WatchError: a field is out of range or an expression is not allowed (``expr_error``).
        """
        if not self.exprs or len(self.exprs) > MAX_EXPRESSIONS:
            raise WatchError(f"give 1 to {MAX_EXPRESSIONS} expressions")
        if not self.file.strip():
            raise WatchError("the file is empty")
        if self.line < 1:
            raise WatchError("the line must be 1 or more")
        if self.throttle is not None and not 0 <= self.throttle <= 3600:
            raise WatchError("the throttle must be between 0 and 3600 seconds")
        if self.count is not None and self.count < 1:
            raise WatchError("the count must be 1 or more")
        if not MIN_CPU_LIMIT <= self.max_cpu <= MAX_CPU_LIMIT:
            raise WatchError(f"the CPU share must be between {MIN_CPU_LIMIT:.1%} and {MAX_CPU_LIMIT:.0%}")
        for text in (*self.exprs, *((self.when,) if self.when else ())):
            try:
                parse_expr(text)
            except ExprError as exc:
                raise WatchError(f"{text!r} is not allowed: {exc}", "expr_error") from None

    def arm_spec(self) -> ArmSpec:
        """The request's fields (with this machine's absolute path of `file` when it exists here)."""
        local = os.path.abspath(self.file) if os.path.exists(self.file) else None
        return ArmSpec(
            file=self.file,
            line=self.line,
            exprs=tuple(self.exprs),
            when=self.when,
            throttle=self.throttle,
            count=self.count,
            label=self.label,
            max_cpu=self.max_cpu,
            local_path=local,
        )


@dataclass(frozen=True, slots=True)
class WatchStatus:
    """A watch's state in one process."""

    agent: str
    pid: int
    host: str
    state: str
    """``asking`` (no answer yet), ``armed``, ``no_file``, ``no_line``, ``expr_error``, ``refused``,
    ``cpu`` (disarmed by the CPU rule), ``done`` (its count reached), ``disarmed``, ``gone``."""
    message: str = ""
    path: str = ""
    tags: tuple[str, ...] = ()
    armed_at: int = 0
    """When it was armed, in the process's clock (ns since the epoch)."""
    stats: dict[str, int] = field(default_factory=dict)
    """hits, sent, filtered (``--when`` false), throttled, dropped, errors."""


@dataclass(frozen=True, slots=True)
class WatchEvent:
    """Something that happened to a watch in one process."""

    agent: str
    pid: int
    host: str
    kind: str
    """``status`` (a new state: armed, not armed, ended, gone), ``error`` (an expression could not be read
    at a hit; the watch stays armed) or ``tag`` (an expression's tag and type, at its first value)."""
    state: str
    """The watch's state in that process after the event."""
    message: str = ""
    expr: int | None = None
    """The expression's index (-1: the ``--when`` condition), for ``error`` and ``tag``."""


@dataclass(frozen=True, slots=True)
class Sample:
    """One expression's value at one hit (`WatchClient` with ``values=True``)."""

    agent: str
    pid: int
    expr: int
    """The expression's index in the spec."""
    key: str
    """For a dict value, the key path below the expression's tag (``a/b``); else ``""``."""
    value: object
    """A float, bool, str, or a tuple of numbers (arrays)."""
    stamp_ns: int
    """When the line ran (the process's clock, ns since the epoch): the samples of one hit share it."""


class _Armed:
    """A watch's dealings with one process (client thread)."""

    __slots__ = ("asked_at", "request", "robot", "status", "tags", "writer")

    def __init__(self, status: WatchStatus) -> None:
        self.status = status
        self.robot = ""
        """The robot namespace of the process's tags."""
        self.request = ""
        self.asked_at = 0.0
        self.tags: dict[int, str] = {}
        self.writer: int | None = None


class Watch:
    """One watch, followed across every watchable process (returned by `WatchClient.arm`)."""

    def __init__(self, client: WatchClient, spec: WatchSpec) -> None:
        self.client = client
        self.spec = spec
        self.id = uuid.uuid4().hex[:16]
        self._arm = spec.arm_spec()
        self._per: dict[str, _Armed] = {}
        self._events: deque[WatchEvent] = deque(maxlen=_MAX_QUEUED)
        self._samples: deque[Sample] = deque(maxlen=_MAX_QUEUED)
        self.disarmed = False

    def status(self) -> dict[str, WatchStatus]:
        """The watch's state in each process it was sent to, by agent id."""
        with self.client._lock:
            return {agent: armed.status for agent, armed in self._per.items()}

    @property
    def armed(self) -> list[WatchStatus]:
        """The processes where it is armed now."""
        return [s for s in self.status().values() if s.state == "armed"]

    def events(self) -> list[WatchEvent]:
        """The events since the last call, oldest first."""
        with self.client._lock:
            out = list(self._events)
            self._events.clear()
        return out

    def samples(self) -> list[Sample]:
        """The values received since the last call, in hit order per process (``values=True`` only)."""
        with self.client._lock:
            out = list(self._samples)
            self._samples.clear()
        return out

    def disarm(self, timeout: float = 2.0) -> None:
        """Remove the watch from every process (waits up to `timeout` for their answers; idempotent)."""
        self.client._disarm(self, timeout)

    def tags(self) -> dict[str, tuple[str, ...]]:
        """Each armed process's tag per expression (``watch/<label>``), by agent id."""
        with self.client._lock:
            return {
                agent: tuple(armed.tags.get(i, "") for i in range(len(self.spec.exprs)))
                for agent, armed in self._per.items()
                if armed.status.state == "armed"
            }


class _Pending:
    __slots__ = ("agent", "answer", "done", "req_id", "text")

    def __init__(self, agent: str, req_id: str, text: str) -> None:
        self.agent = agent
        self.req_id = req_id
        self.text = text
        self.done = threading.Event()
        self.answer: dict[str, Any] | None = None


class WatchClient:
    """A watcher: its own ROS node and thread (see the module docstring).

    Args:
        values: also receive the watched values (`Watch.samples`), as ``dbglog watch`` prints them; the
            viewer reads them as tags instead.
    """

    def __init__(self, *, values: bool = False) -> None:
        from std_msgs.msg import String

        from dbglog._ros._node import PrivateNode

        self._string = String
        self.node_name = watcher_node_name()
        self._ros = PrivateNode(self.node_name)
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self._started = time.monotonic()
        self._announced: dict[str, tuple[Process, float]] = {}
        """agent id -> (its latest announcement, when it came)."""
        self._on_graph: set[str] = set()
        self._seen_on_graph: set[str] = set()
        self._pending: dict[str, _Pending] = {}
        self._watches: dict[str, Watch] = {}
        self._closing: dict[str, tuple[Watch, float]] = {}
        """Watches disarmed less than `CLOSING_S` ago: their last values are still taken."""
        self._array_subs: dict[tuple[str, str], Any] = {}
        """(robot, tag) -> the subscription of an array tag's topic (``values=True``)."""
        self._batch_subs: dict[str, Any] = {}
        """robot namespace -> the subscription of its batch topic (``values=True``)."""
        self._unclaimed: deque[tuple[float, str, Any]] = deque(maxlen=_UNCLAIMED_MAX)
        """(when, robot, decoded batch) received while some process was still being asked to arm."""
        self._values = values
        topics = watch_topics()
        try:
            node = self._ros.node
            self._requests = node.create_publisher(String, topics.requests, message_qos())
            self._subs: list[tuple[Any, Any, str]] = [
                (
                    node.create_subscription(String, topics.agents, _no_callback, agents_qos()),
                    String,
                    "agents",
                ),
                (
                    node.create_subscription(String, topics.answers, _no_callback, message_qos()),
                    String,
                    "answers",
                ),
            ]
            self._wake = self._ros.guard()
        except Exception:
            self._ros.close()
            raise
        try:
            self._follow_robot("")  # the root's batch now: its writers are matched before the first watch
        except Exception:
            self._ros.close()
            raise
        self._thread = threading.Thread(target=self._run, name="dbglog-watcher", daemon=True)
        self._thread.start()

    # ----- processes and queries ----------------------------------------------------------------------

    def processes(self) -> list[Process]:
        """The watchable processes known now (announced and on the graph), by host and pid."""
        with self._lock:
            return sorted(
                (p for agent, (p, _) in self._announced.items() if self._alive(agent)),
                key=lambda p: (p.host, p.pid),
            )

    def wait_for_processes(self, seconds: float = DISCOVERY_S) -> list[Process]:
        """Wait until this client has been up `seconds` (discovery of running processes), then list them."""
        remaining = self._started + seconds - time.monotonic()
        if remaining > 0:
            self._stop.wait(remaining)
        return self.processes()

    def discovering(self) -> bool:
        """True while a watchable process's node is on the graph but its announcement has not come yet."""
        with self._lock:
            announced = {process.node for process, _since in self._announced.values()}
            return bool(self._on_graph - announced)

    def files(self, process: Process | str, *, everything: bool = False, timeout: float = 5.0) -> list[str]:
        """The source files `process` has loaded: those of the user's tree, or all with `everything`.

        Raises:
            WatchError: the process did not answer within `timeout`, or is gone.
        """
        answer = self._ask(process, "files", {"all": everything}, timeout)
        return [str(f) for f in answer.get("files", [])]

    def source(
        self, process: Process | str, file: str, line: int, *, context: int = 10, timeout: float = 5.0
    ) -> Source:
        """Lines ``line - context`` to ``line + context`` of `file` as the process reads it now.

        Raises:
            WatchError: no such file in the process (``no_file``), no answer, or the process is gone.
        """
        answer = self._ask(process, "source", _file_fields(file, line, context=context), timeout)
        return Source(
            str(answer["path"]), int(answer["first"]), tuple(map(str, answer["lines"])), int(answer["total"])
        )

    def names(self, process: Process | str, file: str, line: int, *, timeout: float = 5.0) -> Names:
        """The local and global names an expression at `line` can read (for completion).

        Raises:
            WatchError: no such file or line (``no_file``, ``no_line``), no answer, or the process is gone.
        """
        answer = self._ask(process, "names", _file_fields(file, line), timeout)
        return Names(str(answer["path"]), tuple(answer["locals"]), tuple(answer["globals"]))

    # ----- watches ------------------------------------------------------------------------------------

    def arm(self, spec: WatchSpec) -> Watch:
        """Arm a watch in every watchable process that has the line, now and as processes (re)start.

        Raises:
            WatchError: the spec is invalid or an expression is not allowed (checked here first).
        """
        spec.check()
        watch = Watch(self, spec)
        with self._lock:
            self._watches[watch.id] = watch
        self._wake.trigger()
        return watch

    def _disarm(self, watch: Watch, timeout: float) -> None:
        with self._lock:
            if watch.disarmed:
                return
            watch.disarmed = True
            self._watches.pop(watch.id, None)
            # Its last hits may still be on their way (the batch and the answer are different topics).
            self._closing[watch.id] = (watch, time.monotonic() + CLOSING_S)
            targets = [
                agent
                for agent, armed in watch._per.items()
                if armed.status.state in ("armed", "asking") and self._alive(agent)
            ]
        pendings = [self._send(agent, "disarm", {"watch": watch.id}) for agent in targets]
        deadline = time.monotonic() + timeout
        answers: dict[str, dict[str, Any]] = {}
        for pending in pendings:
            with contextlib.suppress(WatchError):
                answers[pending.agent] = self._wait(pending, deadline)
        with self._lock:
            for agent in targets:
                armed = watch._per[agent]
                stats = answers.get(agent, {}).get("stats")
                if isinstance(stats, dict):
                    armed.status = _replace(
                        armed.status, stats={k: int(v) for k, v in stats.items() if k in _STATS}
                    )
                if armed.status.state in ("armed", "asking"):
                    armed.status = _replace(armed.status, state="disarmed")

    def close(self) -> None:
        """Disarm every watch, stop the thread, destroy the node (idempotent)."""
        if self._stop.is_set():
            return
        for watch in list(self._watches.values()):
            with contextlib.suppress(Exception):
                watch.disarm(timeout=1.0)
        self._stop.set()
        self._wake.trigger()
        self._thread.join(timeout=5.0)
        self._ros.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    # ----- requests -----------------------------------------------------------------------------------

    def _agent_of(self, process: Process | str) -> str:
        return process.agent if isinstance(process, Process) else process

    def _send(self, agent: str, op: str, fields: dict[str, Any]) -> _Pending:
        with self._lock:
            pending = self._pending[self._send_locked(agent, op, fields)]
        self._publish(pending.text)
        return pending

    def _publish(self, text: str) -> None:
        with contextlib.suppress(Exception):  # the context is going away
            self._requests.publish(self._string(data=text))

    def _wait(self, pending: _Pending, deadline: float) -> dict[str, Any]:
        while True:
            if pending.done.wait(min(RETRY_S, max(0.0, deadline - time.monotonic()))):
                assert pending.answer is not None
                return pending.answer
            with self._lock:
                gone = pending.agent in self._announced and not self._alive(pending.agent)
                if gone or time.monotonic() >= deadline:
                    self._pending.pop(pending.req_id, None)
            if gone:
                raise WatchError("the process is gone", "gone")
            if time.monotonic() >= deadline:
                raise WatchError("the process did not answer in time", "timeout")
            self._publish(pending.text)

    def _ask(self, process: Process | str, op: str, fields: dict[str, Any], timeout: float) -> dict[str, Any]:
        pending = self._send(self._agent_of(process), op, fields)
        answer = self._wait(pending, time.monotonic() + timeout)
        if not answer.get("ok", False):
            raise WatchError(str(answer.get("error", "refused")), str(answer.get("state", "refused")))
        return answer

    # ----- the client's thread ------------------------------------------------------------------------

    def _alive(self, agent: str) -> bool:
        """On the node graph, or announced lately (the graph learns a node's name later than its data,
        more so on a busy machine); gone once off the graph and not announced for a while."""
        entry = self._announced.get(agent)
        if entry is None:
            return False
        process, since = entry
        quiet = time.monotonic() - since
        if process.node in self._on_graph:
            # A killed process's node stays on the graph until the middleware's lease ends (~20 s); one
            # of this host that stopped announcing itself and whose pid is not running is gone now.
            return quiet < FRESH_S or not _exited_here(process)
        if process.node in self._seen_on_graph:
            return quiet < FRESH_S  # it left the graph: gone unless it still announces itself
        return quiet < UNSEEN_S

    def _run(self) -> None:
        from dbglog._ros._node import WaitSet

        wait_set = WaitSet(self._ros, self._wake)
        last_graph = 0.0
        while not self._stop.is_set():
            subs = [sub for sub, _cls, _kind in self._subs]
            subs += [*self._batch_subs.values(), *self._array_subs.values()]
            try:
                wait_set.wait(subs, int(_TICK_S * 1e9))
            except Exception:
                if not self._ros.ok():
                    return
                wait_set.reset()
            if self._stop.is_set():
                return
            try:
                self._take()
                now = time.monotonic()
                if now - last_graph >= _GRAPH_POLL_S:
                    last_graph = now
                    self._poll_graph()
                self._manage(now)
            except Exception:  # noqa: S110  (the client's thread survives a bad message or a graph hiccup)
                pass

    def _take(self) -> None:
        for sub, cls, kind in self._subs:
            for _ in range(256):
                got = sub.handle.take_message(cls, False)
                if got is None:
                    break
                self._on_message(kind, got[0].data)
        for robot, sub in list(self._batch_subs.items()):
            for _ in range(256):
                got = sub.handle.take_message(sub.msg_type, True)
                if got is None:
                    break
                self._on_batch(got[0], robot)
        for (robot, tag), sub in list(self._array_subs.items()):
            for _ in range(256):
                got = sub.handle.take_message(sub.msg_type, False)
                if got is None:
                    break
                self._on_array(robot, tag, got[0], int(got[1].get("source_timestamp", 0)))

    def _follow_writer(self, armed: _Armed, message: dict[str, Any]) -> None:
        """Take a process's current batch writer and robot namespace from its announcement (lock held)."""
        writer, robot = message.get("writer"), message.get("robot")
        if isinstance(writer, int):
            armed.writer = writer
        if isinstance(robot, str) and robot != armed.robot:
            armed.robot = robot
            self._follow_robot(robot)

    def _follow_robot(self, robot: object) -> None:
        """Subscribe to a robot namespace's batch topic, where its processes' values go (``values=True``)."""
        if not self._values or not isinstance(robot, str) or robot in self._batch_subs:
            return
        from std_msgs.msg import UInt8MultiArray

        from dbglog._ros._batch import batch_topic
        from dbglog._ros._qos import batch_qos

        self._batch_subs[robot] = self._ros.node.create_subscription(
            UInt8MultiArray, batch_topic(robot), _no_callback, batch_qos(), raw=True
        )

    def _poll_graph(self) -> None:
        names = {name for name, _ns in self._ros.node.get_node_names_and_namespaces() if is_agent_node(name)}
        with self._lock:
            self._on_graph = names
            self._seen_on_graph |= names

    def _on_message(self, kind: str, text: str) -> None:
        try:
            message = loads(text)
        except ProtocolError:
            return
        if kind == "agents":
            self._on_announcement(message)
        elif "reply_to" in message:
            self._on_answer(message)
        elif message.get("client") == self.node_name and "event" in message:
            self._on_event(message)

    def _on_announcement(self, message: dict[str, Any]) -> None:
        try:
            process = _process(message)
        except (KeyError, TypeError, ValueError):
            return
        with self._lock:
            self._announced[process.agent] = (process, time.monotonic())
            self._follow_robot(message.get("robot"))
            self._reconcile(process, message)

    def _reconcile(self, process: Process, message: dict[str, Any]) -> None:
        """Take a watch of ours the announcement lists as armed when its status never came (lock held)."""
        listed = message.get("watches", [])
        for entry in listed if isinstance(listed, list) else []:
            if not isinstance(entry, dict) or not isinstance(entry.get("ids"), list):
                continue
            for watch_id in entry["ids"]:
                watch = self._watches.get(str(watch_id))
                armed = None if watch is None else watch._per.get(process.agent)
                if watch is None or armed is None:
                    continue
                if armed.status.state == "armed":  # the program may have reconnected its SDK (dbglog.init)
                    self._follow_writer(armed, message)
                    continue
                if armed.status.state not in ("asking", "no_file", "no_line"):
                    continue
                fields = {
                    "state": "armed",
                    "tags": entry.get("tags", []),
                    "path": entry.get("file", ""),
                    "armed_at": entry.get("armed_at", 0),
                    "writer": message.get("writer"),
                    "robot": message.get("robot"),
                }
                self._apply_arm(watch, armed, fields)

    def _on_answer(self, message: dict[str, Any]) -> None:
        with self._lock:
            pending = self._pending.pop(str(message.get("reply_to")), None)
            if message.get("op") == "arm" and message.get("client") == self.node_name:
                self._on_arm_answer(message)
        if pending is not None:
            pending.answer = message
            pending.done.set()

    def _on_arm_answer(self, message: dict[str, Any]) -> None:
        watch = self._watches.get(str(message.get("watch", "")))
        agent = str(message.get("agent"))
        if watch is None:  # an answer to a retry, or for a watch disarmed meanwhile
            for w in self._watches.values():
                armed = w._per.get(agent)
                if armed is not None and armed.request == message.get("reply_to"):
                    watch = w
                    break
        if watch is None:
            return
        armed = watch._per.get(agent)
        if armed is None or armed.status.state != "asking":
            return
        self._apply_arm(watch, armed, message)

    def _apply_arm(self, watch: Watch, armed: _Armed, message: dict[str, Any]) -> None:
        """Take an arm answer (or the event of a pending request armed later): state, tags, writer."""
        state = str(message.get("state", "refused"))
        tags = tuple(str(t) for t in message.get("tags", []))
        if tags:
            armed.tags = dict(enumerate(tags))
        writer = message.get("writer")
        if isinstance(writer, int):
            armed.writer = writer
        robot = message.get("robot")
        if isinstance(robot, str):
            armed.robot = robot
            self._follow_robot(robot)
        if state == "armed":
            text = ", ".join(map(str, message.get("codes", [])))
        else:
            text = str(message.get("error", ""))
            if message.get("pending"):
                text += " (armed once it is loaded)"
        was_taking = armed.status.state in _TAKING
        armed.status = _replace(
            armed.status,
            state=state,
            message=text,
            path=str(message.get("path", armed.status.path)),
            tags=tags or armed.status.tags,
            armed_at=int(message.get("armed_at", 0) or armed.status.armed_at),
        )
        if state == "armed" and not was_taking:
            self._claim_unclaimed(watch, armed)
        status = armed.status
        watch._events.append(WatchEvent(status.agent, status.pid, status.host, "status", state, text))
        skipped = message.get("skipped_threads")
        if skipped:
            text = f"threads traced by another tool are not watched: {', '.join(map(str, skipped))}"
            watch._events.append(WatchEvent(status.agent, status.pid, status.host, "error", state, text))

    def _on_event(self, message: dict[str, Any]) -> None:
        with self._lock:
            watch = self._watches.get(str(message.get("watch")))
            if watch is None:
                return
            agent = str(message.get("agent"))
            armed = watch._per.get(agent)
            if armed is None:
                return
            kind = str(message.get("event"))
            status = armed.status
            expr = message.get("expr")
            index = int(expr) if isinstance(expr, int) else None
            if kind == "stats":
                stats = {k: int(v) for k, v in message.items() if k in _STATS and isinstance(v, int)}
                armed.status = _replace(status, stats=stats)
                return
            if kind == "status" and message.get("state") == "armed":
                self._apply_arm(watch, armed, message)
                return
            if kind == "status":
                armed.status = status = _replace(
                    status, state=str(message.get("state")), message=str(message.get("message", ""))
                )
            elif kind == "tag" and index is not None:
                tag = str(message.get("tag", ""))
                if index >= 0 and tag and not tag.startswith(armed.tags.get(index, "\0") + "/"):
                    armed.tags[index] = armed.tags.get(index, tag)
                self._follow_array(armed.robot, tag, str(message.get("type", "")))
                text = f"{tag} ({message.get('type')})"
                watch._events.append(
                    WatchEvent(status.agent, status.pid, status.host, "tag", status.state, text, index)
                )
                return
            watch._events.append(
                WatchEvent(
                    status.agent,
                    status.pid,
                    status.host,
                    kind,
                    status.state,
                    str(message.get("message", "")),
                    index,
                )
            )

    def _follow_array(self, robot: str, tag: str, type_name: str) -> None:
        """Subscribe to an array tag's topic (arrays are not in the batch)."""
        key = (robot, tag)
        if not self._values or key in self._array_subs or not type_name.startswith("std_msgs/msg/"):
            return
        if not type_name.endswith("MultiArray"):
            return
        from dbglog._ros._qos import tag_qos
        from dbglog._ros._types import TypeGateError, message_class

        try:
            cls = message_class(type_name)
        except TypeGateError:
            return
        self._array_subs[key] = self._ros.node.create_subscription(
            cls, topic_for_tag(tag, robot), _no_callback, tag_qos()
        )

    # ----- values -------------------------------------------------------------------------------------

    def _owners(self, robot: str, tag: str, writer: int | None) -> list[tuple[Watch, _Armed, int, str]]:
        """The (watch, process, expression, key) that `tag` of `robot`'s namespace belongs to (lock held).

        When several processes publish the tag, the batch's writer tells which one sent it (a process
        that reconnected its SDK has a new writer: then every owner gets it).
        """
        out: list[tuple[Watch, _Armed, int, str]] = []
        closing = [w for w, _until in self._closing.values()]
        for watch in [*self._watches.values(), *closing]:
            for armed in watch._per.values():
                if armed.status.state not in _TAKING or armed.robot != robot:
                    continue
                out.extend((watch, armed, index, key) for index, key in _claims(armed, tag))
        if writer is not None and len({armed.status.agent for _w, armed, _i, _k in out}) > 1:
            mine = [o for o in out if o[1].writer == writer]
            return mine or out
        return out

    def _on_batch(self, raw: bytes, robot: str) -> None:
        from dbglog._ros._batch import BatchError, decode_batch

        with self._lock:
            if not self._watches and not self._closing:
                return
        try:
            batch = decode_batch(raw)
        except BatchError:
            return
        got: list[tuple[Watch, Sample]] = []
        with self._lock:
            if any(a.status.state == "asking" for w in self._watches.values() for a in w._per.values()):
                now = time.monotonic()
                unclaimed = self._unclaimed
                while unclaimed and now - unclaimed[0][0] > _UNCLAIMED_S:
                    unclaimed.popleft()
                unclaimed.append((now, robot, batch))
            for samples in batch.tags:
                for watch, armed, index, key in self._owners(robot, samples.tag, batch.writer):
                    got.extend((watch, sample) for sample in _armed_samples(armed, index, key, samples))
            got.sort(key=lambda item: (item[1].agent, item[1].stamp_ns, item[1].expr, item[1].key))
            for watch, sample in got:
                watch._samples.append(sample)

    def _claim_unclaimed(self, watch: Watch, armed: _Armed) -> None:
        """Give a process that just armed `watch` its values from the batches received while it was being
        asked (lock held): no watch claimed them then, so none of them was given to this one."""
        now = time.monotonic()
        several = len({a.status.agent for a in watch._per.values()}) > 1
        got: list[Sample] = []
        for when, robot, batch in self._unclaimed:
            if robot != armed.robot or now - when > _UNCLAIMED_S:
                continue
            if several and armed.writer is not None and batch.writer != armed.writer:
                continue  # another process's batch (several publish the tag)
            for samples in batch.tags:
                for index, key in _claims(armed, samples.tag):
                    got.extend(_armed_samples(armed, index, key, samples))
        got.sort(key=lambda sample: (sample.stamp_ns, sample.expr, sample.key))
        watch._samples.extend(got)

    def _on_array(self, robot: str, tag: str, msg: Any, stamp: int) -> None:
        with self._lock:
            for watch, armed, index, key in self._owners(robot, tag, None):
                status = armed.status
                if stamp >= status.armed_at:
                    value = tuple(msg.data.tolist() if hasattr(msg.data, "tolist") else msg.data)
                    watch._samples.append(Sample(status.agent, status.pid, index, key, value, stamp))

    # ----- following processes ------------------------------------------------------------------------

    def _manage(self, now: float) -> None:
        """Arm each watch in each process not asked yet; repeat unanswered requests; say who is gone."""
        sends: list[str] = []
        with self._lock:
            for watch_id, (_watch, until) in list(self._closing.items()):
                if now > until:
                    del self._closing[watch_id]
            for watch in list(self._watches.values()):
                for agent, (process, _since) in list(self._announced.items()):
                    alive = self._alive(agent)
                    armed = watch._per.get(agent)
                    if armed is None:
                        if not alive or (watch.spec.node and not process.has_node(watch.spec.node)):
                            continue
                        armed = watch._per[agent] = _Armed(
                            WatchStatus(agent, process.pid, process.host, "asking")
                        )
                        pending = self._send_locked(agent, "arm", {"watch": watch.id, **watch._arm.to_json()})
                        armed.request, armed.asked_at = pending, now
                        sends.append(self._pending[pending].text)
                        continue
                    state = armed.status.state
                    if not alive and state not in ("gone", "disarmed"):
                        self._pending.pop(armed.request, None)
                        armed.status = _replace(armed.status, state="gone", message="the process exited")
                        watch._events.append(
                            WatchEvent(
                                agent, process.pid, process.host, "status", "gone", "the process exited"
                            )
                        )
                    elif state == "asking" and now - armed.asked_at >= RETRY_S:
                        pending_obj = self._pending.get(armed.request)
                        if pending_obj is not None:
                            armed.asked_at = now
                            sends.append(pending_obj.text)
        for text in sends:
            self._publish(text)

    def _send_locked(self, agent: str, op: str, fields: dict[str, Any]) -> str:
        req_id = uuid.uuid4().hex[:16]
        text = dumps({"op": op, "id": req_id, "client": self.node_name, "to": agent, **fields})
        self._pending[req_id] = _Pending(agent, req_id, text)
        return req_id


_STATS: Final = frozenset({"hits", "sent", "filtered", "throttled", "dropped", "errors"})
_TAKING: Final = frozenset({"armed", "done", "cpu", "disarmed"})
"""The states of a process whose values a watch takes."""


def _claims(armed: _Armed, tag: str) -> list[tuple[int, str]]:
    """The (expression, key) of a process's watch that `tag` carries: its tag, or a key under it."""
    out = []
    for index, base in armed.tags.items():
        if tag == base:
            out.append((index, ""))
        elif tag.startswith(base + "/"):
            out.append((index, tag[len(base) + 1 :]))
    return out


def _armed_samples(armed: _Armed, index: int, key: str, samples: Any) -> list[Sample]:
    """A batch's samples of one tag (`TagSamples`) as expression `index`'s values (under `key`), those
    since the process armed the watch."""
    status = armed.status
    values = samples.values if isinstance(samples.values, list) else samples.values.tolist()
    return [
        Sample(status.agent, status.pid, index, key, value, stamp)
        for stamp, value in zip(samples.times_ns.tolist(), values, strict=True)
        if stamp >= status.armed_at
    ]


def _no_callback(_msg: object) -> None:
    """Subscription callback that never runs: the client's thread takes messages itself."""


def _exited_here(process: Process) -> bool:
    """Whether `process` ran on this host and its pid is no longer running (another pid namespace under
    the same host name reads as exited too: the caller asks only of a process that stopped announcing)."""
    if process.host != socket.gethostname():
        return False
    try:
        os.kill(process.pid, 0)
    except ProcessLookupError:
        return True
    except OSError:  # running, as another user's
        return False
    return False


def _replace(status: WatchStatus, **changes: Any) -> WatchStatus:
    import dataclasses

    return dataclasses.replace(status, **changes)


def _file_fields(file: str, line: int, **more: Any) -> dict[str, Any]:
    local = os.path.abspath(file) if os.path.exists(file) else None
    return {"file": file, "line": int(line), "local_path": local, **more}


def _strings(value: object) -> tuple[str, ...]:
    if not isinstance(value, list):
        return ()
    return tuple(str(v) for v in value)


def _process(message: dict[str, Any]) -> Process:
    watches: list[ArmedWatch] = []
    for w in message.get("watches", []):
        if isinstance(w, dict):
            watches.append(
                ArmedWatch(
                    str(w.get("file", "")),
                    int(w.get("line", 0)),
                    _strings(w.get("exprs")),
                    None if w.get("when") is None else str(w.get("when")),
                    _strings(w.get("tags")),
                    int(w.get("watchers", 0)),
                )
            )
    return Process(
        agent=str(message["agent"]),
        node=str(message["node"]),
        pid=int(message["pid"]),
        host=str(message.get("host", "")),
        program=_strings(message.get("program")),
        executable=str(message.get("executable", "")),
        python=str(message.get("python", "")),
        cwd=str(message.get("cwd", "")),
        nodes=_strings(message.get("nodes")),
        backend=str(message.get("backend", "")),
        watches=tuple(watches),
        robot=str(message.get("robot") or ""),
    )
