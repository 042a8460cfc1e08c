"""MCAP files in every layout the ``mcap`` library's writer offers, for the tests of reading them."""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

from geometry_msgs.msg import Twist
from mcap.writer import CompressionType, IndexType, Writer
from rclpy.serialization import serialize_message
from std_msgs.msg import Float64, Int32

from dbglog.record._msgdef import message_definition

__all__ = ["LAYOUTS", "T0", "TOPICS", "Layout", "N", "write"]

T0 = 1_700_000_000_000_000_000
N = 50
TOPICS = {
    "/rosdashboard/speed": "std_msgs/msg/Float64",
    "/rosdashboard/count": "std_msgs/msg/Int32",
    "/cmd_vel": "geometry_msgs/msg/Twist",
}


_FLAGS = (IndexType.CHUNK, IndexType.MESSAGE, IndexType.ATTACHMENT, IndexType.METADATA)


@dataclass(frozen=True)
class Layout:
    """One combination of the `mcap` writer's options."""

    chunked: bool
    compression: CompressionType
    index: IndexType
    schemas: bool
    channels: bool
    statistics: bool
    offsets: bool
    crcs: bool

    def __str__(self) -> str:
        parts = [
            f"chunked-{self.compression.name.lower()}" if self.chunked else "unchunked",
            "index-" + "+".join(f"{f.name}".lower() for f in _FLAGS if f & self.index)
            if self.index != IndexType.NONE
            else "no-index",
            *(name for name, on in (("schemas", self.schemas), ("channels", self.channels)) if on),
            *(name for name, on in (("stats", self.statistics), ("offsets", self.offsets)) if on),
        ]
        return ",".join(parts)


def _layouts() -> list[Layout]:
    """Every layout that changes what a reader finds (CRCs alternate: they change no structure)."""
    out: list[Layout] = []
    indexes = [IndexType.NONE, IndexType.CHUNK, IndexType.MESSAGE, IndexType.CHUNK | IndexType.MESSAGE]
    flags = list(itertools.product([True, False], repeat=4))
    for chunked in (True, False):
        compressions = list(CompressionType) if chunked else [CompressionType.NONE]
        for compression, index, (schemas, channels, statistics, offsets) in itertools.product(
            compressions, indexes, flags
        ):
            crcs = len(out) % 2 == 0
            out.append(Layout(chunked, compression, index, schemas, channels, statistics, offsets, crcs))
    return out


LAYOUTS = _layouts()


def _twist(i: int) -> Twist:
    msg = Twist()
    msg.linear.x = i * 0.25
    return msg


def write(path: Path, layout: Layout, n: int = N, *, chunk_size: int = 1024) -> Path:
    """Write `n` messages on each of the three topics with the `mcap` writer in `layout`."""
    with path.open("wb") as f:
        w = Writer(
            f,
            chunk_size=chunk_size,
            compression=layout.compression,
            index_types=layout.index,
            repeat_schemas=layout.schemas,
            repeat_channels=layout.channels,
            use_chunking=layout.chunked,
            use_statistics=layout.statistics,
            use_summary_offsets=layout.offsets,
            enable_crcs=layout.crcs,
        )
        w.start(profile="ros2", library="mcap-python")
        channels = {}
        for topic, msg_type in TOPICS.items():
            schema = w.register_schema(msg_type, "ros2msg", (message_definition(msg_type) or "").encode())
            channels[topic] = w.register_channel(topic, "cdr", schema)
        for i in range(n):
            t = T0 + i * 10_000_000
            for topic, payload in (
                ("/rosdashboard/speed", serialize_message(Float64(data=i * 0.5))),
                ("/rosdashboard/count", serialize_message(Int32(data=i - 20))),
                ("/cmd_vel", serialize_message(_twist(i))),
            ):
                w.add_message(channels[topic], log_time=t + 7, data=payload, publish_time=t)
        w.finish()  # type: ignore[no-untyped-call]
    return path
