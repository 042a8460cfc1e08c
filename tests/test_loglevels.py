"""Log levels and logger-name matching, written once on the ground floor (console, CLI, bridge)."""

from __future__ import annotations

import argparse
import fnmatch

import pytest
from hypothesis import given
from hypothesis import strategies as st

from dbglog._ros import _loglevels
from dbglog._ros._loglevels import LEVEL_NAMES, LEVELS, WARN, level_name, level_of, node_matches
from dbglog.regex_bridge import _rules
from dbglog.viewer._cli import _cli_logs
from dbglog.viewer._data import _logstore


def test_the_three_users_share_one_table() -> None:
    """The console's store, dbglog logs and the bridge's rules use the ground floor's levels and matcher."""
    assert _logstore.LEVEL_NAMES is LEVEL_NAMES
    assert _logstore.level_of is level_of
    assert _cli_logs.LEVELS is LEVELS
    assert _rules.LEVELS is LEVELS
    assert dict(LEVELS) == {"debug": 10, "info": 20, "warn": 30, "error": 40, "fatal": 50}
    assert {n: LEVELS[name.lower()] for n, name in LEVEL_NAMES.items()} == {n: n for n in LEVEL_NAMES}


def test_level_names_read_and_shown() -> None:
    """Names read in any case, warning as warn, empty as every line; unknown ones named in the error."""
    assert level_of(" Warning ") == level_of("WARN") == WARN
    assert level_of("") == 0
    assert (level_name(40), level_name(0), level_name(35)) == ("ERROR", "", "35")
    with pytest.raises(ValueError, match=r"unknown level 'loud' \(one of: debug, info, warn, error, fatal\)"):
        level_of("loud")


def test_cli_level_option_keeps_its_messages() -> None:
    """dbglog logs --level accepts warning and refuses an empty or unknown name with the same message."""
    assert _cli_logs._level("warning") == WARN
    for bad in ("", "loud"):
        with pytest.raises(argparse.ArgumentTypeError, match="one of: debug, info, warn, error, fatal"):
            _cli_logs._level(bad)


@given(
    st.text(alphabet="ab_.*?[]!", max_size=8),
    st.text(alphabet="ab_.", max_size=8),
)
def test_node_matches_is_fnmatchcase(pattern: str, logger: str) -> None:
    """A logger pattern is an exact name without glob characters, else fnmatch's case-sensitive glob."""
    assert node_matches(logger, pattern) == fnmatch.fnmatchcase(logger, pattern)
    assert _loglevels.is_glob(pattern) == any(c in pattern for c in "*?[")
