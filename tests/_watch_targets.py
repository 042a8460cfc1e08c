"""Load tests/data/watch/targets.py as a module of its own and find its marked lines."""

from __future__ import annotations

import importlib.util
import sys
import types
from pathlib import Path

TARGETS = Path(__file__).resolve().parent / "data" / "watch" / "targets.py"


def load_targets() -> types.ModuleType:
    """Import targets.py once (as ``watch_targets``), as a program's module would be loaded."""
    module = sys.modules.get("watch_targets")
    if module is None:
        spec = importlib.util.spec_from_file_location("watch_targets", TARGETS)
        assert spec is not None
        assert spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules["watch_targets"] = module
        spec.loader.exec_module(module)
    return module


def line_of(marker: str, path: Path = TARGETS) -> int:
    """The number of the line that ends with ``# L:<marker>``."""
    for number, text in enumerate(path.read_text().splitlines(), 1):
        if text.rstrip().endswith(f"# L:{marker}") or f"# L:{marker} " in text:
            return number
    raise LookupError(marker)
