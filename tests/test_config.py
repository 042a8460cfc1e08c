"""Environment parsing: the accepted switch words, defaults, and clear errors naming the variable."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from dbglog._config import ConfigError, env_bool, env_float, load_config

TRUE_WORDS = ["1", "true", "yes", "on", "TRUE", " On "]
FALSE_WORDS = ["0", "false", "no", "off", "OFF", " No"]


@pytest.mark.parametrize("word", TRUE_WORDS)
def test_true_words_enable(word: str) -> None:
    """1/true/yes/on in any case and padding read as True."""
    assert env_bool("X", False, environ={"X": word}) is True


@pytest.mark.parametrize("word", FALSE_WORDS)
def test_false_words_disable(word: str) -> None:
    """0/false/no/off in any case and padding read as False."""
    assert env_bool("X", True, environ={"X": word}) is False


@pytest.mark.parametrize("environ", [{}, {"X": ""}, {"X": "   "}])
def test_unset_or_empty_is_the_default(environ: dict[str, str]) -> None:
    """An unset or blank variable gives the default."""
    assert env_bool("X", True, environ=environ) is True
    assert env_bool("X", False, environ=environ) is False


@given(st.text(min_size=1, max_size=12).filter(lambda w: w.strip().lower() not in {*TRUE_WORDS, "1", "0"}))
def test_any_other_word_is_an_error_naming_the_variable(word: str) -> None:
    """Every other non-blank value is refused with the variable's name and value in the message."""
    if not word.strip() or word.strip().lower() in {"true", "yes", "on", "false", "no", "off"}:
        return
    with pytest.raises(ConfigError, match="DBGLOG="):
        env_bool("DBGLOG", True, environ={"DBGLOG": word})


def test_exit_wait_is_read_from_the_environment() -> None:
    """DBGLOG_EXIT_WAIT: 2 s unless set; 0 turns the exit's wait for readers off; nonsense is refused."""
    assert load_config({}).exit_wait == 2.0
    assert load_config({"DBGLOG_EXIT_WAIT": "0"}).exit_wait == 0.0
    with pytest.raises(ConfigError, match="DBGLOG_EXIT_WAIT"):
        load_config({"DBGLOG_EXIT_WAIT": "soon"})


def test_env_float_reads_and_validates() -> None:
    """env_float accepts finite numbers >= minimum and names the variable otherwise."""
    assert env_float("R", 2.0, environ={}) == 2.0
    assert env_float("R", 2.0, environ={"R": " 0.5 "}) == 0.5
    for bad in ("abc", "-1", "inf", "nan"):
        with pytest.raises(ConfigError, match="R="):
            env_float("R", 2.0, environ={"R": bad})


def test_load_config_defaults_and_switches() -> None:
    """DBGLOG and DBGLOG_STRICT map onto Config; unset means on and not strict (without -O)."""
    assert load_config({}).enabled is True
    assert load_config({}).strict is False
    cfg = load_config({"DBGLOG": "off", "DBGLOG_STRICT": "1"})
    assert (cfg.enabled, cfg.strict) == (False, True)
    with pytest.raises(ConfigError, match="DBGLOG_STRICT="):
        load_config({"DBGLOG_STRICT": "sometimes"})


def test_dbglog_namespace_is_read_once_and_checked() -> None:
    """DBGLOG_NAMESPACE gives the robot namespace, with or without its slash; a bad one names the variable."""
    assert load_config({}).namespace == ""
    assert load_config({"DBGLOG_NAMESPACE": "robot1"}).namespace == "/robot1"
    assert load_config({"DBGLOG_NAMESPACE": "/lab/robot1"}).namespace == "/lab/robot1"
    assert load_config({"DBGLOG_NAMESPACE": "/"}).namespace == ""
    with pytest.raises(ConfigError, match="DBGLOG_NAMESPACE='1robot'"):
        load_config({"DBGLOG_NAMESPACE": "1robot"})
    with pytest.raises(ConfigError, match="'rosdashboard' is dbglog's own"):
        load_config({"DBGLOG_NAMESPACE": "/rosdashboard"})
