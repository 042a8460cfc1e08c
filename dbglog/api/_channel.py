"""One tag's channel: its topic, message type and publisher, and how its samples go out.

Shared by the runtime (which makes channels) and the publisher thread's pipe (which sends their samples):
neither module imports the other for it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from dbglog._ros._batch import SCALAR_TYPES, type_code
from dbglog._ros._cdr import scalar_encoder
from dbglog.api._convert import ScalarSpec
from dbglog.api._rate import Known

__all__ = ["LISTEN_CHECK_S", "Channel", "cdr_encoder"]

LISTEN_CHECK_S = 0.1
"""How often a tag's subscriber count is looked up (a C call)."""
NEW_TAG_S = 5.0
"""A tag sends every sample on its topic for this long after its publisher is created, so a subscriber
that is still being matched (discovery takes a moment) misses nothing."""


class Channel:
    """One tag's topic, message type and publisher (and, for scalars, its place in a batch)."""

    __slots__ = (
        "alive",
        "checked",
        "code",
        "created",
        "encode",
        "listening",
        "msg_class",
        "newest_sent",
        "publish",
        "publish_raw",
        "publisher",
        "queued",
        "rate_site",
        "spec",
        "tag",
        "tag_bytes",
        "topic",
    )

    def __init__(
        self, tag: str, topic: str, msg_class: type, publisher: Any, spec: ScalarSpec | None, raw: bool
    ) -> None:
        self.tag = tag
        self.tag_bytes = tag.encode()
        self.topic = topic
        self.msg_class = msg_class
        self.publisher = publisher
        self.publish: Callable[[object], None] = publisher.publish
        self.publish_raw: Callable[[bytes], None] = publisher.publish
        """Publishes CDR bytes (the publisher thread's fast path)."""
        self.spec = spec
        self.alive = True
        """False once the publisher was destroyed (samples still queued for it go to its successor)."""
        self.created = self.checked = time.monotonic()
        self.listening = True
        """Someone subscribes to the tag's topic (looked up every `LISTEN_CHECK_S`)."""
        self.encode: Callable[[object], bytes] | None = None
        if spec is not None and raw:
            self.encode = cdr_encoder(spec)
        self.queued = (
            spec is not None and spec.name in SCALAR_TYPES and msg_class.__module__.startswith("std_msgs.")
        )
        """Scalar std_msgs values go through the queue and the batch; other messages are sent at once."""
        self.code = type_code(spec.name) if self.queued and spec is not None else 0
        """The tag's type code in a batch (`SCALAR_TYPES`): its value slot, Float32 rounding, String texts."""
        self.newest_sent = -math.inf
        """When the tag's newest value last went on its topic while nobody subscribed (publisher thread)."""
        self.rate_site: Known | None = None
        """The call instruction that last used rate options on this tag (the hot path checks it first)."""

    def listened(self, now: float) -> bool:
        """True when the tag's topic has a subscriber (or the tag is new): then it gets every sample."""
        if now - self.checked > LISTEN_CHECK_S:
            self.checked = now
            try:
                self.listening = now - self.created < NEW_TAG_S or self.publisher.get_subscription_count() > 0
            except Exception:
                self.listening = True
        return self.listening

    def send(self, value: object, *, message: bool) -> None:
        """Publish a message, or a checked scalar value (as CDR bytes when verified)."""
        if message:
            self.publish(value)
        elif self.encode is not None:
            self.publish(self.encode(value))
        else:
            self.publish(self.msg_class(data=value))


def cdr_encoder(spec: ScalarSpec) -> Callable[[object], bytes]:
    """Return value -> CDR bytes of `spec` as one C call (`encode_scalar`'s bytes, header included)."""
    return scalar_encoder(spec.fmt)
