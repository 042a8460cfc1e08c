"""Heavy dependencies stay lazy: importing dbglog's packages pulls in neither rclpy nor Dear PyGui."""

from __future__ import annotations

import subprocess
import sys

import pytest


@pytest.mark.parametrize(
    "module", ["dbglog", "dbglog.viewer", "dbglog.regex_bridge", "dbglog._cli", "dbglog.viewer.widget_api"]
)
def test_import_is_light(module: str) -> None:
    """Importing the module (and building the CLI parser) loads neither rclpy nor dearpygui."""
    code = (
        f"import sys, {module}\n"
        "from dbglog._cli import build_parser\n"
        "build_parser()\n"
        "heavy = sorted(m for m in sys.modules if m.split('.')[0] in ('rclpy', 'dearpygui'))\n"
        "print(','.join(heavy))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    assert out.stdout.strip() == ""


def test_cli_help_lists_every_command() -> None:
    """`dbglog --help` works and lists every subcommand."""
    out = subprocess.run(
        [sys.executable, "-m", "dbglog", "--help"], capture_output=True, text=True, timeout=60, check=True
    )
    for command in ("bridge", "tags", "echo", "view", "demo"):
        assert command in out.stdout


def test_dbglog_without_a_command_prints_help_and_exits_2() -> None:
    """`dbglog` alone is a usage error, as argparse makes any other: help on stderr, exit status 2."""
    out = subprocess.run(
        [sys.executable, "-m", "dbglog"], capture_output=True, text=True, timeout=60, check=False
    )
    assert out.returncode == 2
    assert out.stdout == ""
    assert "usage: dbglog" in out.stderr
    assert "tags" in out.stderr


def test_widget_api_loads_no_bridge_matcher() -> None:
    """Importing widget_api loads neither the bridge's RE2-Set matcher nor its YAML rules loader."""
    code = (
        "import sys, dbglog.viewer.widget_api\n"
        "import dbglog.regex_bridge\n"
        "bridge = ('dbglog.regex_bridge._engine', 'dbglog.regex_bridge._rules', 'yaml')\n"
        "print(','.join(sorted(m for m in bridge if m in sys.modules)))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    assert out.stdout.strip() == ""


def test_regex_bridge_exports_load_on_use() -> None:
    """Every name dbglog.regex_bridge exports resolves on first use; an unknown name is an AttributeError."""
    code = (
        "import dbglog.regex_bridge as rb\n"
        "assert all(getattr(rb, n) is not None for n in rb.__all__)\n"
        "assert rb.Matcher.__module__ == 'dbglog.regex_bridge._engine'\n"
        "try:\n    rb.nope\nexcept AttributeError as e:\n    print(e)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    assert "has no attribute 'nope'" in out.stdout
