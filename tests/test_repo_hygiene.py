"""What running the quickstart leaves in the checkout: nothing git would offer to commit."""

from __future__ import annotations

import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_demo_screenshot_and_venvs_are_ignored_by_git() -> None:
    """`.ci/demo`'s dbglog-demo.png and the 3.11/3.12 venvs never show up as untracked files."""
    for name in ("dbglog-demo.png", ".venv/bin/python", ".venv-3.12/bin/python"):
        proc = subprocess.run(
            ["git", "check-ignore", "-q", name], cwd=ROOT, capture_output=True, text=True, check=False
        )
        assert proc.returncode == 0, f"{name} is not ignored by .gitignore ({proc.stderr.strip()})"


def test_demo_script_writes_its_screenshot_where_gitignore_covers_it() -> None:
    """The demo script's default PNG path is the ignored dbglog-demo.png at the repository root."""
    assert '"${DBGLOG_DEMO_PNG:-$ROOT/dbglog-demo.png}"' in (ROOT / ".ci" / "demo").read_text()
