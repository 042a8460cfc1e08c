"""The live viewer: a headless data engine (ROS topics → series) and a Dear PyGui dashboard on top of it.

``Engine`` imports rclpy only when started; nothing here imports Dear PyGui (the UI lives in ``_ui``).
Widget authors use ``dbglog.viewer.widget_api``.
"""

from __future__ import annotations

from dbglog.viewer._data._engine import Engine
from dbglog.viewer._data._model import (
    Binding,
    DataSource,
    FieldInfo,
    SeriesSnapshot,
    Status,
    TopicInfo,
    ValueKind,
)

__all__ = [
    "Binding",
    "DataSource",
    "Engine",
    "FieldInfo",
    "SeriesSnapshot",
    "Status",
    "TopicInfo",
    "ValueKind",
]
