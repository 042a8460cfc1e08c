"""Recordings: write dbglog tags and ROS topics to MCAP files (ROS 2 profile) and read them back fast."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from dbglog.record._reader import Recording, TopicData, read_recording
    from dbglog.record._writer import McapWriter, RecordingError

__all__ = ["McapWriter", "Recording", "RecordingError", "TopicData", "read_recording"]

_WHERE = {
    "McapWriter": "dbglog.record._writer",
    "RecordingError": "dbglog.record._writer",
    "Recording": "dbglog.record._reader",
    "TopicData": "dbglog.record._reader",
    "read_recording": "dbglog.record._reader",
}


def __getattr__(name: str) -> Any:
    """Import the MCAP machinery (numpy, mcap, zstandard) only when a name is used."""
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'dbglog.record' has no attribute {name!r}")
