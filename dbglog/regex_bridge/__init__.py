"""The regex bridge: turn numbers in the log lines nodes already write into typed ``/rosdashboard`` tags.

Rules and matching are pure Python (no rclpy); the ROS node lives in ``_node`` and is imported lazily.
"""

from dbglog.regex_bridge._engine import Matcher, MatcherStats, Unparseable, Value
from dbglog.regex_bridge._regex import MAX_LINE, RegexError, compile_regex, parse_number
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
