"""`dbglog view` without a usable X display says why and exits 2 (GLFW alone aborts the process)."""

from __future__ import annotations

import os
from pathlib import Path

from dbglog.viewer._ui._display import x_display_problem
from tests._children import run_dbglog


def _unused_display() -> str:
    """An X display name no server listens on here."""
    taken = {p.name for p in Path("/tmp/.X11-unix").glob("X*")} if Path("/tmp/.X11-unix").is_dir() else set()
    number = next(n for n in range(4321, 5000) if f"X{n}" not in taken)
    return f":{number}"


def _view_without(display: str | None, tmp_path: Path) -> tuple[int, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    if display is not None:
        env["DISPLAY"] = display
    png = tmp_path / "view.png"
    proc = run_dbglog("view", "--screenshot", str(png), "--after", "0.5", env=env)
    assert not png.exists()
    return proc.returncode, proc.stderr


def test_view_without_display_says_so(tmp_path: Path) -> None:
    """No DISPLAY: exit 2 with the reason and the way to render headless, no abort, no traceback."""
    code, err = _view_without(None, tmp_path)
    assert code == 2, err
    assert "dbglog view: error: no display: DISPLAY is not set" in err
    assert "xvfb-run -a dbglog view" in err
    assert "Traceback" not in err
    assert "Glfw" not in err


def test_view_on_a_display_nobody_serves_names_it(tmp_path: Path) -> None:
    """DISPLAY naming no X server: exit 2 naming the display, before GLFW's assertion could abort."""
    display = _unused_display()
    code, err = _view_without(display, tmp_path)
    assert code == 2, err
    assert f"cannot open the X display DISPLAY='{display}'" in err
    assert "Traceback" not in err
    assert "Glfw" not in err


def test_display_problem_names_wayland_and_accepts_a_served_display(display: str) -> None:
    """Only WAYLAND_DISPLAY set: the message says the window needs X11; a running Xvfb is usable."""
    problem = x_display_problem(None, wayland=True)
    assert problem is not None
    assert "X11" in problem
    assert "WAYLAND_DISPLAY" in problem
    assert x_display_problem("  ") == "no display: DISPLAY is not set"
    assert x_display_problem(display) is None
    assert x_display_problem(_unused_display(), attempts=1) is not None
