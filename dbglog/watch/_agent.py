"""The watch agent: what makes a Python process watchable (``DBGLOG_WATCH=1`` or ``dbglog run``).

It runs on a daemon thread of its own with a private ROS node (``dbglog_watch_<pid>_<hex>``): it announces
the process (transient-local, so a watcher started later sees it), takes the requests addressed to it
(list files, read source lines, list names, arm, disarm), logs each request and answer once, and reports
on its watches (errors, counts, the CPU rule). A hit runs in the program's thread, in the back end's
callback (`dbglog.watch._monitor`): it reads the values (`dbglog.watch._expr`), copies them
(`dbglog.watch._values`) and queues them on the SDK's queue; the SDK's publisher thread publishes them,
and anything that needs a publisher created or a message built goes there too (`dbglog.api.feed`).
"""

from __future__ import annotations

import atexit
import collections
import contextlib
import logging
import os
import re
import socket
import sys
import threading
import time
import types
import uuid
from typing import Any, Final

from dbglog._ros._tags import tag_problem
from dbglog._ros._watch import agent_node_name, agents_qos, message_qos, watch_topics
from dbglog.watch._code import (
    CodeLookupError,
    find_file,
    loaded_files,
    locate,
    names_at,
    read_source,
    user_file,
)
from dbglog.watch._expr import EvalError, Expr, ExprError, parse_expr
from dbglog.watch._monitor import Backend, BackendError, new_backend
from dbglog.watch._protocol import ArmSpec, ProtocolError, dumps, loads, number_field, text_field
from dbglog.watch._values import Kind, freeze, kind_name

__all__ = ["Agent", "Watch", "agent", "label_for", "start"]

_log = logging.getLogger("dbglog.watch")

TAG_ROOT: Final = "watch"
"""Watch tags are ``watch/<label>``."""
RATE_HZ: Final = 1000.0
"""Without ``--throttle`` a watch sends at most this many hits a second (bursts of `BURST` pass)."""
BURST: Final = 100
CPU_WINDOW_NS: Final = 1_000_000_000
"""The CPU share is measured over windows this long."""
CLIENT_GONE_S: Final = 5.0
"""A watcher whose node has not been on the graph for this long (killed) loses its watches."""
_TICK_S: Final = 0.25
_PENDING_S: Final = 1.0
"""How often a request whose file or line is not loaded yet is tried again (while its watcher lives)."""
_IDLE_TICK_S: Final = 1.0
_STATS_S: Final = 1.0
_NODES_S: Final = 2.0
ANNOUNCE_S: Final = 3.0
"""The announcement is sent again this often: a watcher that missed it (discovery races) sees the
process within this, and learns of a watch armed for it whose status event it missed."""
_ANSWERS_KEPT: Final = 256
_NOTES_PER_WATCH: Final = 32
_MAX_SOURCE_CONTEXT: Final = 200
_STD: Final[dict[str, str]] = {"int": "Int64", "float": "Float64", "bool": "Bool", "text": "String"}


_NOT_NAME = re.compile(r"[^A-Za-z0-9_/]+")
_UNDERSCORES = re.compile(r"_{2,}")
_SLASHES = re.compile(r"/{2,}")


def plain_name(text: str) -> str:
    """Map text to a plain tag name (its own topic name, nothing escaped): ``a-b`` -> ``a_b``, a part
    starting with a digit gets ``_`` (``0`` -> ``_0``). Readable rather than reversible: the SDK's own
    escaping (`dbglog._ros._tags.escape_tag`) would warn in the watched program for every such tag."""
    name = _SLASHES.sub("/", _UNDERSCORES.sub("_", _NOT_NAME.sub("_", text))).strip("/")
    parts = [("_" + p if p[:1].isdigit() else p) for p in name.split("/") if p]
    return _UNDERSCORES.sub("_", "/".join(parts)) or "_"


def label_for(text: str) -> str:
    """Return the default label of an expression: its path as a tag (``self.pose.x`` -> ``self/pose/x``)."""
    path = text.replace("]", "").replace("[", "/").replace(".", "/").replace('"', "").replace("'", "")
    return plain_name("".join(path.split()))


# ---------------------------------------------------------------------------------------------------------
# Publishing one expression's values (publisher thread, but for the fast path).


class _Sink:
    """One tag a watch expression publishes on: its kind (fixed by its first value) and channel."""

    __slots__ = ("channel", "children", "expr", "kind", "reported", "tag")

    def __init__(self, expr: _Expression, tag: str) -> None:
        self.expr = expr
        self.tag = tag
        self.kind: Kind | None = None
        self.channel: Any = None
        """The scalar channel once created: the program's thread then queues values on it directly."""
        self.children: dict[str, _Sink] = {}
        self.reported = False

    def publish(self, kind: Kind, value: Any, stamp: int) -> None:
        """Publish one frozen value (publisher thread)."""
        from dbglog.api import feed

        if self.kind is None:
            self.kind = kind
        if kind != self.kind:
            if self.kind == "float" and kind in ("int", "bool"):
                kind, value = "float", float(value)
            elif self.kind == "int" and kind == "bool":
                kind, value = "int", int(value)
            elif self.kind == "int" and kind == "float":  # 0, then 0.5: its floats go on a Float64 tag
                old = self.tag
                self.kind, self.channel, self.reported = "float", None, False
                self.tag = f"{old}_float"
                self.expr.note(
                    f"{self.expr.text} holds a float now: its values go on {self.tag} (Float64) "
                    f"from here, {old} kept its integers"
                )
            else:
                self.expr.note(
                    f"{self.expr.text} is now {kind_name(kind)}; its tag {self.tag} carries "
                    f"{kind_name(self.kind)} (its first value): not sent"
                )
                return
        if kind == "dict":
            for key, (sub_kind, sub_value) in value.items():
                child = self.children.get(key)
                if child is None:
                    if len(self.children) >= 256:
                        continue
                    child = self.children[key] = _Sink(self.expr, f"{self.tag}/{plain_name(key)}")
                child.publish(sub_kind, sub_value, stamp)
            return
        if kind == "array":
            try:
                msg = feed.array_message(value)
            except feed.ConversionError as exc:
                self.expr.note(f"{self.expr.text}: {exc}; not sent")
                return
            self._settle(type(msg))
            if feed.send_message(self.tag, msg):
                self._report(type(msg))
            return
        std = _STD[kind]
        ch = self.channel
        if ch is None or not ch.alive:
            self._settle(std)
            ch = feed.scalar_channel(self.tag, std)
            if ch is None:
                self.expr.note(
                    f"{self.expr.text}: the tag {self.tag} cannot be published (see the program's "
                    "dbglog warnings)"
                )
                return
            self._report(ch.msg_class)
            if self.expr.sink is self:
                self.channel = ch  # the program's thread may queue on it from now on
        if not feed.enqueue(ch, value, stamp):
            self.expr.watch.dropped += 1

    def _settle(self, wanted: type | str) -> None:
        """Move to ``<tag>_2`` ... when the SDK already publishes another type on the tag."""
        from dbglog.api import feed

        def fits(tag: str) -> bool:
            have = feed.channel_type(tag)
            name = wanted if isinstance(wanted, str) else wanted.__name__
            return have is None or have.__name__ == name

        if fits(self.tag):
            return
        base = self.tag
        for n in range(2, 100):
            candidate = f"{base}_{n}"
            if fits(candidate):
                self.tag = candidate
                return

    def _report(self, msg_class: type) -> None:
        if self.reported:
            return
        self.reported = True
        module = msg_class.__module__.split(".")[0]
        self.expr.watch.agent.event(
            self.expr.watch,
            {
                "event": "tag",
                "expr": self.expr.index,
                "tag": self.tag,
                "type": f"{module}/msg/{msg_class.__name__}",
            },
        )


class _PendingArm:
    """An arm request, checked, kept until its file and line are loaded."""

    __slots__ = ("client", "exprs", "message", "spec", "watch_id", "when")

    def __init__(
        self,
        client: str,
        watch_id: str,
        message: dict[str, Any],
        spec: ArmSpec,
        exprs: list[Expr],
        when: Expr | None,
    ) -> None:
        self.client = client
        self.watch_id = watch_id
        self.message = message
        self.spec = spec
        self.exprs = exprs
        self.when = when


class _Expression:
    """One expression of a watch."""

    __slots__ = ("expr", "index", "sink", "text", "watch")

    def __init__(self, watch: Watch, index: int, expr: Expr, tag: str) -> None:
        self.watch = watch
        self.index = index
        self.expr = expr
        self.text = expr.text
        self.sink = _Sink(self, tag)

    def note(self, message: str) -> None:
        self.watch.note(self.index, message)


# ---------------------------------------------------------------------------------------------------------
# One armed watch.


class Watch:
    """One watch armed in this process: a line, its expressions, and who watches it."""

    def __init__(
        self,
        agent: Agent,
        key: tuple[object, ...],
        spec: ArmSpec,
        path: str,
        codes: tuple[types.CodeType, ...],
        exprs: list[Expr],
        when: Expr | None,
        tags: list[str],
    ) -> None:
        self.agent = agent
        self.key = key
        self.spec = spec
        self.path = path
        self.line = spec.line
        self.codes = codes
        self.exprs = [_Expression(self, i, e, t) for i, (e, t) in enumerate(zip(exprs, tags, strict=True))]
        self.when = when
        self.clients: dict[str, str] = {}
        """Watcher node -> its id for this watch."""
        self.counts: dict[str, int | None] = {}
        self.max_cpus: dict[str, float] = {}
        self.armed_at = time.time_ns()
        self.state = "armed"
        self.active = True
        """False once the watch ended (its count, the CPU rule, disarmed): its hits return at once."""
        self.ended: tuple[str, str] | None = None
        """(state, message) set by the program's thread when it ends there; the agent reports it."""
        self.hits = self.sent = self.filtered = self.throttled = self.dropped = self.errors = 0
        self.noted: set[tuple[int, str]] = set()
        self.throttle_ns = int(spec.throttle * 1e9) if spec.throttle else 0
        self.unlimited = spec.throttle == 0
        """``throttle=0``: every hit is sent (no `RATE_HZ` cap)."""
        self.last_pass = -(1 << 62)
        self.tokens = float(BURST)
        self.last_refill = time.perf_counter_ns()
        self.limit: int | None = None
        self.max_cpu = spec.max_cpu
        self.budget_ns = int(spec.max_cpu * CPU_WINDOW_NS)
        self.window_start = time.perf_counter_ns()
        self.window_busy = 0
        self.window_cpu = time.process_time_ns()
        """The process's CPU time when the window started: a window's cost is at most what it spent since
        (a hit the OS paused, on a loaded machine, took wall time but no CPU)."""
        self.window_events = 0
        self.reported_stats: tuple[int, ...] = ()
        self._event_ns = agent.backend.event_ns if agent.backend is not None else 0
        self._queue = agent._queue
        self._pipe = agent._pipe
        self.window_hits = 0

    def update_limits(self) -> None:
        """Count and CPU share from every watcher's request: the largest count, the smallest share."""
        counts = list(self.counts.values())
        self.limit = None if not counts or None in counts else max(c for c in counts if c is not None)
        self.max_cpu = min(self.max_cpus.values(), default=self.spec.max_cpu)
        self.budget_ns = int(self.max_cpu * CPU_WINDOW_NS)

    # ----- the program's thread -----------------------------------------------------------------------

    def hit(self, frame: types.FrameType) -> bool:
        """Read and queue the values at one hit (the program's thread); False once the watch is off."""
        if not self.active:
            return False
        t0 = time.perf_counter_ns()
        self.hits += 1
        try:
            local_ns = frame.f_locals
            global_ns = frame.f_globals
            when = self.when
            if when is not None:
                try:
                    passed = when.truth(local_ns, global_ns)
                except EvalError as exc:
                    self.note(-1, str(exc))
                    passed = False
                if not passed:
                    self.filtered += 1
                    return True
            if self.throttle_ns:
                if t0 - self.last_pass < self.throttle_ns:
                    self.throttled += 1
                    return True
                self.last_pass = t0
            elif not self.unlimited:
                tokens = self.tokens + (t0 - self.last_refill) * (RATE_HZ / 1e9)
                self.last_refill = t0
                if tokens < 1.0:
                    self.tokens = tokens
                    self.throttled += 1
                    return True
                self.tokens = min(float(BURST), tokens) - 1.0
            stamp = time.time_ns()
            queue, pipe = self._queue, self._pipe
            for expression in self.exprs:
                try:
                    kind, value = freeze(expression.expr.evaluate(local_ns, global_ns))
                except EvalError as exc:
                    self.note(expression.index, str(exc))
                    continue
                sink = expression.sink
                ch = sink.channel
                if kind == "int" and sink.kind == "float":
                    kind, value = "float", float(value)
                if ch is not None and kind == sink.kind and ch.alive:
                    if len(queue) < pipe.capacity:
                        queue.append((ch, value, stamp))
                        if pipe.sleeping:
                            pipe.wake()
                    else:
                        self.dropped += 1
                else:
                    self.agent.queue_slow(sink, kind, value, stamp)
            self.sent += 1
            if self.limit is not None and self.sent >= self.limit:
                self.active = False
                self.ended = ("done", f"{self.sent} hits sent: the count is reached")
        except Exception as exc:  # never into the program
            self.note(-1, f"unexpected {type(exc).__name__}: {exc}")
        finally:
            busy = self.window_busy + time.perf_counter_ns() - t0 + self._event_ns
            self.window_busy = busy
            if busy > self.budget_ns and busy > self.max_cpu * (t0 - self.window_start) and self.active:
                busy = self.window_busy = min(busy, time.process_time_ns() - self.window_cpu)
                if busy > self.budget_ns and busy > self.max_cpu * (t0 - self.window_start):
                    self.active = False  # a full window's share already spent: off now, said by the agent
                    self.ended = ("cpu", self._cpu_message(busy, t0 - self.window_start))
        return self.active

    def note(self, index: int, message: str) -> None:
        """Report an expression's error to the watchers once (any thread); the watch stays armed."""
        self.errors += 1
        key = (index, message)
        if key in self.noted or len(self.noted) >= _NOTES_PER_WATCH:
            return
        self.noted.add(key)
        where = "the --when condition" if index < 0 else repr(self.exprs[index].text)
        self.agent.event(self, {"event": "error", "expr": index, "message": f"{where}: {message}"})

    def _cpu_message(self, busy_ns: int, elapsed_ns: int) -> str:
        share = busy_ns / max(elapsed_ns, 1)
        return (
            f"the watch took {share:.1%} of a CPU in the program (more than its {self.max_cpu:.1%}): "
            "disarmed so as not to slow the program (watch a line that runs less often, add --when, or "
            "raise --max-cpu)"
        )

    # ----- the agent's thread -------------------------------------------------------------------------

    def events(self) -> int:
        """Back-end events in the watch's code objects so far (3.11: every traced line of their frames)."""
        backend = self.agent.backend
        if backend is None:
            return 0
        total = 0
        for code in self.codes:
            entry = backend.entry(code)
            total += entry.events if entry is not None else 0
        return total

    def check_cpu(self) -> None:
        """End the window: disarm when the watch's CPU share (hits and their events) is over its limit."""
        now = time.perf_counter_ns()
        elapsed = now - self.window_start
        if elapsed < CPU_WINDOW_NS or not self.active:
            return
        events, hits = self.events(), self.hits
        other = max(0, (events - self.window_events) - (hits - self.window_hits))  # traced lines not hit
        cpu = time.process_time_ns()
        cost = min(self.window_busy + other * self._event_ns, cpu - self.window_cpu)
        self.window_start, self.window_busy, self.window_events, self.window_hits = now, 0, events, hits
        self.window_cpu = cpu
        if cost > self.max_cpu * elapsed:
            self.active = False
            self.ended = ("cpu", self._cpu_message(cost, elapsed))

    def stats(self) -> dict[str, int]:
        """The counters."""
        return {
            "hits": self.hits,
            "sent": self.sent,
            "filtered": self.filtered,
            "throttled": self.throttled,
            "dropped": self.dropped,
            "errors": self.errors,
        }

    def describe(self) -> dict[str, Any]:
        """The watch as the announcement lists it."""
        return {
            "file": self.path,
            "line": self.line,
            "exprs": [e.text for e in self.exprs],
            "when": self.spec.when,
            "tags": [e.sink.tag for e in self.exprs],
            "watchers": len(self.clients),
            "ids": sorted(self.clients.values()),
            "armed_at": self.armed_at,
            "state": self.state,
        }


# ---------------------------------------------------------------------------------------------------------
# The agent.


class Agent:
    """This process's watch agent: its thread, its ROS node, its watches."""

    def __init__(self) -> None:
        self.id = uuid.uuid4().hex[:16]
        self.pid = os.getpid()
        self.host = socket.gethostname()
        self.node_name = agent_node_name()
        self.backend: Backend | None = None
        self.backend_error: str | None = None
        self.watches: dict[tuple[object, ...], Watch] = {}
        self._by_client: dict[tuple[str, str], Watch] = {}
        self._at: dict[tuple[types.CodeType, int], list[Watch]] = {}
        self._answers: collections.OrderedDict[str, str] = collections.OrderedDict()
        self._outbox: collections.deque[tuple[Watch | None, dict[str, Any]]] = collections.deque()
        self._slow: collections.deque[tuple[_Sink, Kind, Any, int]] = collections.deque()
        self._slow_scheduled = False
        self._seen: dict[str, float] = {}
        self._pending: dict[tuple[str, str], _PendingArm] = {}
        self._pending_at = 0.0
        self._nodes: list[str] = []
        self._announced = ""
        self._announced_at = 0.0
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self._ready = threading.Event()
        self.error: str | None = None
        self._ros: Any = None
        self._wake: Any = None
        self._queue: Any = None
        self._pipe: Any = None
        self._thread = threading.Thread(target=self._run, name="dbglog-watch", daemon=True)

    def start(self) -> None:
        """Start the agent's thread (the node comes up there, without delaying the program)."""
        self._thread.start()

    def wait_ready(self, timeout: float) -> bool:
        """Wait until the node is up (or failed: `error` says why); True when up."""
        return self._ready.wait(timeout) and self.error is None

    # ----- values: the program's thread and the publisher thread ----------------------------------------

    def queue_slow(self, sink: _Sink, kind: Kind, value: Any, stamp: int) -> None:
        """Hand a value to the publisher thread (a new tag, an array, a dict)."""
        if len(self._slow) >= 10_000:
            sink.expr.watch.dropped += 1
            return
        self._slow.append((sink, kind, value, stamp))
        if not self._slow_scheduled:
            self._slow_scheduled = True
            self._pipe.call_soon(self._publish_slow)

    def _publish_slow(self) -> None:
        self._slow_scheduled = False
        slow = self._slow
        while slow:
            sink, kind, value, stamp = slow.popleft()
            try:
                sink.publish(kind, value, stamp)
            except Exception as exc:
                sink.expr.note(f"publishing failed ({type(exc).__name__}: {exc})")

    def event(self, watch: Watch | None, message: dict[str, Any]) -> None:
        """Queue an event for a watch's watchers (any thread; the agent's thread sends it)."""
        self._outbox.append((watch, message))

    # ----- the agent's thread ----------------------------------------------------------------------------

    def _run(self) -> None:
        try:
            self._start_ros()
        except Exception as exc:
            self.error = f"{type(exc).__name__}: {exc}"
            self._ready.set()
            if self._stop.is_set() or sys.is_finalizing():
                return  # the program ended while the node was coming up
            _log.warning(
                "dbglog: the watch agent cannot start ROS 2 (%s): this process is not watchable", self.error
            )
            self._ready.set()
            return
        self._ready.set()
        _log.info(
            "dbglog: this process is watchable (node %s): DBGLOG_WATCH exposes its variables to the "
            "ROS domain (docs/watch.md)",
            self.node_name,
        )
        from dbglog._ros._node import WaitSet

        wait_set = WaitSet(self._ros, self._wake)
        last_tick = 0.0
        last_nodes = -_NODES_S
        while not self._stop.is_set():
            timeout = _TICK_S if self.watches or self._outbox else _IDLE_TICK_S
            try:
                wait_set.wait([self._requests], int(timeout * 1e9))
            except Exception:
                if not self._ros.ok():
                    return
                wait_set.reset()
            if self._stop.is_set():
                break
            try:
                self._take_requests()
                now = time.monotonic()
                if now - last_tick >= _TICK_S:
                    last_tick = now
                    self._tick(now)
                if now - last_nodes >= _NODES_S:
                    last_nodes = now
                    self._refresh_nodes()
                if now - self._announced_at >= ANNOUNCE_S:
                    self._announce(force=True)
                self._send_events()
            except Exception:  # the agent's loop survives anything; the program never sees it
                _log.debug("dbglog: watch agent step failed", exc_info=True)

    def _start_ros(self) -> None:
        import numpy  # noqa: F401  (here, not at a hit in the program's thread: arrays are copied with it)
        from std_msgs.msg import String

        from dbglog._ros._node import PrivateNode
        from dbglog.api import feed

        self._queue = feed.QUEUE
        self._pipe = feed.PIPE
        self._string = String
        topics = watch_topics()
        self._ros = PrivateNode(self.node_name)
        try:
            node = self._ros.node
            self._agents_pub = node.create_publisher(String, topics.agents, agents_qos())
            self._answers_pub = node.create_publisher(String, topics.answers, message_qos())
            self._requests = node.create_subscription(String, topics.requests, _no_callback, message_qos())
            self._wake = self._ros.guard()
        except Exception:
            self._ros.close()
            raise
        self._refresh_nodes()
        self._announce(force=True)
        # The SDK's node and batch writer now, on this thread: a watcher discovers them (a second or
        # more on a busy graph) before the first watch, whose first values then arrive at once.
        with contextlib.suppress(Exception):
            feed.connect()

    def _publish(self, publisher: Any, text: str) -> None:
        publisher.publish(self._string(data=text))

    def _take_requests(self) -> None:
        handle = self._requests.handle
        for _ in range(64):
            got = handle.take_message(self._string, False)
            if got is None:
                return
            self._on_request(got[0].data)

    def _on_request(self, text: str) -> None:
        try:
            message = loads(text)
            to = message.get("to")
            if to != self.id:
                return  # another process's request
            req_id = str(text_field(message, "id", limit=64))
            client = str(text_field(message, "client", limit=256))
            op = str(text_field(message, "op", limit=32))
        except ProtocolError as exc:
            _log.info("dbglog: ignored a watch request that does not follow the protocol (%s)", exc)
            return
        cached = self._answers.get(req_id)
        if cached is not None:  # a repeat: the same answer, not handled or logged again
            self._publish(self._answers_pub, cached)
            return
        self._seen[client] = time.monotonic()
        summary = _summary(op, message)
        log = _log.warning if op == "arm" else _log.info
        log("dbglog: watch request %s from %s: %s", req_id, client, summary)
        try:
            answer = self._handle(op, message, client)
        except ProtocolError as exc:
            answer = {"ok": False, "state": "refused", "error": f"bad request: {exc}"}
        except Exception as exc:  # never lose the answer
            answer = {"ok": False, "state": "refused", "error": f"{type(exc).__name__}: {exc}"}
        answer.setdefault("ok", True)
        answer.update(self._who())
        answer.update({"reply_to": req_id, "client": client, "op": op})
        encoded = dumps(answer)
        self._answers[req_id] = encoded
        while len(self._answers) > _ANSWERS_KEPT:
            self._answers.popitem(last=False)
        self._publish(self._answers_pub, encoded)
        _log.info("dbglog: watch answer to %s (%s): %s", req_id, client, _answer_summary(answer))
        if op in ("arm", "disarm"):
            self._announce()

    def _who(self) -> dict[str, Any]:
        return {"agent": self.id, "pid": self.pid, "host": self.host}

    def _handle(self, op: str, message: dict[str, Any], client: str) -> dict[str, Any]:
        if op == "files":
            return self._op_files(bool(message.get("all")))
        if op == "source":
            return self._op_source(message)
        if op == "names":
            return self._op_names(message)
        if op == "arm":
            return self._op_arm(message, client)
        if op == "disarm":
            return self._op_disarm(str(text_field(message, "watch", limit=64)), client)
        raise ProtocolError(f"unknown op {op!r}")

    def _op_files(self, everything: bool) -> dict[str, Any]:
        files = sorted(loaded_files())
        return {"files": files if everything else [f for f in files if user_file(f)]}

    def _resolve(self, message: dict[str, Any]) -> tuple[str, list[types.ModuleType]]:
        files = loaded_files()
        wanted = str(text_field(message, "file"))
        path = find_file(wanted, files, text_field(message, "local_path", optional=True))
        return path, files[path]

    def _op_source(self, message: dict[str, Any]) -> dict[str, Any]:
        line = int(number_field(message, "line", low=1, high=1e7) or 1)
        context = int(number_field(message, "context", optional=True, high=_MAX_SOURCE_CONTEXT) or 10)
        try:
            path, _ = self._resolve(message)
            lines = read_source(path)
        except CodeLookupError as exc:
            return {"ok": False, "state": exc.state, "error": str(exc)}
        except OSError as exc:
            return {"ok": False, "state": "no_file", "error": f"cannot read the file: {exc}"}
        first = max(1, line - context)
        last = min(len(lines), line + context)
        return {"path": path, "first": first, "lines": lines[first - 1 : last], "total": len(lines)}

    def _op_names(self, message: dict[str, Any]) -> dict[str, Any]:
        line = int(number_field(message, "line", low=1, high=1e7) or 1)
        try:
            path, modules = self._resolve(message)
            located = locate(path, line, modules)
        except CodeLookupError as exc:
            return {"ok": False, "state": exc.state, "error": str(exc)}
        local, global_ = names_at(located, modules)
        return {"path": path, "locals": local, "globals": global_}

    # ----- arming -------------------------------------------------------------------------------------

    def _op_arm(self, message: dict[str, Any], client: str) -> dict[str, Any]:
        spec = ArmSpec.from_json(message)
        watch_id = str(text_field(message, "watch", limit=64))
        try:
            exprs = [parse_expr(text) for text in spec.exprs]
            when = parse_expr(spec.when) if spec.when else None
        except ExprError as exc:
            return {"ok": False, "state": "expr_error", "error": f"not allowed: {exc}", "watch": watch_id}
        if spec.label is not None:
            problem = tag_problem(spec.label)
            if problem:
                error = f"label {spec.label!r} is not a valid tag: {problem}"
                return {"ok": False, "state": "refused", "error": error, "watch": watch_id}
        pending = _PendingArm(client, watch_id, message, spec, exprs, when)
        answer = self._try_arm(pending)
        if answer.get("state") in ("no_file", "no_line"):
            # Not (yet) loaded: armed when it is (a module imported later, a program still starting).
            answer["pending"] = True
            with self._lock:
                self._pending[(client, watch_id)] = pending
        return answer

    def _try_arm(self, pending: _PendingArm) -> dict[str, Any]:
        """Arm a checked request; the answer says armed, or why not."""
        spec, client, watch_id = pending.spec, pending.client, pending.watch_id
        try:
            path, modules = self._resolve(pending.message)
            located = locate(path, spec.line, modules)
        except CodeLookupError as exc:
            return {"ok": False, "state": exc.state, "error": str(exc), "watch": watch_id}
        with self._lock:
            if self.backend is None and self.backend_error is None:
                try:
                    self.backend = new_backend()
                except BackendError as exc:
                    self.backend_error = str(exc)
            if self.backend is None:
                error = f"cannot watch here: {self.backend_error}"
                return {"ok": False, "state": "refused", "error": error, "watch": watch_id}
            from dbglog.api import feed

            if not feed.connect():
                error = "dbglog cannot publish (no ROS 2 for the SDK)"
                return {"ok": False, "state": "refused", "error": error, "watch": watch_id}
            key = (path, spec.line, *spec.shared_key())
            watch = self.watches.get(key)
            if watch is None or not watch.active:
                tags = self._choose_tags(spec, pending.exprs)
                watch = Watch(self, key, spec, path, located.codes, pending.exprs, pending.when, tags)
                try:
                    self._install(watch)
                except Exception as exc:
                    error = f"cannot watch here: {exc}"
                    return {"ok": False, "state": "refused", "error": error, "watch": watch_id}
                self.watches[key] = watch
            previous = self._by_client.get((client, watch_id))
            if previous is not None and previous is not watch:
                self._leave(previous, client, watch_id, "disarmed", "replaced by a new arm request")
            watch.clients[client] = watch_id
            watch.counts[client] = spec.count
            watch.max_cpus[client] = spec.max_cpu
            watch.update_limits()
            self._by_client[(client, watch_id)] = watch
        answer: dict[str, Any] = {
            "state": "armed",
            "watch": watch_id,
            "path": path,
            "line": spec.line,
            "tags": [e.sink.tag for e in watch.exprs],
            "armed_at": watch.armed_at,
            "writer": feed.writer(),
            "robot": feed.robot(),
            "backend": self.backend.name,
            "codes": [f"in {getattr(c, 'co_qualname', c.co_name)}" for c in located.codes],
        }
        if self.backend.skipped:
            answer["skipped_threads"] = list(self.backend.skipped)
        return answer

    def _retry_pending(self) -> None:
        """Arm the requests whose file or line was not loaded yet, once it is (said as a status event)."""
        for key, pending in list(self._pending.items()):
            answer = self._try_arm(pending)
            if answer.get("state") in ("no_file", "no_line"):
                continue
            self._pending.pop(key, None)
            _log.info("dbglog: watch request of %s armed now: %s", pending.client, _answer_summary(answer))
            event = {k: v for k, v in answer.items() if k not in ("watch", "ok")}
            self._outbox.append(
                (None, {"event": "status", "client": pending.client, "watch": pending.watch_id, **event})
            )
            self._announce()

    def _choose_tags(self, spec: ArmSpec, exprs: list[Expr]) -> list[str]:
        """``watch/<label>`` per expression; ``_2``... when another watch here publishes on it."""
        taken = {e.sink.tag for w in self.watches.values() if w.active for e in w.exprs}
        tags: list[str] = []
        for expr in exprs:
            if spec.label is None:
                label = label_for(expr.text)
            elif len(exprs) == 1:
                label = spec.label
            else:
                label = f"{spec.label}/{label_for(expr.text)}"
            base = f"{TAG_ROOT}/{label}"
            from dbglog.api import feed

            base = feed.resolve_tag(base) or base
            tag, n = base, 2
            while tag in taken or tag in tags:
                tag, n = f"{base}_{n}", n + 1
            tags.append(tag)
        return tags

    def _install(self, watch: Watch) -> None:
        backend = self.backend
        assert backend is not None
        for code in watch.codes:
            at = self._at.setdefault((code, watch.line), [])
            at.append(watch)
            backend.watch(code, watch.line, tuple(at))
        watch.window_events = watch.events()

    def _uninstall(self, watch: Watch) -> None:
        backend = self.backend
        if backend is None:
            return
        for code in watch.codes:
            at = self._at.get((code, watch.line), [])
            if watch in at:
                at.remove(watch)
            if not at:
                self._at.pop((code, watch.line), None)
            backend.watch(code, watch.line, tuple(at))

    def _end(self, watch: Watch, state: str, message: str) -> None:
        """End a watch for every watcher: off the line, out of the table, and said."""
        watch.active = False
        watch.state = state
        self._uninstall(watch)
        if self.watches.get(watch.key) is watch:
            del self.watches[watch.key]
        for client, watch_id in list(watch.clients.items()):
            self._by_client.pop((client, watch_id), None)
        self._stats(watch, force=True)
        self.event(watch, {"event": "status", "state": state, "message": message})
        _log.info("dbglog: watch on %s:%d ended (%s): %s", watch.path, watch.line, state, message)
        self._announce()

    def _leave(self, watch: Watch, client: str, watch_id: str, state: str, message: str) -> None:
        """One watcher leaves a watch; the watch ends when it was the last one."""
        self._by_client.pop((client, watch_id), None)
        watch.clients.pop(client, None)
        watch.counts.pop(client, None)
        watch.max_cpus.pop(client, None)
        if not watch.clients:
            watch.active = False
            watch.state = state
            self._uninstall(watch)
            if self.watches.get(watch.key) is watch:
                del self.watches[watch.key]
        else:
            watch.update_limits()

    def _op_disarm(self, watch_id: str, client: str) -> dict[str, Any]:
        with self._lock:
            self._pending.pop((client, watch_id), None)
            watch = self._by_client.get((client, watch_id))
            if watch is not None:
                self._leave(watch, client, watch_id, "disarmed", f"disarmed by {client}")
                return {"state": "disarmed", "watch": watch_id, "stats": watch.stats()}
        return {"state": "disarmed", "watch": watch_id}

    # ----- periodic work --------------------------------------------------------------------------------

    def _tick(self, now: float) -> None:
        if self._pending and now - self._pending_at >= _PENDING_S:
            self._pending_at = now
            self._retry_pending()
        with self._lock:
            for watch in list(self.watches.values()):
                watch.check_cpu()
                if watch.ended is not None and watch.state == "armed":
                    state, message = watch.ended
                    self._end(watch, state, message)
                else:
                    self._stats(watch)
            if self.watches or self._pending:
                self._check_clients(now)

    def _stats(self, watch: Watch, *, force: bool = False) -> None:
        stats = watch.stats()
        values = tuple(stats.values())
        if values != watch.reported_stats or force:
            watch.reported_stats = values
            self.event(watch, {"event": "stats", **stats})

    def _check_clients(self, now: float) -> None:
        try:
            present = {name for name, _ns in self._ros.node.get_node_names_and_namespaces()}
        except Exception:
            return
        for name in present:
            if name in self._seen:
                self._seen[name] = now
        for client, watch_id in list(self._pending):
            if now - self._seen.get(client, now) > CLIENT_GONE_S:
                self._pending.pop((client, watch_id), None)
        for (client, watch_id), watch in list(self._by_client.items()):
            if now - self._seen.get(client, now) > CLIENT_GONE_S:
                _log.info(
                    "dbglog: watcher %s left the ROS graph: its watch on %s:%d is disarmed",
                    client,
                    watch.path,
                    watch.line,
                )
                self._leave(watch, client, watch_id, "disarmed", f"{client} is gone")
                self._announce()

    def _send_events(self) -> None:
        outbox = self._outbox
        while outbox:
            watch, message = outbox.popleft()
            base = {**self._who(), **message}
            if watch is None:  # addressed already (a pending request armed)
                self._publish(self._answers_pub, dumps(base))
                continue
            for client, watch_id in list(watch.clients.items()):
                self._publish(self._answers_pub, dumps({**base, "client": client, "watch": watch_id}))

    def _refresh_nodes(self) -> None:
        nodes = _user_nodes()
        if nodes != self._nodes:
            self._nodes = nodes
            self._announce()

    def _announce(self, *, force: bool = False) -> None:
        if self._ros is None:
            return
        with self._lock:
            text = dumps(
                {
                    **self._who(),
                    "node": self.node_name,
                    "program": [str(a)[:500] for a in sys.argv[:32]],
                    "executable": sys.executable,
                    "python": ".".join(map(str, sys.version_info[:3])),
                    "cwd": _cwd(),
                    "nodes": self._nodes,
                    "backend": "sys.monitoring" if hasattr(sys, "monitoring") else "settrace",
                    "writer": _writer(),
                    "robot": _robot(),
                    "watches": [w.describe() for w in self.watches.values()],
                }
            )
        if text != self._announced or force:
            self._announced = text
            self._announced_at = time.monotonic()
            self._publish(self._agents_pub, text)

    # ----- life cycle -----------------------------------------------------------------------------------

    def stop(self) -> None:
        """Disarm everything, stop the thread, destroy the node (at exit; idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        with self._lock:
            for watch in list(self.watches.values()):
                watch.active = False
            self.watches.clear()
            self._by_client.clear()
            self._at.clear()
            if self.backend is not None:
                self.backend.close()
        if self._wake is not None:
            with contextlib.suppress(Exception):
                self._wake.trigger()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        if self._ros is not None and not self._thread.is_alive():
            self._ros.close()

    def after_fork_in_child(self) -> None:
        """The parent's node and thread are not in this child: stop watching, quietly (no ROS calls)."""
        self._stop.set()
        if self.backend is not None:
            self.backend.after_fork()
        self.watches.clear()
        self._by_client.clear()
        self._at.clear()
        self._ros = None


def _writer() -> int | None:
    """The SDK's batch writer id, once it is connected."""
    from dbglog.api import feed

    return feed.writer() if feed.connected() else None


def _robot() -> str | None:
    """The robot namespace of the SDK's topics, once it is connected (``""``: the root)."""
    from dbglog.api import feed

    return feed.robot() if feed.connected() else None


def _no_callback(_msg: object) -> None:
    """Subscription callback that never runs: the agent takes requests itself."""


def _cwd() -> str:
    try:
        return os.getcwd()
    except OSError:
        return ""


def _summary(op: str, message: dict[str, Any]) -> str:
    if op == "arm":
        exprs = message.get("exprs")
        shown = ", ".join(map(str, exprs)) if isinstance(exprs, list) else "?"
        when = f" when {message.get('when')}" if message.get("when") else ""
        return f"arm a watch on {message.get('file')}:{message.get('line')}: {shown}{when}"
    if op in ("source", "names"):
        return f"{op} of {message.get('file')}:{message.get('line')}"
    if op == "disarm":
        return f"disarm {message.get('watch')}"
    return op


def _answer_summary(answer: dict[str, Any]) -> str:
    if not answer.get("ok", True):
        return f"{answer.get('state')}: {answer.get('error')}"
    if "files" in answer:
        return f"{len(answer['files'])} files"
    if "lines" in answer:
        return f"{len(answer['lines'])} lines of {answer.get('path')}"
    if "locals" in answer:
        return f"{len(answer['locals'])} local and {len(answer['globals'])} global names"
    state = answer.get("state")
    if state == "armed":
        return f"armed on {answer.get('path')}:{answer.get('line')}, tags {', '.join(answer.get('tags', []))}"
    return str(state)


def _user_nodes() -> list[str]:
    """The rclpy nodes of this process that an executor spins (the global one, or one on a thread's stack)."""
    rclpy = sys.modules.get("rclpy")
    if rclpy is None:
        return []
    executors: list[Any] = []
    with contextlib.suppress(Exception):
        global_executor = vars(rclpy).get("__executor")
        if global_executor is not None:
            executors.append(global_executor)
    executor_file = os.sep + os.path.join("rclpy", "executors.py")
    with contextlib.suppress(Exception):
        for top in list(sys._current_frames().values()):
            frame: types.FrameType | None = top
            while frame is not None:
                if frame.f_code.co_filename.endswith(executor_file):
                    candidate = frame.f_locals.get("self")
                    if candidate is not None and candidate not in executors:
                        executors.append(candidate)
                frame = frame.f_back
    names: set[str] = set()
    for executor in executors:
        with contextlib.suppress(Exception):
            for node in list(getattr(executor, "_nodes", ())):
                with contextlib.suppress(Exception):
                    names.add(node.get_fully_qualified_name())
    return sorted(names)


# ---------------------------------------------------------------------------------------------------------
# The process's agent.

_AGENT: Agent | None = None
_AGENT_LOCK = threading.Lock()


def agent() -> Agent | None:
    """This process's agent, if it was started."""
    return _AGENT


def start() -> Agent:
    """Make this process watchable (idempotent): start the agent's thread, which brings its node up.

    Called by ``import dbglog`` with ``DBGLOG_WATCH=1`` and by ``dbglog run``.
    """
    global _AGENT
    with _AGENT_LOCK:
        if _AGENT is None:
            _AGENT = Agent()
            _AGENT.start()
            atexit.register(_AGENT.stop)
            os.register_at_fork(after_in_child=_AGENT.after_fork_in_child)
        return _AGENT
