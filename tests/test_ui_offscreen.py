"""Widgets out of view cost nothing: not read, not redrawn, yet live; scrolled into view they catch up.

The real viewer runs in a child process (`ViewerApp.run`) with a plot in view and one far below, both fed
new samples on every pass of its loop; its frame hook reports each widget's redraw count, its status now
and the newest sample its plot drew. This process scrolls the canvas with the real wheel (xdotool).
"""

from __future__ import annotations

import json
import shutil
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests._viewer_child import ViewerChild

pytestmark = pytest.mark.gui

SIZE = (1000, 700)
BELOW_Y = 1400.0
"""Where the second plot sits: well below the view of a 700-pixel window."""


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child: two live plots, one far below the view; report updates, status and what each drew."""
    warnings.simplefilter("error")
    import dearpygui.dearpygui as dpg

    from dbglog.viewer._data._model import Binding, FieldInfo
    from dbglog.viewer._document._dashboard import WidgetConfig
    from dbglog.viewer._ui import StaticSource, ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry
    from dbglog.viewer._widgets._plot import PlotWidget

    tmp = Path(tmp_dir)
    source = StaticSource()
    for topic in ("/t/top", "/t/below"):
        source.add_topic(topic, "std_msgs/msg/Float64", [FieldInfo("data", "double", True)])
    app = ViewerApp(source, WidgetRegistry.builtin(), width=SIZE[0], height=SIZE[1])
    app.start()
    try:
        for name, y, topic in (("Top", 20.0, "/t/top"), ("Below", BELOW_Y, "/t/below")):
            app.canvas.add_config(WidgetConfig("plot", name, 20, y, 420, 240, (Binding(topic, "data"),), {}))
        newest = [0.0]
        last = [""]

        def hook() -> None:
            t = time.time()
            newest[0] = t
            for topic in ("/t/top", "/t/below"):
                source.push(topic, "data", t % 1.0, t)
            items = {}
            for item in app.items:
                assert isinstance(item.widget, PlotWidget)
                items[item.name] = {
                    "updates": item.updates,
                    "pill": item.status.value,
                    "now": item.current_status(app.timeline)[0].value,
                    "drawn_to": item.widget.drawn_to,
                }
            state = {
                "rendered": app.loop.rendered,
                "scroll": dpg.get_y_scroll(app.canvas.window),
                "scroll_max": dpg.get_y_scroll_max(app.canvas.window),
                "newest": newest[0],
                "items": items,
                "mouse": list(dpg.get_mouse_pos(local=False)),
            }
            text = json.dumps(state)
            if text != last[0]:
                last[0] = text
                out = tmp / "state.json.tmp"
                out.write_text(text)
                out.replace(tmp / "state.json")

        app.frame_hooks.append(hook)
        app.run()
    finally:
        app.close()


class Viewer(ViewerChild):
    """The child viewer of this module, reporting its drawn frames as ``rendered``."""

    frame_key = "rendered"

    def __init__(self, tmp: Path, display: str) -> None:
        super().__init__("offscreen", tmp, display, "test_ui_offscreen", probe=tmp)

    def wheel_down(self) -> None:
        """Turn the wheel one notch down where the mouse is, and let the viewer draw it."""
        self.xdo("click", "5")
        self.frames(2)


@pytest.fixture
def viewer(display: str, tmp_path: Path) -> Iterator[Viewer]:
    """The child viewer on the display, killed at the end."""
    assert shutil.which("xdotool"), "xdotool is missing: .ci/setup.sh installs it"
    v = Viewer(tmp_path, display)
    yield v
    v.stop()


def test_a_widget_out_of_view_is_not_redrawn_and_catches_up_in_view(viewer: Viewer) -> None:
    """While the plot in view redraws with every sample, the one below the view is not redrawn at all, yet
    counts as live; scrolled into view with the wheel, it draws the newest samples at once."""
    v = viewer
    state = v.ready()
    state = v.wait_for(lambda s: s["items"]["Top"]["updates"] >= 5 and s["scroll_max"] > 0)
    below = state["items"]["Below"]["updates"]
    top = state["items"]["Top"]["updates"]
    state = v.wait_for(lambda s: s["items"]["Top"]["updates"] >= top + 20)
    assert state["items"]["Below"]["updates"] == below, "a widget out of view was redrawn"
    assert state["items"]["Below"]["now"] == "live"  # what the report says of it, drawn or not
    # The wheel over the canvas background (right of the plots) scrolls down to the second plot.
    v.move(800, 300)
    for _ in range(30):
        v.wheel_down()
        if v.state()["scroll"] >= BELOW_Y - 200:
            break
    state = v.wait_for(lambda s: s["items"]["Below"]["updates"] > below)
    state = v.frames(3)
    drawn, newest = state["items"]["Below"]["drawn_to"], state["newest"]
    assert drawn is not None
    assert newest - drawn < 1.0, "scrolled into view, the plot shows the newest samples"
    assert state["items"]["Below"]["pill"] == "live"
    top = state["items"]["Top"]["updates"]
    state = v.frames(10)
    assert state["items"]["Top"]["updates"] == top, "the plot scrolled out of view is redrawn no more"
