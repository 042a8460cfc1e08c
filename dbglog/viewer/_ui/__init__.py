"""The Dear PyGui viewer: window, canvas, dialogs. Import only on the UI thread that will run it."""

from __future__ import annotations

from dbglog.viewer._data._static_source import StaticSource
from dbglog.viewer._ui._app import PAYLOAD_TYPE, ViewerApp

__all__ = ["PAYLOAD_TYPE", "StaticSource", "ViewerApp"]
