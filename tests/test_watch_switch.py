"""The opt-in: DBGLOG_WATCH, read once at import, starts the agent; otherwise nothing of watches loads."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from dbglog._config import ConfigError, load_config
from tests._ros import own_output

PROBE = """
import sys, dbglog
loaded = "dbglog.watch._agent" in sys.modules
agent = sys.modules["dbglog.watch._agent"].agent() if loaded else None
print(loaded, agent is not None and agent.wait_ready(60))
"""


def _probe(code: str, **env: str) -> str:
    base = {k: v for k, v in os.environ.items() if k not in ("DBGLOG", "DBGLOG_WATCH")}
    out = subprocess.run(
        [sys.executable, "-c", code],
        env={**base, **env},
        capture_output=True,
        text=True,
        timeout=90,
        check=False,
    )
    assert out.returncode == 0, out.stderr
    return own_output(out.stdout)


def test_watch_switch_is_read_with_the_others() -> None:
    """DBGLOG_WATCH is off by default, takes the usual switch words, and names itself when wrong."""
    assert load_config({}).watch is False
    assert load_config({"DBGLOG_WATCH": "yes"}).watch is True
    with pytest.raises(ConfigError, match="DBGLOG_WATCH="):
        load_config({"DBGLOG_WATCH": "maybe"})


def test_import_with_the_switch_starts_the_agent() -> None:
    """``import dbglog`` with DBGLOG_WATCH=1 makes the process watchable: the agent's node comes up."""
    assert _probe(PROBE, DBGLOG_WATCH="1") == "True True"


@pytest.mark.parametrize("env", [{}, {"DBGLOG_WATCH": "0"}, {"DBGLOG": "off", "DBGLOG_WATCH": "1"}])
def test_without_the_switch_nothing_is_loaded(env: dict[str, str]) -> None:
    """Without DBGLOG_WATCH, or with dbglog switched off, no watch module is even imported."""
    code = "import sys, dbglog\nprint(sorted(m for m in sys.modules if m.startswith('dbglog.watch')))"
    assert _probe(code, **env) == "[]"


def test_the_client_module_is_light() -> None:
    """Importing the watchers' client (as the viewer does) loads neither rclpy nor the in-process agent."""
    code = (
        "import sys, dbglog.watch.client\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'rclpy' or m == 'dbglog.watch._agent'))"
    )
    assert _probe(code) == "[]"
