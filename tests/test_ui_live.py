"""End to end: a real rclpy publisher feeds a viewer widget through the real data engine (under Xvfb)."""

from __future__ import annotations

import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

pytestmark = pytest.mark.gui


def run_here(tmp: str) -> None:
    """Child-process body (one Dear PyGui context each): publish, see the dial turn live, then stale."""
    warnings.simplefilter("error")
    warnings.filterwarnings("ignore", "module 'sre_", DeprecationWarning)
    import dearpygui.dearpygui as dpg
    from std_msgs.msg import Float64

    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._model import Binding, Status
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._ui._dialogs import TopicDialog
    from dbglog.viewer._widgets import WidgetRegistry
    from tests._ros import RosPeer

    topic = "/rosdashboard/ui_e2e_speed"
    with RosPeer("ui_e2e_publisher") as peer, Engine(stale_after=1.0) as engine:
        pub = peer.publisher(topic, Float64)
        app = ViewerApp(engine, WidgetRegistry.builtin(), width=900, height=600)
        app.start()
        try:
            item = app.add_widget("dial", 20, 20)
            assert item is not None
            app.apply_bindings(item, (Binding(topic, "data"),))
            app.frame()
            assert item.status.value == "waiting"

            def live_with(value: float) -> bool:
                msg = Float64()
                msg.data = value
                pub.publish(msg)
                app.frame()
                widget = item.widget
                text = dpg.get_item_configuration(widget._readout)["text"] if widget else ""  # type: ignore[attr-defined]
                return item.status is Status.LIVE and text == f"{value:.1f}"

            deadline = time.monotonic() + 20
            while not live_with(42.5):
                assert time.monotonic() < deadline, f"dial never turned live: {item.status} {item.reason}"
                time.sleep(0.02)
            shot = app.screenshot(Path(tmp) / "live.png")
            assert shot.stat().st_size > 0
            dialog = app.dialogs.topic(item)
            assert isinstance(dialog, TopicDialog)
            dpg.set_value(dialog.topic_input, "ui_e2e")
            deadline = time.monotonic() + 10  # the graph's topic list is read again at least every 2 s
            while [s.split()[0] for s in dialog.suggestions()] != [topic]:
                assert time.monotonic() < deadline, dialog.suggestions()
                app.frame()
                time.sleep(0.05)
            assert "std_msgs/msg/Float64" in dialog.suggestions()[0]
            dialog.choose_topic(topic)
            items = dpg.get_item_configuration(dialog.field_combo)["items"]
            assert any(label.strip().startswith("data") for label in items), items
            dialog.close()
            deadline = time.monotonic() + 20
            while item.status.value != Status.STALE.value:
                assert time.monotonic() < deadline, f"dial never turned stale: {item.status}"
                app.frame()
                time.sleep(0.02)
        finally:
            app.close()


def test_real_publisher_turns_dial_live_then_stale(tmp_path: Path) -> None:
    """A Float64 from a real rclpy node turns a bound dial live with the value, then stale when it stops."""
    root = Path(__file__).resolve().parent.parent
    code = (
        f"import sys; sys.path.insert(0, {str(root)!r}); "
        "from tests import test_ui_live; test_ui_live.run_here(sys.argv[1])"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, timeout=100, check=False
    )
    assert proc.returncode == 0, f"{proc.stdout}\n{proc.stderr}"
    assert (tmp_path / "live.png").stat().st_size > 0
