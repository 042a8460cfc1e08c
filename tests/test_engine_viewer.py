"""What the real viewer says about its bindings, read from ``dbglog view --screenshot --report-json``.

Real publishers feed one viewer process; each test reads one widget's status and reason from its report:
a kind the widget can't show is an error (issue 12.16), one bad field is that widget's error alone with
no traceback (13.5), a misspelled topic waits with close matches and an empty graph hints at the
domain (12.17).
"""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from std_msgs.msg import Float64, String

from dbglog.viewer._data._suggest import EMPTY_GRAPH_HINT
from tests._ros import RosPeer

pytestmark = pytest.mark.gui

_RUN = f"/viewer_iso_{uuid.uuid4().hex[:6]}"
TEXT_TOPIC = f"{_RUN}/mode"
NUMBER_TOPIC = f"{_RUN}/proximity"
MOTOR_RPM = f"{_RUN}/motor/rpm"


def _widget(kind: str, name: str, i: int, *bindings: tuple[str, str]) -> dict[str, Any]:
    return {
        "type": kind,
        "name": name,
        "x": 10 + 230 * (i % 5),
        "y": 10 + 230 * (i // 5),
        "width": 220,
        "height": 220,
        "bindings": [{"topic": t, "field": f, "regex": ""} for t, f in bindings],
    }


WIDGETS = [
    ("led", "Led on text", ((TEXT_TOPIC, ""),)),
    ("dial", "Dial on text", ((TEXT_TOPIC, ""),)),
    ("string", "String on text", ((TEXT_TOPIC, ""),)),
    ("plot", "Plot of both", ((NUMBER_TOPIC, ""), (TEXT_TOPIC, ""))),
    ("dial", "Good dial", ((NUMBER_TOPIC, ""),)),
    ("dial", "Bad field", ((NUMBER_TOPIC, "data.x"),)),
    ("led", "Led on number", ((NUMBER_TOPIC, ""),)),
    ("dial", "Typo", ((f"{_RUN}/proximty", ""),)),
    ("dial", "Dict parent", ((f"{_RUN}/motor", ""),)),
]


def _run_viewer(board: Path, tmp: Path, after: float, env: dict[str, str]) -> tuple[dict[str, Any], str]:
    """Run `dbglog view --screenshot --report-json` on `board`; return the report's widgets and stderr."""
    report = tmp / "report.json"
    options = ("--after", str(after), "--report-json", str(report), "--size", "1200x720")
    proc = subprocess.run(
        [sys.executable, "-m", "dbglog", "view", str(board), "--screenshot", str(tmp / "shot.png"), *options],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return {w["name"]: w for w in json.loads(report.read_text())["widgets"]}, proc.stderr


@pytest.fixture(scope="module")
def viewer(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[dict[str, Any], str]]:
    """One viewer process over all the widgets, while real publishers send text and numbers."""
    tmp = tmp_path_factory.mktemp("viewer_iso")
    board = tmp / "board.json"
    widgets = [_widget(kind, name, i, *b) for i, (kind, name, b) in enumerate(WIDGETS)]
    board.write_text(json.dumps({"format": "dbglog-dashboard", "version": 1, "widgets": widgets}))
    stop = threading.Event()
    with RosPeer("viewer_iso_pub") as peer:
        text = peer.publisher(TEXT_TOPIC, String)
        number = peer.publisher(NUMBER_TOPIC, Float64)
        rpm = peer.publisher(MOTOR_RPM, Float64)

        def pump() -> None:
            i = 0
            while not stop.wait(0.05):
                text.publish(String(data="ON" if i % 2 else "OFF"))
                number.publish(Float64(data=0.25 + (i % 4) * 0.25))
                rpm.publish(Float64(data=1200.0))
                i += 1

        thread = threading.Thread(target=pump, daemon=True)
        thread.start()
        try:
            yield _run_viewer(board, tmp, 7.0, dict(os.environ))
        finally:
            stop.set()
            thread.join(5)


def test_a_kind_a_widget_cannot_show_is_an_error_with_the_reason(viewer: tuple[dict[str, Any], str]) -> None:
    """An LED or a dial on a String topic is an error saying what it shows and what the topic is."""
    widgets, _ = viewer
    led = widgets["Led on text"]
    assert led["status"] == "error", led
    assert f"LED shows bool or numbers; {TEXT_TOPIC} is std_msgs/msg/String text" in led["reason"]
    assert "a regex can turn text into numbers or bools" in led["reason"]
    dial = widgets["Dial on text"]
    assert dial["status"] == "error", dial
    assert f"Dial shows bool or numbers; {TEXT_TOPIC} is std_msgs/msg/String text" in dial["reason"]


def test_widgets_that_can_show_the_kind_stay_live(viewer: tuple[dict[str, Any], str]) -> None:
    """The String widget on the same text topic and an LED on a number topic are live."""
    widgets, _ = viewer
    assert widgets["String on text"]["status"] == "live", widgets["String on text"]
    assert widgets["Led on number"]["status"] == "live", widgets["Led on number"]


def test_a_multi_binding_widget_names_the_binding_it_cannot_show(viewer: tuple[dict[str, Any], str]) -> None:
    """A plot of a number and a text topic is an error naming the text topic only."""
    plot = viewer[0]["Plot of both"]
    assert plot["status"] == "error", plot
    assert f"Plot shows bool or numbers; {TEXT_TOPIC} is std_msgs/msg/String text" in plot["reason"]
    assert f"{NUMBER_TOPIC}:" not in plot["reason"]


def test_a_bad_field_is_its_widgets_error_alone_without_a_traceback(
    viewer: tuple[dict[str, Any], str],
) -> None:
    """`data.x` on Float64 is that dial's error, named once; the dial on `data` of the same topic is live."""
    widgets, stderr = viewer
    bad = widgets["Bad field"]
    assert bad["status"] == "error", bad
    assert "std_msgs/msg/Float64 has no field 'data.x'" in bad["reason"]
    assert "(fields: data)" in bad["reason"]
    assert widgets["Good dial"]["status"] == "live", widgets["Good dial"]
    assert "Traceback" not in stderr, stderr[-3000:]


def test_a_misspelled_topic_waits_with_close_matches(viewer: tuple[dict[str, Any], str]) -> None:
    """A typo'd topic stays waiting, and after a few seconds its reason names the published topic."""
    typo = viewer[0]["Typo"]
    assert typo["status"] == "waiting", typo
    assert f"did you mean {NUMBER_TOPIC}" in typo["reason"], typo["reason"]


def test_a_dict_parent_waits_naming_its_sub_topics(viewer: tuple[dict[str, Any], str]) -> None:
    """A binding on a dict tag's parent names the sub-topics that are published."""
    parent = viewer[0]["Dict parent"]
    assert parent["status"] == "waiting", parent
    assert f"it has sub-topics: {MOTOR_RPM}" in parent["reason"], parent["reason"]


def test_an_empty_graph_hints_at_the_domain_and_discovery_range(tmp_path: Path) -> None:
    """On a ROS domain where nothing runs, a waiting widget's reason points at ROS_DOMAIN_ID."""
    board = tmp_path / "board.json"
    widgets = [_widget("dial", "Alone", 0, ("/nobody/here", ""))]
    board.write_text(json.dumps({"format": "dbglog-dashboard", "version": 1, "widgets": widgets}))
    env = dict(os.environ)
    session = int(env.get("ROS_DOMAIN_ID", "0"))
    env["ROS_DOMAIN_ID"] = str(random.choice([d for d in range(201, 233) if d != session]))
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    start = time.monotonic()
    shown, _ = _run_viewer(board, tmp_path, 5.0, env)
    assert time.monotonic() - start < 100
    alone = shown["Alone"]
    assert alone["status"] == "waiting", alone
    assert EMPTY_GRAPH_HINT in alone["reason"]
