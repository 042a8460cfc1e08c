"""The SDK's optional compiled part (``_hot.c``): loaded once, unless it is missing or switched off."""

from __future__ import annotations

import os
from types import ModuleType

__all__ = ["HOT_PATH_ENV", "load"]

HOT_PATH_ENV = "DBGLOG_PURE_PYTHON"
"""Set to 1 to keep the Python functions (the compiled module is then not even imported)."""


def load() -> ModuleType | None:
    """Return the compiled module ``dbglog.api._hot``, or None (not built here, or switched off)."""
    if os.environ.get(HOT_PATH_ENV, "") not in ("", "0"):
        return None
    try:
        from dbglog.api import _hot
    except ImportError:  # installed without a C compiler: the Python functions do the same, slower
        return None
    return _hot
