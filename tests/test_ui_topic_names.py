"""Topic setup shows a tag as logged (速度, robot1:speed) and takes a robot's tag typed as tools show it.

The suggestion rules are checked as a plain function; the dialog itself under Xvfb with the real mouse and
keyboard (the harness of `tests/test_ui_menus.py`).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from dbglog.viewer._data._model import FieldInfo, TopicInfo
from dbglog.viewer._ui._dialogs import topic_suggestions, typed_topic
from tests._viewer_child import ViewerChild as Viewer
from tests.test_ui_dialogs import topic_dialog
from tests.test_ui_menus import center

_FLOAT = "std_msgs/msg/Float64"
TOPICS = ["/rosdashboard/speed", "/rosdashboard/__901f___5ea6_", "/robot1/rosdashboard/speed"]


def test_suggestions_match_and_show_the_tag_as_logged() -> None:
    """Typing a tag's text or robot1:tag finds its topic; an escaped or a robot's tag shows its label."""
    topics = [TopicInfo(t, (_FLOAT,), 1) for t in TOPICS] + [
        TopicInfo("/odom", ("nav_msgs/msg/Odometry",), 1)
    ]
    assert topic_suggestions(topics, "robot1:sp") == [
        f"/robot1/rosdashboard/speed   [{_FLOAT}]   robot1:speed"
    ]
    assert topic_suggestions(topics, "速") == [f"/rosdashboard/__901f___5ea6_   [{_FLOAT}]   速度"]
    assert topic_suggestions(topics, "/rosdashboard/sp") == [  # the prefix match first
        f"/rosdashboard/speed   [{_FLOAT}]",
        f"/robot1/rosdashboard/speed   [{_FLOAT}]   robot1:speed",
    ]
    assert [s.split()[0] for s in topic_suggestions(topics, "speed")] == [
        "/rosdashboard/speed",
        "/robot1/rosdashboard/speed",
    ]


def test_a_robots_tag_typed_is_its_topic() -> None:
    """robot1:speed (or :a:b) typed is that tag's topic; a plain name or a /topic stays as typed."""
    assert typed_topic(" robot2:speed ") == "/robot2/rosdashboard/speed"
    assert typed_topic(":a:b") == "/rosdashboard/a__3a_b"
    assert typed_topic("odom") == "odom"
    assert typed_topic("/odom") == "/odom"


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: an empty viewer whose graph has an escaped tag and a robot's tag."""
    warnings.simplefilter("error")
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry
    from tests.test_ui import make_source
    from tests.test_ui_menus import Probe

    source = make_source()
    for topic in TOPICS[1:]:
        source.add_topic(topic, _FLOAT, [FieldInfo("data", "double", True)])
    app = ViewerApp(source, WidgetRegistry.builtin(), width=1200, height=760)
    app.start()
    try:
        app.frame_hooks.append(Probe(app, Path(tmp_dir) / "probe").hook)
        app.run()
    finally:
        app.close()


@pytest.fixture
def viewer(display: str, tmp_path: Path) -> Iterator[Callable[[], Viewer]]:
    """Start viewers on the display; each is killed at the end if it still runs."""
    started: list[Viewer] = []

    def start() -> Viewer:
        v = Viewer("robots", tmp_path, display, "test_ui_topic_names")
        started.append(v)
        v.ready()
        return v

    yield start
    for v in started:
        v.stop()


@pytest.mark.gui
def test_topic_setup_finds_a_robots_tag_by_its_label(viewer: Callable[[], Viewer]) -> None:
    """A dropped dial: typing robot1:sp offers robot1's speed (its label shown), Enter takes its topic; a
    robot's tag nobody publishes yet, typed whole, binds to its topic."""
    v = viewer()
    v.drag(center(v.state()["toolbox"]["Dial"]), (700.0, 420.0))
    v.wait_for(lambda s: (topic_dialog(s) or {}).get("topic_active"))
    v.type("robot1:sp")
    state = v.wait_for(lambda s: (topic_dialog(s) or {}).get("topic") == "robot1:sp")
    assert topic_dialog(state)["suggestions"] == [  # type: ignore[index]
        f"/robot1/rosdashboard/speed   [{_FLOAT}]   robot1:speed"
    ]
    v.key("Return")
    v.wait_for(lambda s: (topic_dialog(s) or {}).get("topic") == "/robot1/rosdashboard/speed")
    v.key("ctrl+a", "BackSpace")
    v.type("robot2:speed")
    state = v.wait_for(lambda s: (topic_dialog(s) or {}).get("topic") == "robot2:speed")
    assert topic_dialog(state)["suggestions"] == []  # type: ignore[index]
    v.key("Return")
    state = v.wait_for(lambda s: s["dialog"] is None)
    assert [i["topics"] for i in state["items"]] == [["/robot2/rosdashboard/speed"]]
