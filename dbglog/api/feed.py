"""The SDK's queue and publisher thread, for other dbglog packages that publish tags (the watch agent).

Not part of dbglog's public API. A sample is queued as the logging calls queue theirs: ``(channel,
value, source time ns)`` appended to `QUEUE`, the publisher thread woken if it sleeps; the batch and the
tag's topic carry it. Work that creates publishers or builds messages (a new tag, an array) goes to the
publisher thread with `call_soon`, never to the caller's thread. Import only when dbglog is on.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Final

from dbglog.api._channel import Channel
from dbglog.api._convert import ConversionError, multiarray_message
from dbglog.api._public import RUNTIME, _std_type

__all__ = [
    "PIPE",
    "QUEUE",
    "Channel",
    "ConversionError",
    "array_message",
    "call_soon",
    "channel_type",
    "connect",
    "connected",
    "enqueue",
    "resolve_tag",
    "robot",
    "scalar_channel",
    "send_message",
    "writer",
]

PIPE: Final = RUNTIME.pipe
"""The publisher thread's pipe: ``capacity``, ``sleeping`` and ``wake()`` for the hot path."""
QUEUE: Final = PIPE.queue
"""The queue of ``(channel, value, source time ns)`` samples (append only, from any thread)."""
_API: Final = "watch"


def call_soon(fn: Callable[[], object]) -> None:
    """Run `fn` on the publisher thread before its next flush."""
    PIPE.call_soon(fn)


def enqueue(ch: Channel, value: object, stamp_ns: int) -> bool:
    """Queue a checked scalar for `ch` with its source time; False (nothing queued) when the queue is full."""
    if len(QUEUE) >= PIPE.capacity:
        return False
    QUEUE.append((ch, value, stamp_ns))
    if PIPE.sleeping:
        PIPE.wake()
    return True


def connect() -> bool:
    """Connect the SDK to ROS now if it is not (its node, batch writer); False when it cannot."""
    return bool(RUNTIME._ensure_ready(_API))


def connected() -> bool:
    """True while the SDK is connected to ROS (its node and batch writer are up)."""
    return RUNTIME.state == "ready"


def robot() -> str:
    """The robot namespace of the SDK's topics while connected (``""``: the root; ``/robot1``): its batch
    is on ``batch_topic(robot)``, a tag on ``topic_for_tag(tag, robot)``."""
    return str(RUNTIME.robot)


def writer() -> int:
    """The batch writer id of this process's SDK connection (``DecodedBatch.writer`` of its batches)."""
    return int(PIPE.writer)


def resolve_tag(tag: str) -> str | None:
    """Return the tag the SDK publishes `tag` under (the logging calls' tag rules), or None."""
    return RUNTIME.resolve_tag(tag, _API)


def channel_type(tag: str) -> type | None:
    """The message class the SDK already publishes on valid tag `tag`, or None."""
    ch = RUNTIME.channels.get(tag)
    return None if ch is None else ch.msg_class


def scalar_channel(tag: str, std_type: str) -> Channel | None:
    """Return the channel of valid tag `tag` for std_msgs scalar `std_type` (``Float64`` ...), creating it
    (publisher thread: it may create a publisher); None when it cannot be had."""
    return RUNTIME.channel(tag, _std_type(std_type), _API)


def array_message(value: Any) -> Any:
    """Return the ``*MultiArray`` message of a numeric array (numpy array, sequence of numbers, bytes).

    Raises:
        ConversionError: the value is not an array the SDK publishes.
    """
    return multiarray_message(value)


def send_message(tag: str, msg: Any) -> bool:
    """Publish a message on valid tag `tag` now (publisher thread); False when it was not sent."""
    ch = RUNTIME.channel(tag, type(msg), _API)
    return ch is not None and RUNTIME.send(ch, msg, _API, message=True)
