"""The viewer's widgets: the built-in classes and the registry that also loads plugins."""

from __future__ import annotations

from dbglog.viewer._widgets._registry import BUILTIN_WIDGETS, ENTRY_POINT_GROUP, WidgetRegistry

__all__ = ["BUILTIN_WIDGETS", "ENTRY_POINT_GROUP", "WidgetRegistry"]
