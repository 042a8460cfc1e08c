"""dbglog's side of ROS 2: its own context and node (or the user's node), one cached publisher per tag.

rclpy is imported on first use only. dbglog never initialises the user's global context; after a
``fork`` the child keeps its hands off the parent's middleware objects and stays quiet (the DDS
middleware does not survive a fork); at interpreter exit everything is shut down.
"""

from __future__ import annotations

import atexit
import contextlib
import ctypes
import functools
import os
import sys
import threading
import time
import warnings
from collections.abc import Callable
from typing import Any, Literal

from dbglog._ros._batch import batch_topic, is_reader_node, sdk_node_name
from dbglog._ros._nogil import publisher_address, rcl_addresses, unlocked_publish
from dbglog._ros._qos import batch_qos, tag_qos
from dbglog._ros._tags import (
    MAX_TOPIC_LENGTH,
    TagError,
    escape_tag,
    normalize_robot,
    ros_args_namespace,
    tag_problem,
    topic_for_tag,
    unescape_tag,
)
from dbglog.api._channel import Channel, cdr_encoder
from dbglog.api._convert import (
    ScalarSpec,
    encode_scalar,
    scalar_spec,
    type_name,
)
from dbglog.api._errors import Reporter, safe_repr
from dbglog.api._native import load
from dbglog.api._pipe import Pipe

__all__ = ["MAX_TAGS", "Channel", "Runtime"]

MAX_TAGS = 10_000
"""More distinct tags than this are refused (a bug such as a value formatted into the tag)."""

_EXIT_FLUSH_SECONDS = 0.5
_EXIT_DRAIN_SECONDS = 2.0
"""At exit, queued samples are published for at most this long (then acknowledgements are awaited)."""
_FORKED_MESSAGE = (
    "dbglog.{api}: this process was forked from one that used ROS 2, whose middleware does not "
    "survive a fork; dbglog drops values in the child (start workers with multiprocessing's "
    "'spawn' or 'forkserver' method to log from them)"
)
_WRITER_CAPACITY = 16 << 20
"""Bytes of messages the writer thread holds at most; more wait on the publisher thread (the pipe's
queue then fills, and drops are counted at the calls)."""
_WRITER_FULL_WAIT_S = 1.0
"""Seconds the publisher thread waits for room in a full writer before it drops (and then, until a message
is written, drops at once): it holds the pipe's lock meanwhile, which `shutdown()` needs."""
_WRITER_STARVED_S = 1.0
"""A message older than this in the writer thread: it is starved (said once)."""
_WRITER_LAST_WRITE_S = 1.0
"""Seconds a write already under way gets to end before its publishers are leaked instead of destroyed."""
_EXIT_YOUNG_S = 4.0
"""A process whose ROS start is more recent than this at exit may not have been discovered by a reader on
the graph yet (measured: a waiting engine lost all the values of 6 of 10 nodes that lived ~1.1 s, none of
22 that lived ~4 s)."""
_EXIT_POLL_S = 0.02
_EXIT_SETTLE_S = 0.5
"""A young process at exit: how long its graph must stay unchanged (no node, subscription or match coming)
before it stops waiting. Discovery tells of participants one by one: having been told of a node that reads
nothing (or of one reader already matched), another reader may be told of a moment later."""
State = Literal["idle", "ready", "no_ros", "forked", "closed"]


def _cdr_round_trips(msg_class: type, spec: ScalarSpec) -> bool:
    """True when our CDR bytes for `spec` decode to the same values through the middleware's serializer."""
    from rclpy.serialization import deserialize_message

    samples: dict[str, list[object]] = {
        "float": [0.0, -1.5, 1e300 if spec.name == "Float64" else 3.0e38],
        "int": [spec.low, spec.high, 1],
        "bool": [True, False],
    }
    try:
        return all(
            deserialize_message(cdr_encoder(spec)(v), msg_class).data == v
            and cdr_encoder(spec)(v) == encode_scalar(spec, v)
            for v in samples[spec.kind]
        )
    except Exception:
        return False


def _leak(obj: object) -> None:
    """Keep `obj` alive forever: a forked child must never finalise the parent's middleware objects."""
    ctypes.pythonapi.Py_IncRef(ctypes.py_object(obj))


class Runtime:
    """Lazily connects to ROS 2 and owns every publisher dbglog creates."""

    def __init__(self, reporter: Reporter) -> None:
        self.reporter = reporter
        self._lock = threading.RLock()
        self.channels: dict[str, Channel] = {}
        """Topic name of a tag (`escape_tag`) -> channel."""
        self.aliases: dict[object, str] = {}
        """Tag as given -> its topic name (plain tags map to themselves)."""
        self.robot = ""
        """The namespace the topics are in while connected (``""``: the root; see `_choose_robot`)."""
        self.env_robot = ""
        """``DBGLOG_NAMESPACE``, normalized (set at import from the configuration)."""
        self._node_robot: str | None = None
        """The namespace of the node given to `init` (kept when dbglog falls back to its own node)."""
        self.fast_float: dict[object, Channel] = {}
        """Tag as given -> its Float64 channel (the hot path queues floats for it without checks)."""
        self.fast_int: dict[object, Channel] = {}
        """Same for Int64."""
        self.fast_bool: dict[object, Channel] = {}
        """Same for Bool."""
        self.fast_str: dict[object, Channel] = {}
        """Same for String."""
        self._fast_tables = {
            "Float64": self.fast_float,
            "Int64": self.fast_int,
            "Bool": self.fast_bool,
            "String": self.fast_str,
        }
        self.pipe = Pipe(self)
        """The queue of scalar samples and the thread that publishes them."""
        self.batch_publish: Callable[[bytes], None] | None = None
        self._batch_publisher: Any = None
        self._writer: Any = None
        """The compiled writer thread (`_new_writer`) of dbglog's own node's messages, or None."""
        self._writer_failed = 0
        self.state: State = "idle"
        self._context: Any = None
        self._node: Any = None
        self._user_node: Any = None
        self._ready_at = 0.0
        """When ROS started (monotonic seconds)."""
        self.exit_wait = 2.0
        """``DBGLOG_EXIT_WAIT``: the most seconds `_await_readers` waits at exit (from the configuration)."""
        self._pid = os.getpid()
        os.register_at_fork(after_in_child=self._after_fork_in_child)
        atexit.register(self._at_exit)

    # ----- tags -----------------------------------------------------------------------------------

    def resolve_tag(self, tag: object, api: str) -> str | None:
        """Return the topic name of `tag` (warning once when it is escaped), or None when it is unusable."""
        clean = self.aliases.get(tag) if isinstance(tag, str) else None
        if clean is not None:
            return clean
        if not isinstance(tag, str):
            self.reporter.drop(
                "bad_tag",
                "type:" + type(tag).__name__,
                f"dbglog.{api}: a tag must be a str, not {type(tag).__name__} ({safe_repr(tag)}); "
                "value dropped",
            )
            return None
        clean = escape_tag(tag)
        robot = self.robot if self.state == "ready" else self._choose_robot()
        if self._too_long(clean, robot, tag, api):
            return None
        with self._lock:
            if len(self.aliases) < 4 * MAX_TAGS:
                self.aliases[tag] = clean
        if clean != tag:
            self.reporter.renamed(
                tag,
                f"dbglog.{api}: tag {safe_repr(tag)} is not a valid ROS 2 name ({tag_problem(tag)}); "
                f"publishing it on {topic_for_tag(clean, robot)} instead",
            )
        return clean

    def _too_long(self, name: str, robot: str, text: str, api: str) -> bool:
        """True (counted, warned once) when the topic of tag `name` would pass rmw's length limit."""
        length = len(topic_for_tag(name, robot))
        if length <= MAX_TOPIC_LENGTH:
            return False
        self.reporter.drop(
            "bad_tag",
            "too_long:" + name,
            f"dbglog.{api}: tag {safe_repr(text)} is too long: its topic would be {length} characters long "
            f"(at most {MAX_TOPIC_LENGTH}); value dropped",
        )
        return True

    def forget_tags(self) -> None:
        """Forget every tag seen (after `shutdown`, for tests)."""
        with self._lock:
            self.aliases.clear()
            for table in self._fast_tables.values():
                table.clear()
        self.pipe.clear()

    # ----- publishers -----------------------------------------------------------------------------

    def channel(self, tag: str, msg_class: type, api: str) -> Channel | None:
        """Return the channel of valid tag `tag` for `msg_class`, creating it on first use."""
        ch = self.channels.get(tag)
        if ch is None:
            with self._lock:
                ch = self.channels.get(tag)
                if ch is None:
                    ch = self._create_channel(tag, msg_class, api)
                    if ch is None:
                        return None
        if ch.msg_class is not msg_class:
            self.reporter.drop(
                "type_conflict",
                f"{tag}:{type_name(msg_class)}",
                f"dbglog.{api}: tag {tag!r} publishes {type_name(ch.msg_class)}; "
                f"a {type_name(msg_class)} value for it was dropped (one type per tag)",
            )
            return None
        return ch

    def _create_channel(self, tag: str, msg_class: type, api: str) -> Channel | None:
        if not self._ensure_ready(api):
            return None
        if len(self.channels) >= MAX_TAGS:
            self.reporter.drop(
                "bad_tag",
                "too_many_tags",
                f"dbglog.{api}: more than {MAX_TAGS} tags; a value for the new tag {tag!r} was dropped",
            )
            return None
        if self._too_long(tag, self.robot, unescape_tag(tag), api):
            return None
        topic = topic_for_tag(tag, self.robot)
        node = self._user_node if self._user_node is not None else self._node
        publisher = node.create_publisher(msg_class, topic, tag_qos())
        spec = scalar_spec(msg_class)
        raw = spec is not None and spec.kind != "str" and _cdr_round_trips(msg_class, spec)
        ch = Channel(tag, topic, msg_class, publisher, spec, raw)
        if ch.encode is not None:
            # The DDS write without the GIL, as the batch's: on the writer thread, or through ctypes
            # (dbglog/_ros/_nogil.py). dbglog's own node: nobody else can destroy these publishers, and this
            # runtime destroys them only under pipe.lock, so the thread may skip rclpy's per-call guard.
            ch.publish_raw = self._raw_publish(publisher) or ch.publish
        self.channels[tag] = ch
        return ch

    def _new_writer(self) -> Any:
        """Start the compiled writer thread (an ordinary thread: docs/api.md says why not ``SCHED_IDLE``);
        or None.

        None without the compiled module or rcl's functions: the publisher thread then writes itself.
        """
        native, addresses = load(), rcl_addresses()
        if native is None or addresses is None:
            return None
        try:
            return native.Writer(*addresses, _WRITER_CAPACITY, _WRITER_FULL_WAIT_S)
        except Exception:  # no thread to be had: the publisher thread writes itself
            return None

    def _raw_publish(self, publisher: Any) -> Callable[[bytes], None] | None:
        """Return the function that writes serialized bytes on `publisher` without the GIL, or None.

        dbglog's own node: through the writer thread, or on the calling thread through ctypes without
        rclpy's per-call handle guard (nobody else destroys these publishers, and this runtime destroys
        them only under the pipe's lock, after the writer thread wrote everything). A user's node: ctypes
        with the guard.
        """
        own = self._user_node is None
        address = publisher_address(publisher) if own and self._writer is not None else None
        if address is not None:
            return functools.partial(self._writer.submit, address)
        return unlocked_publish(publisher, guarded=not own)

    def note_writer(self) -> None:
        """Warn (once each) when the writer thread's rcl writes failed since the last look, or when it is
        starved by other work (publisher thread)."""
        writer = self._writer
        if writer is None:
            return
        stats = writer.stats()
        waited = stats["longest_wait_s"]  # the longest wait since the last look
        if waited >= _WRITER_STARVED_S:
            self.reporter.warn(
                "queue_full",
                "writer_starved",
                f"dbglog: other work keeps the CPUs busy: a message has waited {waited:.1f} s in "
                "dbglog's writer thread to be published, so viewers see the values late (docs/api.md)",
                None,
            )
        failed = stats["failed"]
        if failed > self._writer_failed:
            self.reporter.warn(
                "publish_failed",
                "writer",
                f"dbglog: the middleware refused {failed - self._writer_failed} message(s) "
                "(rcl_publish_serialized_message failed); their samples are lost",
                None,
            )
            self._writer_failed = failed

    def _writer_idle(self, timeout: float) -> bool:
        """Wait until the writer thread wrote what it holds (dropping it after `timeout`); False if still
        writing then: the publishers it writes on must not be destroyed."""
        writer = self._writer
        if writer is None or writer.drain(timeout):
            return True
        writer.discard()
        return bool(writer.drain(_WRITER_LAST_WRITE_S))

    def remember_fast_path(self, given: str, ch: Channel) -> None:
        """Let the hot path of logfloat/logint/logbool/logstring queue `given`'s values for `ch`."""
        if not ch.queued or ch.spec is None or self.channels.get(ch.tag) is not ch:
            return
        table = self._fast_tables.get(ch.spec.name)
        if table is None or table.get(given) is ch:  # known already: no lock, no count on later calls
            return
        with self._lock:
            if sum(len(t) for t in self._fast_tables.values()) >= 4 * MAX_TAGS:
                return
            table[given] = ch

    def enqueue(self, ch: Channel, value: object, api: str) -> None:
        """Queue a checked scalar for the publisher thread; count and warn (once) when the queue is full."""
        pipe = self.pipe
        if len(pipe.queue) >= pipe.capacity:
            self.reporter.drop(
                "queue_full",
                "queue_full",
                f"dbglog.{api}: {pipe.capacity} samples are waiting to be published (the middleware "
                "cannot keep up); values are dropped until the queue drains",
            )
            return
        pipe.queue.append((ch, value, time.time_ns()))
        if pipe.sleeping:
            pipe.wake()

    def send_queued(self, ch: Channel, value: object) -> bool:
        """Publish a queued sample on its tag's topic (publisher thread); False when it was dropped."""
        if not ch.alive:
            current = self.channels.get(ch.tag)
            if current is None or current.msg_class is not ch.msg_class:
                with self._lock:
                    current = self.channels.get(ch.tag)
                    if current is None:
                        current = self._create_channel(ch.tag, ch.msg_class, "log")
            if current is None or current.msg_class is not ch.msg_class:
                return False
            ch = current
        try:
            return self.send(ch, value, "log")
        except Exception:  # strict mode raises on this thread: the user's thread is not here
            return False

    def send(self, ch: Channel, value: object, api: str, *, message: bool = False) -> bool:
        """Publish on `ch`; on failure fall back to dbglog's own node once, else count and warn."""
        try:
            ch.send(value, message=message)
        except Exception as first:
            exc = first
            retry = self._recover(ch)
            if retry is not None:
                try:
                    retry.send(value, message=message)
                except Exception as exc2:
                    exc = exc2
                else:
                    return True
            self.reporter.drop(
                "publish_failed",
                ch.tag,
                f"dbglog.{api}: publishing on {ch.topic} failed ({type(exc).__name__}: {exc}); value dropped",
                exc,
            )
            return False
        return True

    def _recover(self, ch: Channel) -> Channel | None:
        """After a failed publish: if the node we used is gone, start over on our own node."""
        with self.pipe.lock, self._lock:
            if self.state != "ready":
                return None
            context = self._user_node.context if self._user_node is not None else self._context
            try:
                alive = bool(context.ok())
            except Exception:
                alive = False
            if alive:
                return None
            self._drop_ros_objects(destroy=self._user_node is None)
            self._user_node = None
            self.state = "idle"
            return self._create_channel(ch.tag, ch.msg_class, "log")

    # ----- life cycle -----------------------------------------------------------------------------

    def _ensure_ready(self, api: str) -> bool:
        """Connect on first use; return False (counted, warned once) when dbglog cannot publish now."""
        if self.state == "ready":
            return True
        if self.state == "idle":
            return self._start(None, api)
        if self.state == "no_ros":
            self.reporter.drop(
                "no_ros",
                "no_ros",
                f"dbglog.{api}: rclpy cannot be imported, so values are dropped: install dbglog[ros] "
                "or source a ROS 2 Jazzy setup",
            )
        elif self.state == "forked":
            self.reporter.drop("forked", "forked", _FORKED_MESSAGE.format(api=api))
        else:
            self.reporter.count("shut_down")
        return False

    def _choose_robot(self) -> str:
        """The namespace of the topics: the node's given to `init`, else the process's (``--ros-args -r
        __ns:=/robot1`` in ``sys.argv``, as ``ros2 launch`` passes it), else ``DBGLOG_NAMESPACE``."""
        if self._node_robot is not None:
            return self._node_robot
        from_args = ros_args_namespace(getattr(sys, "argv", None) or [])
        return from_args if from_args is not None else self.env_robot

    def _start(self, user_node: Any, api: str) -> bool:
        # rclpy's first node imports modules that warn (lark imports the deprecated sre_parse): a user's
        # -W error::DeprecationWarning must not stop dbglog's own node. catch_warnings swaps a global,
        # so it is held only under the runtime's lock, for this start-up.
        with self._lock, warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            warnings.simplefilter("ignore", PendingDeprecationWarning)
            try:
                import rclpy  # noqa: F401  (the C extension loads here, on first use)
                from rclpy.context import Context
                from rclpy.node import Node
            except Exception as exc:
                self.state = "no_ros"
                self.reporter.drop(
                    "no_ros",
                    "no_ros",
                    f"dbglog.{api}: rclpy cannot be imported ({type(exc).__name__}: {exc}); values are "
                    "dropped: install dbglog[ros] or source a ROS 2 Jazzy setup",
                    exc,
                )
                return False
            self.robot = self._choose_robot()
            if user_node is not None:
                self._user_node = user_node
            else:
                context = Context()
                try:
                    # Our own context: no command-line remapping, no signal handlers, and the user's
                    # logging configuration is left alone.
                    context.init([], initialize_logging=False)
                    self._node = Node(
                        sdk_node_name(os.getpid()),
                        namespace=self.robot,
                        context=context,
                        use_global_arguments=False,
                        enable_rosout=False,
                        start_parameter_services=False,
                    )
                except Exception as exc:
                    with contextlib.suppress(Exception):
                        context.try_shutdown()
                    self.state = "no_ros"
                    self.reporter.drop(
                        "no_ros",
                        "no_ros",
                        f"dbglog.{api}: cannot start ROS 2: creating dbglog's node failed "
                        f"({type(exc).__name__}: {exc}); values are dropped until dbglog.init() succeeds",
                        exc,
                    )
                    return False
                self._context = context
            node = self._user_node if self._user_node is not None else self._node
            try:
                from std_msgs.msg import UInt8MultiArray

                self._batch_publisher = node.create_publisher(
                    UInt8MultiArray, batch_topic(self.robot), batch_qos()
                )
                if self._user_node is None and self._writer is None:
                    self._writer = self._new_writer()
                # The DDS write without the GIL: the caller's threads run meanwhile.
                self.batch_publish = self._raw_publish(self._batch_publisher) or self._batch_publisher.publish
            except Exception as exc:
                self._batch_publisher = self.batch_publish = None
                self.reporter.warn(
                    "publish_failed",
                    "batch_publisher",
                    f"dbglog.{api}: cannot create the batch publisher on {batch_topic(self.robot)} "
                    f"({type(exc).__name__}: {exc}); the viewer falls back to the per-tag topics",
                    exc,
                )
            self.pipe.new_writer()
            self._pid = os.getpid()
            self._ready_at = time.monotonic()
            self.state = "ready"
            return True

    def init(self, node: Any = None) -> None:
        """Connect now: on `node` when given, else on dbglog's own context and node."""
        if node is not None and not callable(getattr(node, "create_publisher", None)):
            raise TypeError(f"node must be an rclpy Node, not {type(node).__name__}")
        robot = None
        if node is not None:
            try:
                robot = normalize_robot(str(node.get_namespace()))
            except TagError as exc:
                raise ValueError(
                    f"dbglog.init: the node's namespace cannot hold dbglog's topics: {exc}"
                ) from None
        if self.state == "ready":
            self.shutdown()  # before taking the lock: locks are always taken publisher-thread lock first
        # The pipe lock too, in that order: the branch below destroys publishers, which only ever happens
        # under the pipe lock (the publisher thread publishes through their raw handles).
        with self.pipe.lock, self._lock:
            if self.state == "forked":
                self.reporter.warn("forked", "init", _FORKED_MESSAGE.format(api="init"), None)
                return
            if self.state == "ready":
                self._drop_ros_objects(destroy=True)
                self._user_node = None
            self._node_robot = robot
            self.state = "idle"
            self._start(node, "init")

    def flush(self, timeout: float) -> bool:
        """Wait up to `timeout` seconds in total until every subscriber acknowledged every message."""
        deadline = time.monotonic() + timeout
        ok = self.pipe.drain(timeout)
        if self.state != "ready":
            return ok
        if self._writer is not None:
            ok = bool(self._writer.drain(max(0.0, deadline - time.monotonic()))) and ok
        from rclpy.duration import Duration

        publishers = [ch.publisher for ch in list(self.channels.values())]
        if self._batch_publisher is not None:
            publishers.append(self._batch_publisher)
        for publisher in publishers:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return False
            try:
                if publisher.get_subscription_count() > 0:
                    ok = bool(publisher.wait_for_all_acked(Duration(seconds=remaining))) and ok
            except Exception:
                ok = False
        return ok

    def _await_readers(self, budget: float) -> None:
        """At exit, wait up to `budget` seconds for dbglog's readers on the graph to match the batch writer.

        A reader that has not matched the writer when it goes loses everything the process logged (its
        writers take their kept history with them), and `flush` waits only for readers already matched. So
        the exit waits while the graph shows a subscription to the batch topic that the writer has not
        matched yet; and while the process is younger than `_EXIT_YOUNG_S`, while a dbglog reader's node
        (`is_reader_node`) is on the graph without subscribing to it yet (an engine subscribes at its next
        graph poll, a recorder when it records the tags), or no other node is on it at all (discovery has
        not told this process of the others yet: it may take a participant's next announcement, 3 s).
        With other nodes on the graph and no reader among them waiting, it waits only until the graph has
        not changed for `_EXIT_SETTLE_S` (discovery tells of the other participants one by one).
        """
        publisher = self._batch_publisher
        node = self._user_node if self._user_node is not None else self._node
        if budget <= 0 or publisher is None or node is None or not self.channels:
            return
        topic = batch_topic(self.robot)
        now = time.monotonic()
        deadline = now + budget
        young_until = self._ready_at + _EXIT_YOUNG_S
        seen: object = None
        changed_at = now
        try:
            while now < deadline:
                infos = node.get_subscriptions_info_by_topic(topic)
                matched = publisher.get_subscription_count()
                if len(infos) <= matched:  # every subscription matched
                    if now >= young_until:
                        return
                    subscribed = {(i.node_namespace, i.node_name) for i in infos}
                    nodes = [(ns, name) for name, ns in node.get_node_names_and_namespaces()]
                    graph = (frozenset(nodes), frozenset(subscribed), matched)
                    if graph != seen:
                        seen, changed_at = graph, now
                    alone = all(n == (node.get_namespace(), node.get_name()) for n in nodes)
                    coming = any(is_reader_node(n[1]) and n not in subscribed for n in nodes)
                    if not (alone or coming) and now - changed_at >= _EXIT_SETTLE_S:
                        return
                time.sleep(_EXIT_POLL_S)
                now = time.monotonic()
        except Exception:  # the node or its context is gone (a user's node destroyed first): go on exiting
            return

    def shutdown(self) -> None:
        """Publish what is queued, then destroy every publisher (and dbglog's own node and context)."""
        self.pipe.drain(_EXIT_FLUSH_SECONDS)
        with self.pipe.lock, self._lock:
            if self.state == "ready":
                self._drop_ros_objects(destroy=True)
            self._user_node = None
            self._node_robot = None
            if self.state in ("ready", "no_ros"):
                self.state = "idle"

    def _drop_ros_objects(self, *, destroy: bool) -> None:
        channels = list(self.channels.values())
        self.channels.clear()
        for table in self._fast_tables.values():
            table.clear()
        for ch in channels:
            ch.alive = False
        batch, self._batch_publisher, self.batch_publish = self._batch_publisher, None, None
        node, context = self._node, self._context
        self._node = self._context = None
        if not destroy:
            return
        if not self._writer_idle(_EXIT_FLUSH_SECONDS):  # a write under way on these publishers
            for obj in (*channels, batch, node, context):
                if obj is not None:
                    _leak(obj)
            return
        owner = self._user_node if self._user_node is not None else node
        # Each may fail when the node or context is already gone: nothing is left to release then.
        for publisher in [ch.publisher for ch in channels] + ([batch] if batch is not None else []):
            with contextlib.suppress(Exception):
                owner.destroy_publisher(publisher)
        if node is not None:
            with contextlib.suppress(Exception):
                node.destroy_node()
        if context is not None:
            with contextlib.suppress(Exception):
                context.try_shutdown()

    def _forget_parent_objects(self) -> None:
        for obj in (
            *self.channels.values(),
            self._batch_publisher,
            self._node,
            self._context,
            self._user_node,
        ):
            if obj is not None:
                _leak(obj)
        self._batch_publisher = self.batch_publish = None
        self.channels.clear()
        for table in self._fast_tables.values():
            table.clear()
        self._node = self._context = self._user_node = None

    def _after_fork_in_child(self) -> None:
        # Locks may have been held by another thread at the fork: start with fresh ones.
        self._lock = threading.RLock()
        self._writer = None  # the parent's thread: its object does nothing here (a new one on start)
        self.reporter.after_fork()
        self.pipe.after_fork_in_child()
        if self.state == "ready":
            self._forget_parent_objects()
        if self.state == "ready" or "rclpy" in sys.modules:
            # The parent may have started the middleware, whose threads did not survive the fork: a
            # new context in the child publishes into the void and cannot exit cleanly. Stay quiet.
            self.state = "forked"
        self._pid = os.getpid()

    def _at_exit(self) -> None:
        if self.state != "ready" or os.getpid() != self._pid:
            self.state = "closed" if self.state != "forked" else self.state
            return
        try:
            self.pipe.drain(_EXIT_DRAIN_SECONDS)
            self._await_readers(self.exit_wait)
            self.flush(_EXIT_FLUSH_SECONDS)
        finally:
            # The publisher thread publishes only under pipe.lock: it is never mid-publish here.
            got = self.pipe.lock.acquire(timeout=_EXIT_FLUSH_SECONDS)
            try:
                with self._lock:
                    self._drop_ros_objects(destroy=True)
                    self._user_node = None
                    self.state = "closed"
            finally:
                if got:
                    self.pipe.lock.release()
