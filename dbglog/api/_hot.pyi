"""The compiled hot path of dbglog's scalar logging functions, its switched-off no-ops (``_hot.c``), and
the publisher thread's per-sample work (``_flush.c``)."""

from collections import deque
from collections.abc import Callable, Iterator
from typing import Any

class HotCall:
    """A logging function whose common case runs in C (the Python function decides the rest)."""

    slow: Callable[..., None]
    __name__: str
    __qualname__: str
    __wrapped__: Callable[..., None]
    def __init__(
        self,
        slow: Callable[..., None],
        kind: int,
        table: dict[object, Any],
        queue: deque[Any],
        pipe: Any,
        calls: Iterator[int],
        rate_limited: Iterator[int],
        clock: Callable[[], float],
        max_chars: int,
        *,
        channel_type: type | None = None,
        site_type: type | None = None,
    ) -> None: ...
    def __call__(self, *args: Any, **kwargs: Any) -> None: ...

class NoOp:
    """A switched-off logging function: a call with its positional arguments and keyword options
    returns at once, any other shape goes to the Python no-op (which refuses what is refused on)."""

    slow: Callable[..., None]
    __name__: str
    __qualname__: str
    __wrapped__: Callable[..., None]
    def __init__(self, slow: Callable[..., None], positional: int, options: tuple[str, ...]) -> None: ...
    def __call__(self, *args: Any, **kwargs: Any) -> None: ...

def take(queue: deque[Any], limit: int, /) -> list[Any]:
    """Pop up to `limit` samples from the queue's left end (fewer if it empties meanwhile)."""

def pack_batch(
    items: list[Any], writer: int | None, seq: int, breathe_ns: int, /
) -> tuple[list[Any], list[object], bytes | None]:
    """The samples' channels (first seen first), each one's last value, and the batch message's bytes."""

class Writer:
    """A thread that writes serialized messages with rcl, in order, without the GIL (``_writer.c``)."""

    native_id: int
    def __init__(self, publish: int, reset: int, capacity: int, full_wait: float = 1.0) -> None: ...
    def submit(self, publisher: int, data: bytes, /) -> None:
        """Queue a copy of `data` for the rcl publisher at that address (BufferError: full `full_wait` s)."""
    def drain(self, timeout: float, /) -> bool:
        """Wait until everything submitted is written; False when `timeout` ran out."""
    def discard(self) -> int:
        """Drop what is queued and not yet being written; how many messages."""
    def stop(self) -> None:
        """Write what is queued, then end the thread."""
    def stats(self) -> dict[str, Any]:
        """Messages written and refused by rcl, bytes queued, one being written, the oldest's wait (s)."""
