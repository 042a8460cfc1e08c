"""Write the samples of SDK batches as messages of their tags' own topics (one numpy pass per tag).

The recorder does not subscribe to a tag topic that only dbglog SDK nodes publish: a subscriber there
makes the SDK publish every sample as its own DDS message besides the batch (50 tags at 1 kHz = 50,000
messages/s that both sides pay for). It takes the batches instead and writes each sample as the message
the tag's topic would have carried (same type and CDR bytes, publish time = the sample's source time),
so every other MCAP tool still reads ``/rosdashboard/<tag>``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from dbglog._ros._batch import BatchError, batch_topic, decode_batch
from dbglog._ros._cdr import CDR_HEADER, string_payload
from dbglog._ros._tags import topic_for_tag

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from dbglog.record._writer import McapWriter

__all__ = ["BatchCounter", "BatchExpander"]

_BODY: dict[str, tuple[str, int]] = {
    "Float64": ("<f8", 8),
    "Float32": ("<f4", 4),
    "Int8": ("i1", 4),
    "Int16": ("<i2", 4),
    "Int32": ("<i4", 4),
    "Int64": ("<i8", 8),
    "UInt8": ("u1", 4),
    "UInt16": ("<u2", 4),
    "UInt32": ("<u4", 4),
    "UInt64": ("<u8", 8),
    "Bool": ("u1", 4),
}
"""numpy dtype of each scalar's field and its CDR body size (padded to 4, as `SCALAR_FORMATS`)."""
_HEADER = list(CDR_HEADER)


class BatchExpander:
    """Write the samples of batch messages into `out` as messages of the tags `wanted` selects.

    Args:
        out: the MCAP writer.
        wanted: topic -> True when that tag topic is to be written from the batches.
    """

    def __init__(self, out: McapWriter, wanted: Callable[[str], bool]) -> None:
        self.out = out
        self.wanted = wanted
        self._channels: dict[tuple[str, str], int] = {}
        self._last_seq: dict[int, int] = {}
        """Batch writer -> newest batch number expanded (history re-sent on re-subscribing is skipped)."""
        self.topics: set[str] = set()
        """Tag topics written from the batches so far."""
        self.bad = 0
        """Batch messages that could not be decoded (kept in the batch topic, not expanded)."""
        self.missing = 0
        """Batches never received: gaps in a writer's batch numbers (lost in DDS, or not sent by the SDK)."""

    def expand(
        self, log_time: int, cdr: bytes, robot: str = "", wanted: Callable[[str], bool] | None = None
    ) -> int:
        """Write the samples of one batch message (CDR bytes) of `robot`'s batch topic; return how many
        were written.

        `wanted` overrides the expander's own choice of tag topics for this batch.
        """
        import numpy as np

        try:
            batch = decode_batch(cdr)
        except BatchError:
            self.bad += 1
            return 0
        last = self._last_seq.get(batch.writer)
        if last is not None and batch.seq <= last:
            return 0
        if last is not None:
            self.missing += batch.seq - last - 1
        self._last_seq[batch.writer] = batch.seq
        wanted = wanted or self.wanted
        out = self.out
        written = 0
        groups: dict[str, tuple[list[int], list[npt.NDArray[np.int64]], list[npt.NDArray[Any]]]] = {}
        for samples in batch.tags:
            topic = topic_for_tag(samples.tag, robot)
            if not wanted(topic):
                continue
            msg_type = f"std_msgs/msg/{samples.std_type}"
            channel = self._channels.get((topic, msg_type))
            if channel is None:
                channel = out.add_channel(topic, msg_type, metadata={"dbglog_from": batch_topic(robot)})
                self._channels[(topic, msg_type)] = channel
                self.topics.add(topic)
            if isinstance(samples.values, list):  # String: variable length, one message each
                for text, stamp in zip(samples.values, samples.times_ns.tolist(), strict=True):
                    out.write(channel, log_time, string_payload(text), stamp)
                written += len(samples.values)
            elif samples.std_type in _BODY:
                chans, times, values = groups.setdefault(samples.std_type, ([], [], []))
                chans.extend([channel] * len(samples.times_ns))
                times.append(samples.times_ns)
                values.append(samples.values)
        # One numpy pass per scalar type over every tag of the batch (not one per tag: a batch holds a
        # few samples of each of many tags, and numpy's per-call cost would dominate).
        for std_type, (chans, times, values) in groups.items():
            dtype, size = _BODY[std_type]
            item = np.dtype(dtype).itemsize
            v = np.concatenate(values) if len(values) > 1 else values[0]
            n = len(v)
            rows = np.zeros((n, 4 + size), dtype=np.uint8)
            rows[:, :4] = _HEADER
            # The batch's dtype (int64/uint64 exact, bool) cast to the field's: every integer kept as sent.
            rows[:, 4 : 4 + item] = v.astype(dtype).view(np.uint8).reshape(n, item)
            t = np.concatenate(times) if len(times) > 1 else times[0]
            out.write_fixed(np.array(chans, dtype=np.int64), np.full(n, log_time, dtype=np.int64), rows, t)
            written += n
        return written


def _written(samples: Any) -> int:
    """How many messages `BatchExpander.expand` writes for one tag's samples of a batch."""
    if isinstance(samples.values, list):  # String
        return len(samples.values)
    return len(samples.times_ns) if samples.std_type in _BODY else 0


class BatchCounter:
    """Count, as batches arrive, the messages `BatchExpander.expand` will write for them (snapshot mode).

    A batch seen before (its writer's history re-sent) counts 0, as `expand` skips it.
    """

    def __init__(self) -> None:
        self._last_seq: dict[int, int] = {}

    def count(self, cdr: bytes, wanted: Callable[[str], bool], robot: str = "") -> int:
        """Return how many messages the batch `cdr` expands to (tags `wanted` selects; 0 if undecodable)."""
        try:
            batch = decode_batch(cdr)
        except BatchError:
            return 0
        last = self._last_seq.get(batch.writer)
        if last is not None and batch.seq <= last:
            return 0
        self._last_seq[batch.writer] = batch.seq
        return sum(_written(s) for s in batch.tags if wanted(topic_for_tag(s.tag, robot)))
