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
