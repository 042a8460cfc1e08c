"""The regex bridge: turn numbers in the log lines nodes already write into typed ``/rosdashboard`` tags.

Rules and matching are pure Python (no rclpy); the ROS node lives in ``_node``. Every name is loaded
on first use (module ``__getattr__``), so importing a sub-module loads neither the RE2-Set matcher
nor the YAML rules loader.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from dbglog._regex._compile import MAX_LINE, RegexError, compile_regex, parse_number
    from dbglog.regex_bridge._engine import Matcher, MatcherStats, Unparseable, Value
    from dbglog.regex_bridge._rules import (
        LEVELS,
        Output,
        Problem,
        Rule,
        RulesError,
        RuleSet,
        load_rules,
        parse_rules,
    )

__all__ = [
    "LEVELS",
    "MAX_LINE",
    "Matcher",
    "MatcherStats",
    "Output",
    "Problem",
    "RegexError",
    "Rule",
    "RuleSet",
    "RulesError",
    "Unparseable",
    "Value",
    "compile_regex",
    "load_rules",
    "parse_number",
    "parse_rules",
]

_HOMES = {
    "dbglog._regex._compile": ("MAX_LINE", "RegexError", "compile_regex", "parse_number"),
    "dbglog.regex_bridge._engine": ("Matcher", "MatcherStats", "Unparseable", "Value"),
    "dbglog.regex_bridge._rules": (
        "LEVELS",
        "Output",
        "Problem",
        "Rule",
        "RuleSet",
        "RulesError",
        "load_rules",
        "parse_rules",
    ),
}
_HOME_OF = {name: module for module, names in _HOMES.items() for name in names}


def __getattr__(name: str) -> Any:
    """Load an exported name from its module on first use."""
    module = _HOME_OF.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """List the exported names with the module's own."""
    return sorted({*globals(), *__all__})
