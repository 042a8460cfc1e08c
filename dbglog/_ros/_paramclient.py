"""An asynchronous parameter client: list, get, describe and set any node's parameters, never blocking.

`ParamClient` owns a private ROS node (its own context) and one thread that runs it. Every call only
queues a request and returns a `concurrent.futures.Future` at once; the thread waits for the node's
parameter service, sends the request and resolves the future with the answer, or with a `ParamError`
when the node is not on the graph, offers no parameter services, or does not answer in time (a node
that never spins costs its caller the timeout, nothing more). So a UI thread may call it freely and poll
``future.done()`` each frame; a terminal command may wait on ``future.result()``. Futures' callbacks run
on the client's thread: keep them short and never draw from them.

The thread also keeps the graph's nodes that offer parameters (`nodes`), tells watchers each node's
values when it is first seen (`watch`: what "old → new" of a change needs), and publishes the viewer's
user markers (`publish_marker`). No import of rclpy at module level.
"""

from __future__ import annotations

import functools
import logging
import os
import queue
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import Future, InvalidStateError
from dataclasses import dataclass
from types import TracebackType
from typing import Any, Final, Self, TypeVar

from dbglog._ros._markers import MARKER_TOPIC, Marker, encode_marker, marker_qos
from dbglog._ros._params import (
    Param,
    ParamDescriptor,
    ParamValue,
    SetResult,
    descriptor_from_msg,
    node_name,
)

__all__ = [
    "DEFAULT_TIMEOUT_S",
    "ClientClosedError",
    "NoAnswerError",
    "NoParametersError",
    "NodeNotFoundError",
    "ParamClient",
    "ParamError",
    "ValuesCallback",
]

_log = logging.getLogger("dbglog.params")
T = TypeVar("T")

DEFAULT_TIMEOUT_S: Final = 5.0
"""How long a call waits for the node by default: DDS discovery of a node just started (up to ~3.4 s on a
loaded machine when it misses the first announcement) plus its answer."""
_GRAPH_PERIOD_S: Final = 0.5
_READY_POLL_S: Final = 0.02
"""While a request waits for its service to be discovered, it is looked at this often."""
_SEED_RETRY_S: Final = (5.0, 60.0)
"""A node that did not tell its values is asked again after 5 s, then twice as long each time, up to 60 s."""
_LIST_SERVICE: Final = "/list_parameters"

ValuesCallback = Callable[[str, dict[str, ParamValue], float], None]
"""``(node, values, asked_at)``: a node's parameter values, and when they were asked (``time.monotonic``)."""


class ParamError(Exception):
    """A parameter call that got no usable answer; the message names the node and says why."""


class NodeNotFoundError(ParamError):
    """The node is not on the ROS graph (within the call's timeout)."""


class NoParametersError(ParamError):
    """The node is on the graph but offers no parameter services."""


class NoAnswerError(ParamError, TimeoutError):
    """The node's parameter service is on the graph but did not answer within the timeout."""


class ClientClosedError(ParamError):
    """The client was closed (or ROS could not start) before the call was answered."""


@dataclass(eq=False, slots=True)
class _Call:
    """One request to one of a node's parameter services (client thread only, once queued)."""

    node: str
    service: str
    """``list_parameters``, ``get_parameters``, ``describe_parameters`` or ``set_parameters``."""
    build: Callable[[], Any]
    convert: Callable[[Any], Any]
    future: Future[Any]
    deadline: float
    timeout: float
    client: Any = None
    sent: Any = None
    sent_at: float = 0.0


@dataclass(frozen=True, slots=True)
class _Waiting:
    """A `set_latest` value waiting for the answer to the one sent before it."""

    value: ParamValue
    future: Future[SetResult]
    timeout: float | None


@dataclass(slots=True)
class _Seed:
    """A node's values asked for a watcher: when to ask (again) and how long to wait after a failure."""

    due: float
    backoff: float = _SEED_RETRY_S[0]
    asking: bool = False
    done: bool = False


@dataclass(slots=True)
class _Graph:
    """What the last graph poll saw."""

    nodes: tuple[str, ...] = ()
    """Every node, fully qualified."""
    with_params: tuple[str, ...] = ()
    """The nodes that offer parameter services."""
    polls: int = 0


def _settle(future: Future[T], value: T | None = None, error: BaseException | None = None) -> None:
    """Resolve `future` unless it is already done or cancelled."""
    try:
        if error is not None:
            future.set_exception(error)
        else:
            future.set_result(value)  # type: ignore[arg-type]
    except InvalidStateError:
        pass


class ParamClient:
    """Ask nodes about their parameters and set them, asynchronously, from any thread.

    Example:
        >>> with ParamClient() as params:
        ...     answer = params.set("/pid_node", {"kp": 2.5})   # returns at once
        ...     ...                                             # the UI polls answer.done() each frame
        ...     [result] = answer.result()                      # SetResult(ok=False, reason=...) if rejected

    Args:
        timeout: the default seconds a call waits for its node (discovery and answer together).
        node_name: the client's ROS node name (default ``dbglog_params_<pid>``).
        graph_period: seconds between looks at the graph (`nodes`, `watch`).
    """

    def __init__(
        self,
        *,
        timeout: float = DEFAULT_TIMEOUT_S,
        node_name: str | None = None,
        graph_period: float = _GRAPH_PERIOD_S,
    ) -> None:
        if not timeout > 0:
            raise ValueError(f"timeout must be > 0 seconds, not {timeout}")
        self.timeout = timeout
        self.node_name = node_name or f"dbglog_params_{os.getpid()}"
        self.graph_period = graph_period
        self._jobs: queue.SimpleQueue[_Call | Marker | None] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._graph = _Graph()
        self._watchers: list[ValuesCallback] = []
        self._latest: dict[tuple[str, str], _Waiting | None] = {}
        """`set_latest`'s parameters with a set awaiting its answer, and the value waiting after it."""
        self._thread: threading.Thread | None = None
        self._started = threading.Event()
        self._running = False
        self._closed = False
        self._guard: Any = None
        self._error: str | None = None
        # client thread only:
        self._clients: dict[tuple[str, str], Any] = {}
        self._waiting: list[_Call] = []
        self._in_flight: dict[int, _Call] = {}
        self._seeds: dict[str, _Seed] = {}
        self._marker_pub: Any = None

    # --- lifecycle ----------------------------------------------------------------------------------

    def start(self) -> Self:
        """Start the client's thread (idempotent); returns at once (ROS starts on that thread)."""
        with self._lock:
            if self._thread is not None or self._closed:
                return self
            self._running = True
            self._thread = threading.Thread(target=self._run, name="dbglog-params", daemon=True)
            self._thread.start()
        return self

    def wait_started(self, timeout: float) -> bool:
        """Block until ROS has started on the client's thread (or failed: see `error`); for terminal
        commands and tests, never a UI thread. Returns whether it got that far in time."""
        self.start()
        return self._started.wait(timeout)

    @property
    def error(self) -> str | None:
        """Why ROS could not start on the client's thread (every call then fails with it), else None."""
        return self._error

    def close(self, timeout: float = 5.0) -> None:
        """Stop the thread and destroy the node; calls not answered yet fail with `ClientClosedError`."""
        with self._lock:
            self._closed = True
            thread, self._running = self._thread, False
        self._jobs.put(None)
        self._wake()
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout)
        self._fail_queued(ClientClosedError("the parameter client was closed"))

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    # --- the graph ----------------------------------------------------------------------------------

    def nodes(self) -> list[str]:
        """The nodes that offer parameter services, fully qualified and sorted, as of the last graph poll."""
        return list(self._graph.with_params)

    def graph_nodes(self) -> list[str]:
        """Every node on the graph, fully qualified and sorted, as of the last graph poll."""
        return list(self._graph.nodes)

    @property
    def graph_polls(self) -> int:
        """How many times the thread has looked at the graph (a caller waiting for discovery counts them)."""
        return self._graph.polls

    def watch(self, on_values: ValuesCallback) -> None:
        """Call ``on_values(node, values, asked_at)`` with the values of each node that offers parameters,
        once when it is first seen (again if it leaves the graph and comes back). A node that does not
        answer is asked again later (after 5 s, then less and less often). Runs on the client's thread."""
        with self._lock:
            self._watchers.append(on_values)
        self.start()
        self._wake()

    # --- calls --------------------------------------------------------------------------------------

    def list_names(self, node: str, *, timeout: float | None = None) -> Future[list[str]]:
        """The names of every parameter of `node`, as it lists them."""

        def build() -> Any:
            from rcl_interfaces.srv import ListParameters

            return ListParameters.Request()

        def convert(response: Any) -> list[str]:
            return [str(n) for n in response.result.names]

        return self._submit(node, "list_parameters", build, convert, timeout)

    def get(
        self, node: str, names: Iterable[str], *, timeout: float | None = None
    ) -> Future[dict[str, ParamValue]]:
        """The current values of `names` of `node`.

        The future fails with a `ParamError` saying so when one of the names is not declared (a node
        answers no value at all then).
        """
        wanted = list(dict.fromkeys(names))

        def build() -> Any:
            from rcl_interfaces.srv import GetParameters

            return GetParameters.Request(names=wanted)

        def convert(response: Any) -> dict[str, ParamValue]:
            values = list(response.values)
            if len(values) != len(wanted):
                raise ParamError(_undeclared(node, wanted))
            return {n: ParamValue.from_msg(v) for n, v in zip(wanted, values, strict=True)}

        if not wanted:
            return _done({})
        return self._submit(node, "get_parameters", build, convert, timeout)

    def describe(
        self, node: str, names: Iterable[str], *, timeout: float | None = None
    ) -> Future[dict[str, ParamDescriptor]]:
        """The descriptors (type, range and step, read-only, description) of `names` of `node`."""
        wanted = list(dict.fromkeys(names))

        def build() -> Any:
            from rcl_interfaces.srv import DescribeParameters

            return DescribeParameters.Request(names=wanted)

        def convert(response: Any) -> dict[str, ParamDescriptor]:
            found = list(response.descriptors)
            if len(found) != len(wanted):
                raise ParamError(_undeclared(node, wanted))
            return {n: descriptor_from_msg(d) for n, d in zip(wanted, found, strict=True)}

        if not wanted:
            return _done({})
        return self._submit(node, "describe_parameters", build, convert, timeout)

    def set(
        self, node: str, values: Mapping[str, ParamValue | object], *, timeout: float | None = None
    ) -> Future[list[SetResult]]:
        """Set parameters of `node` (each on its own, as ``ros2 param set``); the future holds the node's
        answer for each, in order: a rejection is an answer (`SetResult.ok` False, with its reason).

        Values are `ParamValue`s or Python values (`ParamValue.of`: 2 is an integer, 2.0 a double; use
        `coerce` to match a parameter's type).

        Raises:
            ValueError: a value of no parameter type (at once, nothing is sent).
        """
        items = [(name, ParamValue.of(v)) for name, v in values.items()]

        def build() -> Any:
            from rcl_interfaces.msg import Parameter as ParameterMsg
            from rcl_interfaces.srv import SetParameters

            return SetParameters.Request(
                parameters=[ParameterMsg(name=n, value=v.to_msg()) for n, v in items]
            )

        def convert(response: Any) -> list[SetResult]:
            results = list(response.results)
            if len(results) != len(items):
                raise ParamError(f"{node} answered {len(results)} results for {len(items)} parameters")
            return [
                SetResult(n, v, bool(r.successful), str(r.reason))
                for (n, v), r in zip(items, results, strict=True)
            ]

        if not items:
            return _done([])
        return self._submit(node, "set_parameters", build, convert, timeout)

    def set_latest(
        self, node: str, name: str, value: ParamValue | object, *, timeout: float | None = None
    ) -> Future[SetResult]:
        """Set one parameter, at most one request at a time: what a control sends while it is dragged.

        While a set of this parameter awaits the node's answer, the newest value waits and is sent when
        the answer comes; a value that was waiting is replaced (its future is cancelled). So a slider
        dragged faster than the node answers sends as fast as the node answers, and its last value
        always goes out. The future holds the node's answer for this value.

        Raises:
            ValueError: a value of no parameter type (at once, nothing is sent).
        """
        target = node if node.startswith("/") else "/" + node
        key = (target, name)
        typed = ParamValue.of(value)
        future: Future[SetResult] = Future()
        with self._lock:
            if key in self._latest:  # one is being answered: this one waits, replacing the one waiting
                replaced = self._latest[key]
                self._latest[key] = _Waiting(typed, future, timeout)
                if replaced is not None:
                    replaced.future.cancel()
                return future
            self._latest[key] = None  # sent now, nothing waiting
        self._send_latest(key, _Waiting(typed, future, timeout))
        return future

    def _send_latest(self, key: tuple[str, str], this: _Waiting) -> None:
        """Send `this` value of a `set_latest` parameter; when answered, send the one waiting, if any."""

        def answered(done: Future[list[SetResult]]) -> None:
            error = done.exception()
            if error is not None:
                _settle(this.future, error=error)
            else:
                _settle(this.future, done.result()[0])
            with self._lock:
                waiting = self._latest.get(key)
                if waiting is None or waiting.future.cancelled():
                    del self._latest[key]
                    return
                self._latest[key] = None
            self._send_latest(key, waiting)

        try:
            sent = self.set(key[0], {key[1]: this.value}, timeout=this.timeout)
        except Exception as exc:  # never leave the parameter marked busy
            sent = Future()
            sent.set_exception(exc)
        sent.add_done_callback(answered)

    def fetch(self, node: str, *, describe: bool = True, timeout: float | None = None) -> Future[list[Param]]:
        """Every parameter of `node` with its value (and descriptor unless `describe` is False), sorted by
        name: a list, then a get and a describe together, all within one `timeout`."""
        outer: Future[list[Param]] = Future()
        limit = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + limit

        def on_names(listed: Future[list[str]]) -> None:
            error = listed.exception()
            if error is not None:
                _settle(outer, error=error)
                return
            names = sorted(listed.result())
            left = max(0.0, deadline - time.monotonic())
            got = self.get(node, names, timeout=left)
            told = self.describe(node, names, timeout=left) if describe else _done({})

            def both(_f: Future[Any]) -> None:
                if not (got.done() and told.done()) or outer.done():
                    return
                for part in (got, told):
                    if part.exception() is not None:
                        _settle(outer, error=part.exception())
                        return
                values, descriptors = got.result(), told.result()
                _settle(outer, [Param(n, values[n], descriptors.get(n)) for n in names])

            got.add_done_callback(both)
            told.add_done_callback(both)

        self.list_names(node, timeout=limit).add_done_callback(on_names)
        return outer

    def publish_marker(self, marker: Marker) -> None:
        """Publish a user marker on ``/_dbglog/markers`` (kept for subscribers that join later)."""
        self.start()
        with self._lock:
            if not self._closed:
                self._jobs.put(marker)
        self._wake()

    # --- calling thread -----------------------------------------------------------------------------

    def _submit(
        self,
        node: str,
        service: str,
        build: Callable[[], Any],
        convert: Callable[[Any], T],
        timeout: float | None,
    ) -> Future[T]:
        future: Future[T] = Future()
        limit = self.timeout if timeout is None else max(0.0, timeout)
        target = node if node.startswith("/") else "/" + node
        call = _Call(target, service, build, convert, future, time.monotonic() + limit, limit)
        self.start()
        with self._lock:  # queued under the lock: `close` fails whatever was queued before it closed
            closed = self._closed or self._error is not None
            if not closed:
                self._jobs.put(call)
        if closed:
            _settle(future, error=ClientClosedError(self._error or "the parameter client is closed"))
            return future
        self._wake()
        return future

    def _wake(self) -> None:
        guard = self._guard
        if guard is not None:
            try:
                guard.trigger()
            except Exception:  # the context is shutting down: the thread is leaving anyway
                _log.debug("parameter client guard trigger failed", exc_info=True)

    def _fail_queued(self, error: ParamError) -> None:
        while True:
            try:
                job = self._jobs.get_nowait()
            except queue.Empty:
                return
            if isinstance(job, _Call):
                _settle(job.future, error=error)

    # --- the client's thread ------------------------------------------------------------------------

    def _run(self) -> None:
        from rclpy.executors import SingleThreadedExecutor

        from dbglog._ros._node import PrivateNode

        try:
            ros = PrivateNode(self.node_name)
            executor = SingleThreadedExecutor(context=ros.context)
            executor.add_node(ros.node)
            self._guard = ros.node.create_guard_condition(lambda: None)
        except Exception as exc:  # rclpy missing, or ROS refusing to start: every call says so
            with self._lock:  # no call is queued after this (`_submit` queues under the lock)
                self._error = f"ROS 2 could not start for the parameter client: {exc}"
            self._started.set()
            self._fail_queued(ClientClosedError(self._error))
            return
        self._started.set()
        try:
            self._loop(ros, executor)
        finally:
            self._guard = None
            closed = ClientClosedError("the parameter client was closed")
            for call in [*self._waiting, *self._in_flight.values()]:
                _settle(call.future, error=closed)
            self._waiting, self._in_flight = [], {}
            self._fail_queued(closed)
            destroy: list[Callable[[], object]] = [executor.shutdown]
            destroy += [functools.partial(ros.node.destroy_client, c) for c in self._clients.values()]
            if self._marker_pub is not None:
                destroy.append(functools.partial(ros.node.destroy_publisher, self._marker_pub))
            ros.close(destroy)

    def _loop(self, ros: Any, executor: Any) -> None:
        node = ros.node
        next_graph = 0.0
        while self._running and ros.ok():
            try:
                self._take_jobs(node)
                now = time.monotonic()
                if now >= next_graph:
                    self._refresh_graph(node, now)
                    next_graph = now + self.graph_period
                self._advance(now)
                wake = next_graph
                if self._waiting:
                    wake = min(wake, now + _READY_POLL_S)
                for call in [*self._waiting, *self._in_flight.values()]:
                    wake = min(wake, call.deadline)
                executor.spin_once(timeout_sec=max(0.0, wake - time.monotonic()))
            except Exception:
                if not (self._running and ros.ok()):
                    return
                _log.exception("parameter client cycle failed; continuing")
                time.sleep(0.05)

    def _take_jobs(self, node: Any) -> None:
        while True:
            try:
                job = self._jobs.get_nowait()
            except queue.Empty:
                return
            if job is None:
                continue
            if isinstance(job, Marker):
                self._publish(node, job)
                continue
            key = (job.node, job.service)
            client = self._clients.get(key)
            if client is None:
                client = self._clients[key] = self._make_client(node, job.node, job.service)
            job.client = client
            self._waiting.append(job)

    @staticmethod
    def _make_client(node: Any, target: str, service: str) -> Any:
        from rcl_interfaces import srv

        kinds = {
            "list_parameters": srv.ListParameters,
            "get_parameters": srv.GetParameters,
            "describe_parameters": srv.DescribeParameters,
            "set_parameters": srv.SetParameters,
        }
        from rclpy.qos import qos_profile_parameters

        # The parameter services' own QoS (deep queues): many requests at once (a watcher asking every node,
        # a slider's sets) must not overwrite each other in the request writer's history.
        return node.create_client(kinds[service], f"{target}/{service}", qos_profile=qos_profile_parameters)

    def _advance(self, now: float) -> None:
        """Send the requests whose service is ready; fail those past their deadline."""
        waiting: list[_Call] = []
        for call in self._waiting:
            if call.future.cancelled():
                continue
            if call.client.service_is_ready():
                call.sent_at = time.monotonic()
                call.sent = call.client.call_async(call.build())
                self._in_flight[id(call)] = call
                call.sent.add_done_callback(functools.partial(self._answered, call))
            elif now >= call.deadline:
                _settle(call.future, error=self._unreachable(call))
            else:
                waiting.append(call)
        self._waiting = waiting
        for key, call in list(self._in_flight.items()):
            if call.future.cancelled() or now >= call.deadline:
                del self._in_flight[key]
                call.client.remove_pending_request(call.sent)
                _settle(
                    call.future,
                    error=NoAnswerError(
                        f"{call.node} did not answer ({call.service}) within {call.timeout:.3g} s: its "
                        "parameter services are on the graph, but nothing replied (does the node spin?)"
                    ),
                )

    def _unreachable(self, call: _Call) -> ParamError:
        """Why a request's service never became ready: no such node, no parameters, or not matched."""
        graph = self._graph
        if call.node not in graph.nodes and call.node not in graph.with_params:
            return NodeNotFoundError(f"{call.node} is not on the ROS graph (waited {call.timeout:.3g} s)")
        if call.node not in graph.with_params:
            return NoParametersError(f"{call.node} is on the ROS graph but offers no parameter services")
        return NoAnswerError(
            f"{call.node} did not answer ({call.service}) within {call.timeout:.3g} s: its service is on the "
            "graph but was not matched in time"
        )

    def _answered(self, call: _Call, sent: Any) -> None:
        """An rclpy future of a request is done (the executor's callback, client thread)."""
        if self._in_flight.pop(id(call), None) is None:
            return  # timed out meanwhile: already failed
        error = sent.exception()
        if error is not None:
            _settle(call.future, error=ParamError(f"{call.node} ({call.service}): {error}"))
            return
        try:
            value = call.convert(sent.result())
        except ParamError as exc:
            _settle(call.future, error=exc)
            return
        except Exception as exc:  # an answer this client cannot read: say so, never crash the thread
            _settle(call.future, error=ParamError(f"{call.node} ({call.service}): unreadable answer: {exc}"))
            return
        _settle(call.future, value)

    def _refresh_graph(self, node: Any, now: float) -> None:
        nodes = sorted(node_name(ns, name) for name, ns in node.get_node_names_and_namespaces())
        on_graph = set(nodes)
        # The graph lists a service name for its clients too (ours, to a node that may not exist): a node
        # offers parameters when it is on the graph and, where this client asked it, a server answers.
        ours = {target for target, service in self._clients if service == "list_parameters"}
        with_params = sorted(
            target
            for service, types in node.get_service_names_and_types()
            if service.endswith(_LIST_SERVICE)
            and "rcl_interfaces/srv/ListParameters" in types
            and (target := service[: -len(_LIST_SERVICE)]) in on_graph
            and (target not in ours or node.count_services(service) > 0)
        )
        self._graph = _Graph(tuple(nodes), tuple(with_params), self._graph.polls + 1)
        present = set(nodes) | set(with_params)
        busy = {(c.node, c.service) for c in [*self._waiting, *self._in_flight.values()]}
        for key in [k for k in self._clients if k[0] not in present and k not in busy]:
            node.destroy_client(self._clients.pop(key))
        with self._lock:
            watching = bool(self._watchers)
        if not watching:
            return
        for gone in [n for n in self._seeds if n not in with_params]:
            del self._seeds[gone]
        for target in with_params:
            seed = self._seeds.setdefault(target, _Seed(due=now))
            if not seed.done and not seed.asking and now >= seed.due:
                seed.asking = True
                asked_at = time.monotonic()
                self.fetch(target, describe=False).add_done_callback(
                    functools.partial(self._seeded, target, seed, asked_at)
                )

    def _seeded(self, target: str, seed: _Seed, asked_at: float, answer: Future[list[Param]]) -> None:
        """A watched node's values arrived (or did not): tell the watchers, or ask again later."""
        seed.asking = False
        if answer.exception() is not None:
            seed.due = time.monotonic() + seed.backoff
            seed.backoff = min(seed.backoff * 2, _SEED_RETRY_S[1])
            _log.debug("parameter values of %s: %s", target, answer.exception())
            return
        if self._seeds.get(target) is not seed:
            return  # the node left meanwhile
        seed.done = True
        values = {p.name: p.value for p in answer.result()}
        with self._lock:
            watchers = list(self._watchers)
        for watcher in watchers:
            try:
                watcher(target, values, asked_at)
            except Exception:  # one watcher's bug must not stop the client
                _log.exception("parameter watcher failed on %s", target)

    def _publish(self, node: Any, marker: Marker) -> None:
        try:
            if self._marker_pub is None:
                from std_msgs.msg import String

                self._marker_pub = node.create_publisher(String, MARKER_TOPIC, marker_qos())
            self._marker_pub.publish(encode_marker(marker))
        except Exception:  # a marker that cannot be sent is logged, the client goes on
            _log.exception("could not publish marker %s", marker.id)


def _undeclared(node: str, names: list[str]) -> str:
    which = names[0] if len(names) == 1 else "one of " + ", ".join(names)
    return f"{node} has no parameter {which} (not declared)"


def _done(value: T) -> Future[T]:
    future: Future[T] = Future()
    future.set_result(value)
    return future
