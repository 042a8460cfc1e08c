"""The transforms editor in the real topic setup dialog, end to end with a real publisher (under Xvfb).

Runs in a process of its own (one Dear PyGui context per process).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

pytestmark = pytest.mark.gui


def run_here(tmp: str) -> None:
    """Child-process body: edit a compass's transforms in Topic setup; the widget shows degrees; saved."""
    warnings.simplefilter("error")
    warnings.filterwarnings("ignore", "module 'sre_", DeprecationWarning)
    from std_msgs.msg import Float64

    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._model import Binding, Status
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._ui._dialogs import TopicDialog
    from dbglog.viewer._values._transforms import RadToDeg
    from dbglog.viewer._widgets import WidgetRegistry
    from tests._ros import RosPeer

    topic = "/rosdashboard/xf_ui/azimuth"
    with RosPeer("xf_ui_publisher") as peer, Engine() as engine:
        pub = peer.publisher(topic, Float64)
        app = ViewerApp(engine, WidgetRegistry.builtin(), width=1000, height=700)
        app.start()
        try:
            item = app.add_widget("compass", 20, 20)
            assert item is not None
            dialog = app.dialogs.topic(item)
            assert isinstance(dialog, TopicDialog)
            dialog.choose_topic(topic)
            # Live validation of the formula field: refused with the reason, then accepted.
            ok, text = dialog.set_formula("__import__('os').system('true')")
            assert not ok
            assert "not allowed" in text
            assert not dialog.add_transform(), "a refused formula is not added"
            assert dialog.transforms() == []
            ok, text = dialog.set_formula("sqrt(linear.x**2 + linear.y**2)")
            assert ok
            assert "linear.x, linear.y" in text
            dialog.choose_transform_kind("scale")
            assert dialog.add_transform()
            dialog.choose_transform_kind("rad2deg")
            assert dialog.add_transform()
            dialog.choose_transform_kind("clamp")
            assert dialog.add_transform()  # clamp [0, 1] by default: then removed again
            assert [t["kind"] for t in dialog.transforms()] == ["scale", "rad2deg", "clamp"]
            dialog.remove_transform(2)
            dialog.remove_transform(0)
            assert dialog.transforms() == [{"kind": "rad2deg"}]
            assert dialog.apply()
            (binding,) = item.bindings
            assert binding.topic == topic
            assert binding.transforms == (RadToDeg(),)
            assert peer.wait_for_subscribers(pub, 1, 20)

            msg = Float64()
            msg.data = math.pi / 2
            deadline = time.monotonic() + 20
            while True:
                pub.publish(msg)
                app.frame()
                snap = engine.snapshot(binding)
                if item.status is Status.LIVE and snap.last == pytest.approx(90.0):
                    break
                assert time.monotonic() < deadline, f"{item.status} {item.reason} {snap.last}"
                time.sleep(0.02)
            raw = engine.snapshot(Binding(topic))
            assert raw.last is None or raw.last == pytest.approx(math.pi / 2)
            assert app.files.save(Path(tmp) / "xf.json")
            saved = json.loads((Path(tmp) / "xf.json").read_text())
            assert saved["widgets"][0]["bindings"][0]["transforms"] == [{"kind": "rad2deg"}]
            shot = app.screenshot(Path(tmp) / "xf.png")
            assert shot.stat().st_size > 0
        finally:
            app.close()


def test_transforms_editor_end_to_end(tmp_path: Path) -> None:
    """Topic setup adds/removes transforms with live formula checks; the engine feeds the widget degrees."""
    root = Path(__file__).resolve().parent.parent
    code = (
        f"import sys; sys.path.insert(0, {str(root)!r}); "
        "from tests import test_binding_transforms_ui; test_binding_transforms_ui.run_here(sys.argv[1])"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, timeout=100, check=False
    )
    assert proc.returncode == 0, f"{proc.stdout}\n{proc.stderr}"
    assert (tmp_path / "xf.png").stat().st_size > 0
