"""Quitting the real viewer under Xvfb: the close request, Ctrl+Q and the unsaved-changes prompt.

Each scenario runs the real `ViewerApp.run` loop in a process of its own; this process plays the window
manager and the keyboard through X11 (a WM_DELETE_WINDOW client message, key events sent to the window)
and watches the child through the JSON state a frame hook writes. The child clicks the prompt's buttons
by calling the callbacks Dear PyGui calls on a click.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import json
import os
import signal
import subprocess
import sys
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests._ros import wait_until

pytestmark = pytest.mark.gui

ROOT = Path(__file__).resolve().parent.parent
EXIT_S = 15.0
"""How long a viewer that should close may take to exit (a few frames; generous for a loaded CI machine)."""


# -- X11: the window manager's close request and key presses, as a desktop sends them -----------------


_X_EVENT_HEAD: list[tuple[str, Any]] = [
    ("type", ctypes.c_int),
    ("serial", ctypes.c_ulong),
    ("send_event", ctypes.c_int),
    ("display", ctypes.c_void_p),
    ("window", ctypes.c_ulong),
]
"""The fields every Xlib event starts with."""


class _ClientMessage(ctypes.Structure):
    _fields_ = [
        *_X_EVENT_HEAD,
        ("message_type", ctypes.c_ulong),
        ("format", ctypes.c_int),
        ("data", ctypes.c_long * 5),
    ]


class _KeyEvent(ctypes.Structure):
    _fields_ = [
        *_X_EVENT_HEAD,
        ("root", ctypes.c_ulong),
        ("subwindow", ctypes.c_ulong),
        ("time", ctypes.c_ulong),
        ("x", ctypes.c_int),
        ("y", ctypes.c_int),
        ("x_root", ctypes.c_int),
        ("y_root", ctypes.c_int),
        ("state", ctypes.c_uint),
        ("keycode", ctypes.c_uint),
        ("same_screen", ctypes.c_int),
    ]


class _XEvent(ctypes.Union):
    _fields_ = [("client", _ClientMessage), ("key", _KeyEvent), ("pad", ctypes.c_long * 24)]


CLIENT_MESSAGE, KEY_PRESS, KEY_RELEASE = 33, 2, 3
CONTROL_MASK = 1 << 2
KEY_PRESS_MASK, KEY_RELEASE_MASK = 1 << 0, 1 << 1


class X11:
    """A connection to the X display in DISPLAY, enough to close a window and type into it."""

    def __init__(self, display: str) -> None:
        lib = ctypes.util.find_library("X11")
        assert lib, "libX11 is missing (Dear PyGui's GLFW needs it too)"
        x = ctypes.CDLL(lib)
        vp, ul = ctypes.c_void_p, ctypes.c_ulong
        x.XOpenDisplay.restype, x.XOpenDisplay.argtypes = vp, [ctypes.c_char_p]
        x.XDefaultRootWindow.restype, x.XDefaultRootWindow.argtypes = ul, [vp]
        x.XInternAtom.restype, x.XInternAtom.argtypes = ul, [vp, ctypes.c_char_p, ctypes.c_int]
        x.XQueryTree.argtypes = [
            vp,
            ul,
            ctypes.POINTER(ul),
            ctypes.POINTER(ul),
            ctypes.POINTER(ctypes.POINTER(ul)),
            ctypes.POINTER(ctypes.c_uint),
        ]
        x.XGetWindowProperty.argtypes = [
            vp,
            ul,
            ul,
            ctypes.c_long,
            ctypes.c_long,
            ctypes.c_int,
            ul,
            ctypes.POINTER(ul),
            ctypes.POINTER(ctypes.c_int),
            ctypes.POINTER(ul),
            ctypes.POINTER(ul),
            ctypes.POINTER(ctypes.POINTER(ctypes.c_ubyte)),
        ]
        x.XSendEvent.argtypes = [vp, ul, ctypes.c_int, ctypes.c_long, ctypes.POINTER(_XEvent)]
        x.XKeysymToKeycode.restype, x.XKeysymToKeycode.argtypes = ctypes.c_ubyte, [vp, ul]
        x.XStringToKeysym.restype, x.XStringToKeysym.argtypes = ul, [ctypes.c_char_p]
        for name in ("XFlush", "XCloseDisplay", "XFree"):
            getattr(x, name).argtypes = [vp]
        # Xlib's default error handler exits the process: a key release sent to a window that has just
        # closed (Ctrl+Q with nothing to save) must be a no-op, not the end of the test run.
        handler_type = ctypes.CFUNCTYPE(ctypes.c_int, vp, vp)
        self._on_error = handler_type(lambda _display, _event: 0)
        x.XSetErrorHandler.restype, x.XSetErrorHandler.argtypes = vp, [handler_type]
        self._previous_handler = x.XSetErrorHandler(self._on_error)
        self.x = x
        self.display = x.XOpenDisplay(display.encode())
        assert self.display, f"cannot open display {display}"

    def close(self) -> None:
        """Close the connection and give Xlib its previous error handler back."""
        self.x.XCloseDisplay(self.display)
        self.x.XSetErrorHandler(ctypes.cast(self._previous_handler, type(self._on_error)))

    def window_of(self, pid: int) -> int | None:
        """The top-level window whose _NET_WM_PID is `pid` (GLFW sets it), or None."""
        x, d = self.x, self.display
        root = x.XDefaultRootWindow(d)
        pid_atom = x.XInternAtom(d, b"_NET_WM_PID", 0)
        r, p, n = ctypes.c_ulong(), ctypes.c_ulong(), ctypes.c_uint()
        kids = ctypes.POINTER(ctypes.c_ulong)()
        if not x.XQueryTree(d, root, ctypes.byref(r), ctypes.byref(p), ctypes.byref(kids), ctypes.byref(n)):
            return None
        found = None
        try:
            for i in range(n.value):
                kind, fmt, count, after = ctypes.c_ulong(), ctypes.c_int(), ctypes.c_ulong(), ctypes.c_ulong()
                data = ctypes.POINTER(ctypes.c_ubyte)()
                ok = x.XGetWindowProperty(
                    d, kids[i], pid_atom, 0, 1, 0, 6, *map(ctypes.byref, (kind, fmt, count, after, data))
                )
                if ok == 0 and count.value:
                    owner = ctypes.cast(data, ctypes.POINTER(ctypes.c_long))[0]
                    x.XFree(data)
                    if owner == pid:
                        found = int(kids[i])
        finally:
            if kids:
                x.XFree(kids)
        return found

    def request_close(self, window: int) -> None:
        """Ask the window to close, as a window manager's close button does (WM_DELETE_WINDOW)."""
        x, d = self.x, self.display
        event = _XEvent()
        event.client.type = CLIENT_MESSAGE
        event.client.window = window
        event.client.message_type = x.XInternAtom(d, b"WM_PROTOCOLS", 0)
        event.client.format = 32
        event.client.data[0] = x.XInternAtom(d, b"WM_DELETE_WINDOW", 0)
        x.XSendEvent(d, window, 0, 0, ctypes.byref(event))
        x.XFlush(d)

    def _key(self, window: int, name: str, kind: int, state: int) -> None:
        x, d = self.x, self.display
        event = _XEvent()
        k = event.key
        k.type, k.window, k.root, k.same_screen = kind, window, x.XDefaultRootWindow(d), 1
        k.state, k.keycode = state, x.XKeysymToKeycode(d, x.XStringToKeysym(name.encode()))
        mask = KEY_PRESS_MASK if kind == KEY_PRESS else KEY_RELEASE_MASK
        x.XSendEvent(d, window, 1, mask, ctypes.byref(event))
        x.XFlush(d)

    def press(self, window: int, name: str, *, ctrl: bool = False) -> None:
        """Press and release key `name` (an X keysym name: "q", "Escape"), with Control held if `ctrl`."""
        if ctrl:
            self._key(window, "Control_L", KEY_PRESS, 0)
            time.sleep(0.1)
        state = CONTROL_MASK if ctrl else 0
        self._key(window, name, KEY_PRESS, state)
        time.sleep(0.1)
        self._key(window, name, KEY_RELEASE, state)
        if ctrl:
            time.sleep(0.05)
            self._key(window, "Control_L", KEY_RELEASE, CONTROL_MASK)


# -- the child: a real viewer whose frame hook reports its state and answers the prompt -----------------

PLANS: dict[str, list[str]] = {
    "clean": [],
    "save": ["save"],
    "discard": ["discard"],
    "cancel": ["cancel", "leave"],  # Cancel, then the prompt from Ctrl+Q is left to the Escape key
    "hold": ["leave"],  # the prompt stays open until a signal arrives
    "save_as": ["save:cancel", "save:choose"],
    "control": ["save"],
}
"""Scenario -> what the child does at each quit prompt, in turn ("leave": nothing, the test acts)."""


def start_dashboard(tmp: Path) -> Path:
    """Write the dashboard the scenarios open: a toggle and a slider without topics, and a dial."""
    from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig, save_dashboard

    widgets = [
        WidgetConfig("toggle", "Lamp", 20, 20, 200, 98, (), {"state": False}),
        WidgetConfig("slider", "Speed", 240, 20, 320, 72, (), {"value": 0.0}),
        WidgetConfig("dial", "Gauge", 20, 140, 220, 248, (), {}),
    ]
    path = tmp / "dash.json"
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget](widgets), 20, True), path)
    return path


class Child:
    """Drives one scenario from a frame hook inside `ViewerApp.run` and reports to `state.json`."""

    def __init__(self, app: Any, tmp: Path, scenario: str) -> None:
        self.app, self.tmp, self.plan = app, tmp, list(PLANS[scenario])
        self.state: dict[str, Any] = {"pid": os.getpid(), "phase": "starting", "prompts": [], "events": []}
        self.handled: object = None
        self.settle = 0
        self.seen = 0.0
        self.shot: Path | None = None
        self.last_written = ""

    def write(self, **changes: Any) -> None:
        """Update the state file (atomically, only when something changed)."""
        import dearpygui.dearpygui as dpg

        self.state.update(changes)
        self.state.update(
            dirty=self.app.doc.dirty,
            widgets=len(self.app.items),
            title=dpg.get_viewport_title() if self.app.started else "",
            prompt_open=self.prompt() is not None,
        )
        text = json.dumps(self.state, indent=1)
        if text != self.last_written:
            self.last_written = text
            tmp = self.tmp / "state.json.tmp"
            tmp.write_text(text)
            tmp.replace(self.tmp / "state.json")

    def prompt(self) -> Any:
        """The open quit prompt, or None."""
        from dbglog.viewer._ui._quit import QuitDialog

        dialog = self.app.dialog
        return dialog if isinstance(dialog, QuitDialog) else None

    def hook(self) -> None:
        """Frame hook: notice a new prompt, photograph it, then act as the plan says."""
        import dearpygui.dearpygui as dpg

        dialog = self.prompt()
        if dialog is None or dialog is self.handled:
            self.write()
            return
        if self.settle == 0:
            self.seen = time.monotonic()
        self.settle += 1
        if self.settle >= 3 and time.monotonic() - self.seen > 0.4 and self.shot is None:
            # Laid out, drawn, and the window behind dimmed (Dear ImGui fades the dimming in): capture it.
            (x, y), (w, h) = dpg.get_item_pos(dialog.window), dpg.get_item_rect_size(dialog.window)
            shot = self.tmp / f"prompt{len(self.state['prompts'])}.png"
            self.state["prompts"].append(
                {
                    "question": dialog.question,
                    "buttons": [dpg.get_item_label(b) for b in dialog_buttons(dialog)],
                    "shown": bool(dpg.is_item_shown(dialog.window)),
                    "modal": bool(dpg.get_item_configuration(dialog.window)["modal"]),
                    "rect": [x, y, w, h],
                    "shot": str(shot),
                }
            )
            dpg.output_frame_buffer(file=str(shot))
            self.shot = shot
        if self.shot is None or not (self.shot.exists() and self.shot.stat().st_size > 0):
            return  # the capture lands a frame or two later
        self.handled, self.settle, self.shot = dialog, 0, None
        action = self.plan.pop(0) if self.plan else "leave"
        self.state["events"].append(f"prompt:{action}")
        if action == "leave":
            self.write(phase="prompt-left-open")
            return
        button = {
            "save": dialog.save_button,
            "discard": dialog.discard_button,
            "cancel": dialog.cancel_button,
        }[action.split(":")[0]]
        click(button)
        if action == "save:cancel" or action == "save:choose":
            request = self.app.files.request
            assert request is not None, "Save As did not open"
            assert request.save
            assert dpg.is_item_shown(request.item)
            self.state["events"].append("save-as-opened")
            if action == "save:cancel":
                self.app.files.cancelled()  # what the dialog's Cancel button calls
            else:
                save_as = request.dialog
                assert save_as is not None
                dpg.set_value(save_as.name_input, str(self.tmp / "new.json"))
                click(save_as.save_button)
        self.write(phase=f"after-{action}", quitting=self.app.quitting)


def dialog_buttons(dialog: Any) -> list[int | str]:
    """The prompt's three buttons, left to right."""
    return [dialog.save_button, dialog.discard_button, dialog.cancel_button]


def unsaved(app: Any) -> bool:
    """Whether the viewer has unsaved changes (a call, so that type narrowing does not outlive a frame)."""
    return bool(app.doc.dirty)


def click(button: int | str) -> None:
    """Click a button: call its callback as Dear PyGui does on a click (sender, app_data, user_data)."""
    import dearpygui.dearpygui as dpg

    callback = dpg.get_item_callback(button)
    assert callable(callback)
    callback(button, None, None)


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: open the scenario's dashboard, change it, run the viewer until it closes."""
    warnings.simplefilter("error")
    from dbglog._cli import interruptible

    interruptible()  # as `dbglog view` does: SIGINT works even if the test runner ignores it
    import dearpygui.dearpygui as dpg

    from dbglog.viewer._document._dashboard import WidgetConfig, load_dashboard
    from dbglog.viewer._ui import StaticSource, ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    tmp = Path(tmp_dir)
    registry = WidgetRegistry.builtin()
    app = ViewerApp(StaticSource(), registry, width=1000, height=640)
    app.start()
    child = Child(app, tmp, scenario)
    try:
        if scenario != "save_as":
            path = start_dashboard(tmp)
            app.load(load_dashboard(path, registry.get), path)
        for _ in range(3):
            app.frame()
        assert not unsaved(app), "opening a dashboard (controls included) changes nothing"
        if scenario == "control":
            speed = app.items[1].widget
            speed.set_value(0.0)  # type: ignore[union-attr]  # let go where it was: nothing changed
            app.frame()
            assert not unsaved(app)
            speed.set_value(0.5)  # type: ignore[union-attr]
            app.frame()
            assert unsaved(app)
            click(app.items[0].widget.button)  # type: ignore[union-attr]  # switch the toggle on
            app.frame()
            assert unsaved(app)
            config = app.items[0].config
            assert isinstance(config, WidgetConfig)
            assert config.properties["state"] is True
            assert dpg.get_viewport_title().endswith(" *")
        elif scenario != "clean":
            app.add_widget("led", 600, 140)
        app.frame_hooks.append(child.hook)
        child.write(phase="ready")
        if scenario == "discard":
            click(app.menus.entries["file.quit"])  # File > Quit
        app.run()
        child.write(phase="loop-ended", quitting=app.quitting)
    except KeyboardInterrupt:
        child.write(phase="interrupted")
        raise SystemExit(130) from None
    finally:
        app.close()


# -- the tests: start a child, act as the desktop would, check what happened ----------------------------


@pytest.fixture
def x11(display: str) -> Iterator[X11]:
    """A connection to the display, to close windows and press keys."""
    conn = X11(display)
    try:
        yield conn
    finally:
        conn.close()


class Viewer:
    """A child process running the real viewer through one scenario."""

    def __init__(self, scenario: str, tmp: Path, display: str) -> None:
        self.tmp = tmp
        code = (
            f"import sys; sys.path.insert(0, {str(ROOT)!r}); "
            "from tests import test_ui_quit; test_ui_quit.run_here(sys.argv[1], sys.argv[2])"
        )
        self.log = (tmp / "child.log").open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-c", code, scenario, str(tmp)],
            env={**os.environ, "DISPLAY": display},
            stdout=self.log,
            stderr=subprocess.STDOUT,
            cwd=ROOT,
        )
        self.window = 0

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

    def wait_for(self, what: Callable[[dict[str, Any]], bool], timeout: float = 30) -> dict[str, Any]:
        """Wait until the reported state satisfies `what`; fail if the child dies or time runs out."""
        ok = wait_until(lambda: self.proc.poll() is not None or what(self.state()), timeout=timeout)
        state = self.state()
        assert ok, f"timed out; state {state}\n{self.output()}"
        assert what(state), f"child exited with {self.proc.returncode}; state {state}\n{self.output()}"
        return state

    def ready(self, x11: X11) -> dict[str, Any]:
        """Wait for the scenario to be set up and the window to be on the display."""
        state = self.wait_for(lambda s: s.get("phase") == "ready")
        assert wait_until(lambda: x11.window_of(self.proc.pid) is not None, timeout=10), "no window"
        self.window = x11.window_of(self.proc.pid) or 0
        return state

    def wait_prompt(self, count: int) -> dict[str, Any]:
        """Wait until the `count`-th quit prompt was shown and photographed."""
        return self.wait_for(lambda s: len(s.get("prompts", [])) >= count)

    def exits_within(self, seconds: float) -> int:
        """Wait for the child to exit; return its exit code (fail if it is still running after `seconds`)."""
        try:
            return self.proc.wait(seconds)
        except subprocess.TimeoutExpired:
            pytest.fail(f"the viewer did not exit within {seconds} s; state {self.state()}\n{self.output()}")

    def running_after(self, seconds: float) -> bool:
        """Whether the child is still running `seconds` from now."""
        try:
            self.proc.wait(seconds)
        except subprocess.TimeoutExpired:
            return True
        return False

    def stop(self) -> None:
        """Kill the child if it still runs."""
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(10)
        self.log.close()


@pytest.fixture
def viewer(display: str, tmp_path: Path) -> Iterator[Callable[[str], Viewer]]:
    """Start viewers on the display; each is killed at the end if it still runs."""
    started: list[Viewer] = []

    def start(scenario: str) -> Viewer:
        v = Viewer(scenario, tmp_path, display)
        started.append(v)
        return v

    yield start
    for v in started:
        v.stop()


def test_close_without_changes_exits_at_once(viewer: Callable[[str], Viewer], x11: X11) -> None:
    """With nothing changed, Ctrl+Q closes the viewer at once, without a prompt."""
    v = viewer("clean")
    assert v.ready(x11)["dirty"] is False
    x11.press(v.window, "q", ctrl=True)
    assert v.exits_within(EXIT_S) == 0, v.output()
    state = v.state()
    assert state["phase"] == "loop-ended"
    assert state["prompts"] == []
    assert state["quitting"] is True


def assert_prompt_on_screen(prompt: dict[str, Any]) -> None:
    """The photographed prompt shows its question and buttons in text colour, over the dimmed window."""
    from dbglog.viewer._ui._theme import CANVAS, TEXT
    from tests.test_ui import count_color, read_png

    assert prompt["buttons"] == ["Save", "Don't save", "Cancel"]
    assert prompt["shown"] is True
    assert prompt["modal"] is True
    img = read_png(Path(prompt["shot"]))
    x, y, w, h = (int(v) for v in prompt["rect"])
    assert w > 300
    assert h > 80
    text = count_color(img[y : y + h, x : x + w], TEXT, tol=30)
    assert text > 300, "the prompt's text is on screen"
    assert count_color(img, TEXT, tol=30) == text, "all other text is dimmed behind the prompt"
    below = img[y + h + 20 :, x : x + w, :3].reshape(-1, 3)
    assert len(below) > 1000
    dimmed = np.median(below, axis=0)
    assert all(d < 0.8 * c for d, c in zip(dimmed, CANVAS[:3], strict=True)), f"not dimmed: {dimmed}"


def test_save_writes_file_with_backup_and_exits(
    viewer: Callable[[str], Viewer], x11: X11, tmp_path: Path
) -> None:
    """Closing with changes asks; Save writes the file atomically (old one kept as .bak) and exits."""
    v = viewer("save")
    v.ready(x11)
    before = (tmp_path / "dash.json").read_bytes()
    x11.request_close(v.window)
    state = v.wait_prompt(1)
    prompt = state["prompts"][0]
    assert prompt["question"] == "Save changes to dash.json before closing?"
    assert_prompt_on_screen(prompt)
    assert v.exits_within(EXIT_S) == 0, v.output()
    assert v.state()["events"] == ["prompt:save"]
    saved = json.loads((tmp_path / "dash.json").read_text())
    assert [w["type"] for w in saved["widgets"]] == ["toggle", "slider", "dial", "led"]
    assert (tmp_path / "dash.json.bak").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == [], "no temp file left"


def test_dont_save_leaves_file_and_exits(viewer: Callable[[str], Viewer], x11: X11, tmp_path: Path) -> None:
    """File > Quit with changes asks too; Don't save closes and leaves the file exactly as it was."""
    v = viewer("discard")
    v.ready(x11)
    before = (tmp_path / "dash.json").read_bytes()
    v.wait_prompt(1)  # the child chose File > Quit
    assert v.exits_within(EXIT_S) == 0, v.output()
    assert v.state()["events"] == ["prompt:discard"]
    assert (tmp_path / "dash.json").read_bytes() == before
    assert not (tmp_path / "dash.json.bak").exists()


def test_cancel_and_escape_keep_running_ctrl_q_asks_again(viewer: Callable[[str], Viewer], x11: X11) -> None:
    """Cancel keeps the viewer open with its changes; Ctrl+Q asks again; Escape cancels that prompt too."""
    v = viewer("cancel")
    v.ready(x11)
    x11.request_close(v.window)
    v.wait_prompt(1)
    state = v.wait_for(lambda s: s.get("phase") == "after-cancel" and not s["prompt_open"])
    assert state["quitting"] is False
    assert v.running_after(1.0), v.output()
    state = v.state()
    assert state["dirty"] is True
    assert state["widgets"] == 4
    assert state["title"].endswith("dash.json *")
    x11.press(v.window, "q", ctrl=True)
    state = v.wait_prompt(2)
    assert state["prompts"][1]["question"] == "Save changes to dash.json before closing?"
    v.wait_for(lambda s: s.get("phase") == "prompt-left-open")
    x11.press(v.window, "Escape")
    state = v.wait_for(lambda s: not s["prompt_open"])
    assert v.running_after(1.0), v.output()
    assert v.state()["dirty"] is True
    x11.press(v.window, "q")  # without Ctrl: not a shortcut
    assert v.running_after(0.5)
    assert not v.state()["prompt_open"]


def test_save_as_when_untitled_cancel_stays_open(
    viewer: Callable[[str], Viewer], x11: X11, tmp_path: Path
) -> None:
    """Without a file, Save opens Save As: cancelling it stays open, choosing a file saves and exits."""
    v = viewer("save_as")
    v.ready(x11)
    x11.request_close(v.window)
    state = v.wait_prompt(1)
    assert state["prompts"][0]["question"] == "Save the new dashboard before closing?"
    state = v.wait_for(lambda s: s.get("phase") == "after-save:cancel")
    assert "save-as-opened" in state["events"]
    assert v.running_after(1.0), v.output()
    assert v.state()["dirty"] is True
    assert not (tmp_path / "new.json").exists()
    x11.request_close(v.window)
    v.wait_prompt(2)
    assert v.exits_within(EXIT_S) == 0, v.output()
    assert v.state()["events"] == [
        "prompt:save:cancel",
        "save-as-opened",
        "prompt:save:choose",
        "save-as-opened",
    ]
    saved = json.loads((tmp_path / "new.json").read_text())
    assert [w["type"] for w in saved["widgets"]] == ["led"]


def test_control_change_marks_dirty_and_is_saved(
    viewer: Callable[[str], Viewer], x11: X11, tmp_path: Path
) -> None:
    """A slider moved or a toggle switched marks the dashboard modified, so quitting asks; Save keeps both."""
    v = viewer("control")
    state = v.ready(x11)
    assert state["dirty"] is True
    assert state["title"].endswith(" *")
    x11.request_close(v.window)
    v.wait_prompt(1)
    assert v.exits_within(EXIT_S) == 0, v.output()
    saved = json.loads((tmp_path / "dash.json").read_text())
    assert saved["widgets"][0]["properties"]["state"] is True
    assert saved["widgets"][1]["properties"]["value"] == 0.5


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_signal_with_unsaved_changes_exits_promptly(
    viewer: Callable[[str], Viewer], x11: X11, tmp_path: Path, signum: int
) -> None:
    """SIGTERM or SIGINT (as `dbglog demo` stops the viewer) exits at once, even with the prompt open."""
    v = viewer("hold")
    v.ready(x11)
    before = (tmp_path / "dash.json").read_bytes()
    x11.request_close(v.window)
    v.wait_for(lambda s: s.get("phase") == "prompt-left-open")
    v.proc.send_signal(signum)
    code = v.exits_within(EXIT_S)
    assert code == (-signal.SIGTERM if signum == signal.SIGTERM else 130), v.output()
    assert (tmp_path / "dash.json").read_bytes() == before


def test_cli_view_closes_on_close_request(display: str, x11: X11, tmp_path: Path) -> None:
    """`dbglog view FILE` (real engine) closes at once on the close request when nothing changed."""
    path = start_dashboard(tmp_path)
    before = path.read_bytes()
    with (tmp_path / "view.log").open("w") as log:
        proc = subprocess.Popen(
            [sys.executable, "-m", "dbglog", "view", str(path), "--size", "900x600"],
            env={**os.environ, "DISPLAY": display},
            stdout=log,
            stderr=subprocess.STDOUT,
            cwd=ROOT,
        )
        try:
            assert wait_until(lambda: x11.window_of(proc.pid) is not None, timeout=30), "no window"
            time.sleep(0.5)  # let it load the dashboard and render
            x11.request_close(x11.window_of(proc.pid) or 0)
            assert proc.wait(EXIT_S) == 0, (tmp_path / "view.log").read_text()
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait(10)
    assert path.read_bytes() == before
