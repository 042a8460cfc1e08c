"""The real viewer in a child process, driven like a desktop: xdotool mouse and keys on its X display."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tests._ros import wait_until

__all__ = ["ROOT", "WAIT_S", "ViewerChild", "in_view", "report_frame"]

ROOT = Path(__file__).resolve().parent.parent
WAIT_S = 30.0


def in_view(rect: list[float], view: list[float]) -> bool:
    """Whether a widget's [x, y, w, h] lies inside the visible canvas [x, y, w, h] (window pixels)."""
    inside_x = view[0] <= rect[0] and rect[0] + rect[2] <= view[0] + view[2]
    return inside_x and view[1] <= rect[1] and rect[1] + rect[3] <= view[1] + view[3]


def report_frame(app: Any, folder: Path, state: dict[str, Any]) -> None:
    """Child side, from a frame hook: write the screenshots asked for and the state for the test to read.

    A test asks for a screenshot by dropping ``shot-NAME.request`` in `folder`; the next rendered frame
    writes ``NAME.png``. The state goes to ``state.json`` atomically (a reader never sees half of it).
    """
    import dearpygui.dearpygui as dpg

    for request in sorted(folder.glob("shot-*.request")):
        name = request.stem.removeprefix("shot-")
        request.unlink()
        dpg.output_frame_buffer(file=str(folder / f"{name}.png"))
        app.pacer.request()  # the viewer renders only on change: render now
    out = folder / "state.json.tmp"
    out.write_text(json.dumps(state, indent=1))
    out.replace(folder / "state.json")


class ViewerChild:
    """A child process running the real viewer, and the mouse and keyboard (xdotool) on its display.

    The child runs ``tests.<module>.run_here(scenario, tmp)``, whose frame hook reports its state (with a
    frame counter under `frame_key`) as ``state.json`` in the probe folder and writes a screenshot there
    when asked.
    """

    frame_key = "frame"
    """The key of the child's frame counter in its reports."""

    def __init__(
        self, scenario: str, tmp: Path, display: str, module: str, *, probe: Path | None = None
    ) -> None:
        self.tmp, self.display = (tmp / "probe") if probe is None else probe, display
        self.tmp.mkdir(exist_ok=True)
        code = (
            f"import sys; sys.path.insert(0, {str(ROOT)!r}); "
            f"from tests import {module}; {module}.run_here(sys.argv[1], sys.argv[2])"
        )
        self.log = (self.tmp / "child.log").open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-c", code, scenario, str(tmp)],
            env={**os.environ, "DISPLAY": display},
            stdout=self.log,
            stderr=subprocess.STDOUT,
            cwd=ROOT,
        )
        self.window = ""

    # -- the child's reports --

    def output(self) -> str:
        """What the child printed."""
        self.log.flush()
        return (self.tmp / "child.log").read_text()

    def state(self) -> dict[str, Any]:
        """The child's last reported state (empty before the first report)."""
        try:
            return dict(json.loads((self.tmp / "state.json").read_text()))
        except (OSError, ValueError):
            return {}

    def wait_for(self, what: Callable[[dict[str, Any]], Any], timeout: float = WAIT_S) -> dict[str, Any]:
        """Wait until the reported state satisfies `what`; fail if the child dies or time runs out."""

        def check() -> bool:
            state = self.state()
            return self.proc.poll() is not None or (bool(state) and bool(what(state)))

        ok = wait_until(check, timeout=timeout)
        state = self.state()
        assert ok, f"timed out; state {json.dumps(state, indent=1)}\n{self.output()}"
        assert what(state), f"child exited with {self.proc.returncode}; state {state}\n{self.output()}"
        return state

    def frames(self, n: int = 3) -> dict[str, Any]:
        """Wait until the viewer drew `n` more frames (so it has seen the last input) and return the state."""
        key = self.frame_key
        start = int(self.state().get(key, 0))
        return self.wait_for(lambda s: int(s.get(key, 0)) >= start + n)

    def ready(self, timeout: float = WAIT_S) -> dict[str, Any]:
        """Wait for the first report and the window (`timeout` seconds), and give the window the keyboard."""
        state = self.wait_for(lambda s: s.get(self.frame_key, 0) >= 3, timeout)
        out = self.xdo("search", "--sync", "--pid", str(self.proc.pid))
        self.window = out.split()[0]
        self.xdo("windowfocus", "--sync", self.window)
        return state

    def shot(self, name: str) -> Path:
        """Ask the child for a screenshot of the window; return the PNG once written."""
        path = self.tmp / f"{name}.png"
        (self.tmp / f"shot-{name}.request").touch()
        assert wait_until(lambda: path.exists() and path.stat().st_size > 0, timeout=WAIT_S), self.output()
        time.sleep(0.2)  # the PNG is written in one go, but give the writer a moment to close it
        return path

    # -- the mouse and the keyboard --

    def xdo(self, *args: str) -> str:
        """Run xdotool on the child's display and return what it printed."""
        done = subprocess.run(
            ["xdotool", *args],
            env={**os.environ, "DISPLAY": self.display},
            capture_output=True,
            text=True,
            timeout=WAIT_S,
            check=True,
        )
        return done.stdout

    def move(self, x: float, y: float) -> None:
        """Move the mouse to window pixel (x, y) and wait until the viewer saw it there."""
        self.xdo("mousemove", "--window", self.window, str(round(x)), str(round(y)))
        self.wait_for(lambda s: abs(s["mouse"][0] - round(x)) <= 1 and abs(s["mouse"][1] - round(y)) <= 1)
        self.frames(3)

    def click(self, x: float, y: float, button: int = 1) -> None:
        """Move to (x, y) and click `button` (1 left, 3 right), holding it for a few frames as a hand does."""
        self.move(x, y)
        self.xdo("mousedown", str(button))
        self.frames(3)
        self.xdo("mouseup", str(button))
        self.frames(3)

    def drag(self, start: tuple[float, float], end: tuple[float, float], steps: int = 8) -> None:
        """Press the left button at `start`, move to `end` in steps with it held, and let go there."""
        self.move(*start)
        self.xdo("mousedown", "1")
        self.frames(3)
        for i in range(1, steps + 1):
            x = start[0] + (end[0] - start[0]) * i / steps
            y = start[1] + (end[1] - start[1]) * i / steps
            self.move(x, y)
        self.frames(3)
        self.xdo("mouseup", "1")
        self.frames(3)

    def hand_drag(self, start: tuple[float, float], through_x: float, end_x: float) -> dict[str, Any]:
        """Drag like a hand, frames not waited for: press at `start`, move along to `through_x` in 120 steps a
        few ms apart (denser than frames, and lasting several frames even on a loaded machine), jump to
        `end_x` in one move, let go; return the state three frames after."""
        x, y = start
        self.move(x, y)
        self.xdo("mousedown", "1")
        self.frames(3)
        steps: list[str] = []
        for i in range(1, 121):
            step_x = round(x + (through_x - x) * i / 120)
            steps += ["mousemove", "--window", self.window, str(step_x), str(round(y)), "sleep", "0.005"]
        steps += ["mousemove", "--window", self.window, str(round(end_x)), str(round(y))]
        self.xdo(*steps)
        self.frames(3)
        self.xdo("mouseup", "1")
        self.frames(3)
        return self.frames(3)

    def menu_entry(self, title: str, label: str) -> None:
        """Click the menu bar's menu `title`, then its entry `label` (the child reports ``menubar``)."""
        bar = self.state()["menubar"][title]
        (fx, fy), (tw, th) = bar["pos"], bar["size"]
        self.click(fx + tw / 2, fy + th / 2 + 3)
        state = self.wait_for(lambda s: s["menubar"][title]["entries"].get(label, [0, 0])[1] > 0)
        ex, ey = state["menubar"][title]["entries"][label]
        self.click(fx + ex + 20, th + 2 * 5 + ey + th / 2)  # the popup opens below the bar (text + padding)

    def key(self, *names: str) -> None:
        """Press keys (xdotool names: "Return", "ctrl+shift+s")."""
        for name in names:  # held for a few frames, as a hand does: the viewer sees the chord together
            self.xdo("keydown", name)
            self.frames(3)
            self.xdo("keyup", name)
            self.frames(3)

    def type(self, text: str) -> None:
        """Type `text` on the keyboard."""
        self.xdo("type", "--delay", "60", text)
        self.frames(3)

    def stop(self) -> None:
        """Kill the child if it still runs."""
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(10)
        self.log.close()
