"""Control widgets: pure value logic, the publishing service against real subscribers, and the real UI.

The UI scenarios run in a fresh process each (one Dear PyGui context per process, under Xvfb), with a
real `RosPeer` subscriber in that process: they drive the widgets' own callbacks and check what arrives.
"""

from __future__ import annotations

import json
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from geometry_msgs.msg import Twist
from std_msgs.msg import Bool, Float64

from dbglog.viewer._data._interfaces import (
    InterfaceError,
    fill_message,
    form_fields,
    installed_types,
    message_type,
    normalize_type,
)
from dbglog.viewer._data._model import Status
from dbglog.viewer._publishing._publish import PublishRequest, PublishService
from dbglog.viewer._widgets._controls import parse_message, slider_value
from tests._children import run_scenario
from tests._ros import RosPeer, wait_until

# ---------------------------------------------------------------------------------------------------------
# Pure logic.


def test_slider_value_clamps_and_snaps() -> None:
    """A slider value is clamped to its range and snapped to its step from the minimum."""
    assert slider_value(5.0, -1.0, 1.0, 0.0) == 1.0
    assert slider_value(-5.0, -1.0, 1.0, 0.0) == -1.0
    assert slider_value(0.26, 0.0, 1.0, 0.25) == 0.25
    assert slider_value(0.38, 0.0, 1.0, 0.25) == 0.5
    assert slider_value(float("nan"), 2.0, -2.0, 0.0) == -2.0
    assert slider_value(0.3, -1.0, 1.0, 0.2) == pytest.approx(0.2)


def test_parse_message_accepts_objects_only() -> None:
    """A message property is a JSON object; anything else is refused with the reason."""
    assert parse_message("") == {}
    assert parse_message('{"linear": {"x": 0.5}}') == {"linear": {"x": 0.5}}
    for bad, why in (("[1]", "object"), ("{", "JSON"), ('{"x": NaN}', "NaN"), ("1" * 2000, "longer")):
        with pytest.raises(ValueError, match=why):
            parse_message(bad)


def test_installed_types_are_scanned_and_unknown_types_never_imported() -> None:
    """The installed types are listed without importing; a name not on the list is refused, not imported."""
    types = installed_types()
    assert {"std_msgs/msg/Bool", "geometry_msgs/msg/Twist", "sensor_msgs/msg/LaserScan"} <= set(types)
    assert normalize_type("std_msgs/Bool") == "std_msgs/msg/Bool"
    for bad in ("antigravity/msg/Fly", "this/msg/Zen", "os/path", "std_msgs/msg/bool", "../x/msg/Y"):
        with pytest.raises(InterfaceError):
            message_type(bad)
    assert "antigravity" not in sys.modules
    assert "this" not in sys.modules


def test_fill_message_checks_every_value_against_the_type() -> None:
    """Nested or dotted values fill a message; a wrong name, kind or range is refused with the field named."""
    twist = message_type("geometry_msgs/msg/Twist")
    msg = fill_message(twist, {"linear": {"x": 0.5}, "angular.z": 1})
    assert (msg.linear.x, msg.angular.z, msg.linear.y) == (0.5, 1.0, 0.0)
    assert [f.path for f in form_fields(twist)] == [
        "linear.x",
        "linear.y",
        "linear.z",
        "angular.x",
        "angular.y",
        "angular.z",
    ]
    for values, why in (
        ({"linear": {"q": 1}}, "no field 'linear.q'"),
        ({"linear": 1}, "is a message"),
        ({"linear.x": "fast"}, "a number"),
        ({"linear.x": True}, "a number"),
    ):
        with pytest.raises(InterfaceError, match=why):
            fill_message(twist, values)
    header = message_type("std_msgs/msg/Header")
    with pytest.raises(InterfaceError, match="outside"):
        fill_message(header, {"stamp": {"sec": 2**40}})
    assert fill_message(message_type("std_msgs/msg/Bool"), {"data": True}).data is True


# ---------------------------------------------------------------------------------------------------------
# The publishing service against real subscribers (no UI).


@pytest.fixture
def service() -> Any:
    """A publishing service of its own, stopped after the test."""
    svc = PublishService(graph_period=0.2)
    yield svc
    svc.stop()


def _state_is(svc: PublishService, key: str, status: Status) -> Callable[[], bool]:
    return lambda: svc.state(key).status is status


def test_service_composes_fields_and_reports_live(service: PublishService) -> None:
    """Two value controls on one Twist topic compose one message; the state is live with a subscriber."""
    with RosPeer("controls_svc_peer") as peer:
        got = peer.subscribe("/ctl_svc/cmd_vel", Twist)
        service.update("lin", PublishRequest("/ctl_svc/cmd_vel", field="linear.x", value=0.5), send=False)
        service.update("ang", PublishRequest("/ctl_svc/cmd_vel", field="angular.z", value=-1.0), send=False)
        assert wait_until(_state_is(service, "lin", Status.LIVE), 15), service.state("lin")
        assert service.state("lin").msg_type == "geometry_msgs/msg/Twist"
        service.update("lin", PublishRequest("/ctl_svc/cmd_vel", field="linear.x", value=0.75), send=True)
        assert got.wait_for(1, 15)
        msg = got.messages[-1]
        assert (msg.linear.x, msg.angular.z) == (0.75, -1.0)
        assert service.state("lin").sent == 1
        assert service.state("ang").sent == 0


def test_service_waits_for_a_topic_whose_type_the_default_cannot_serve(service: PublishService) -> None:
    """A slider on a topic's linear.x, and a button with a Twist's fields, before anything on the graph
    knows the topic (the robot not up yet): waiting, with the reason, not an error, and nothing sent; once
    a Twist subscriber appears both take its type and publish."""
    topic = "/ctl_svc/later_cmd"
    service.update("lin", PublishRequest(topic, field="linear.x", value=0.5), send=True)
    service.update("btn", PublishRequest(topic, fields={"angular": {"z": 1.0}}), send=False)
    assert wait_until(lambda: "on the ROS graph" in service.state("lin").reason, 15), service.state("lin")
    time.sleep(0.6)  # a few reads of the graph later: still waiting
    for key, field_name in (("lin", "'linear.x'"), ("btn", "'angular.z'")):
        state = service.state(key)
        assert state.status is Status.WAITING, state
        assert f"waiting for {topic} on the ROS graph" in state.reason
        assert field_name in state.reason
        assert state.msg_type is None
    assert service.state("lin").sent == 0
    with RosPeer("controls_later_peer") as peer:
        got = peer.subscribe(topic, Twist)
        assert wait_until(_state_is(service, "lin", Status.LIVE), 15), service.state("lin")
        assert service.state("lin").msg_type == "geometry_msgs/msg/Twist"
        assert wait_until(_state_is(service, "btn", Status.LIVE), 15), service.state("btn")
        service.update("lin", PublishRequest(topic, field="linear.x", value=0.75), send=True)
        assert wait_until(lambda: bool(got.messages) and got.messages[-1].linear.x == 0.75, 15)


def test_service_type_clash_is_an_error(service: PublishService) -> None:
    """A control whose type differs from the topic's type on the graph is an error naming both types."""
    with RosPeer("controls_clash_peer") as peer:
        got = peer.subscribe("/ctl_svc/flag", Bool)
        service.update(
            "num", PublishRequest("/ctl_svc/flag", msg_type="std_msgs/msg/Float64", value=1.0), send=True
        )
        service.update("auto", PublishRequest("/ctl_svc/flag", value=2.0), send=True)
        assert wait_until(_state_is(service, "num", Status.ERROR), 15), service.state("num")
        reason = service.state("num").reason
        assert "type clash" in reason
        assert "std_msgs/msg/Bool" in reason
        assert "Float64" in reason
        assert wait_until(_state_is(service, "auto", Status.ERROR), 15)
        assert "field 'data' is boolean" in service.state("auto").reason
        time.sleep(0.3)
        assert got.messages == []


def test_service_rate_limit_holds_and_last_value_arrives(service: PublishService) -> None:
    """200 updates in about a second at a 10 Hz limit send at most ~11 messages, the last one included."""
    with RosPeer("controls_rate_peer") as peer:
        got = peer.subscribe("/ctl_svc/level", Float64)
        request = PublishRequest("/ctl_svc/level", value=0.0)
        service.update("s", request, send=False, rate_limit_hz=10)
        assert wait_until(_state_is(service, "s", Status.LIVE), 15)
        t0 = time.monotonic()
        for i in range(200):
            service.update("s", PublishRequest("/ctl_svc/level", value=float(i)), send=True, rate_limit_hz=10)
            time.sleep(0.005)
        span = time.monotonic() - t0
        assert wait_until(lambda: got.values()[-1:] == [199.0], 10), got.values()[-3:]
        received = got.values()
        assert len(received) <= span * 10 + 2, (len(received), span)
        assert len(received) >= 3
        assert received == sorted(received)


def test_service_repeats_at_a_set_rate(service: PublishService) -> None:
    """With a repeat rate the value is sent again and again (for commands that time out)."""
    with RosPeer("controls_repeat_peer") as peer:
        got = peer.subscribe("/ctl_svc/hold", Float64)
        service.update(
            "r", PublishRequest("/ctl_svc/hold", value=0.25), send=True, rate_limit_hz=50, repeat_hz=20
        )
        assert got.wait_for(10, 15)
        assert set(got.values()) == {0.25}
        service.release("r")
        time.sleep(0.3)
        n = len(got.messages)
        time.sleep(0.5)
        assert len(got.messages) == n, "a released control keeps sending"


# ---------------------------------------------------------------------------------------------------------
# The real UI, one process per scenario.


def _pump(app: Any, predicate: Callable[[], bool], timeout: float = 20.0, what: str = "") -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, f"timed out waiting for {what or predicate}"
        app.frame()
        time.sleep(0.01)


def _viewer(engine: Any) -> Any:
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    app = ViewerApp(engine, WidgetRegistry.discover(), width=1100, height=720)
    app.start()
    return app


def _control(app: Any, type_name: str, topic: str, fld: str = "", **props: Any) -> Any:
    from dbglog.viewer._data._model import Binding

    item = app.add_widget(type_name, 20 + 30 * len(app.items), 20 + 40 * len(app.items))
    assert item is not None, type_name
    if props:
        item.set_properties(props)
    app.apply_bindings(item, (Binding(topic, fld),))
    return item


def scenario_toggle_and_text(tmp: Path) -> None:
    """Toggle publishes the state it shows (Bool); Text field publishes what is typed (String); saved."""
    import dearpygui.dearpygui as dpg
    from std_msgs.msg import String

    from dbglog.viewer._data._engine import Engine

    with RosPeer("controls_ui_peer") as peer, Engine() as engine:
        flags = peer.subscribe("/ctl_ui/autopilot", Bool)
        texts = peer.subscribe("/ctl_ui/say", String)
        app = _viewer(engine)
        try:
            toggle = _control(app, "toggle", "/ctl_ui/autopilot", on_text="AUTO", off_text="MANUAL")
            text = _control(app, "text_field", "/ctl_ui/say")
            _pump(app, lambda: toggle.status is Status.LIVE and text.status is Status.LIVE, what="live")
            assert "1 subscriber" in toggle.reason
            assert "std_msgs/msg/Bool" in toggle.reason
            w = toggle.widget
            assert dpg.get_item_configuration(w.button)["label"] == "MANUAL"
            w.on_click()
            assert dpg.get_item_configuration(w.button)["label"] == "AUTO"
            _pump(app, lambda: flags.values() == [True], what="True")
            w.on_click()
            _pump(app, lambda: flags.values() == [True, False], what="True, False")
            assert dpg.get_item_configuration(w.button)["label"] == "MANUAL"
            w.on_click()
            _pump(app, lambda: flags.values() == [True, False, True], what="three states")
            dpg.set_value(text.widget.input, "hello robot")
            text.widget.submit()
            _pump(app, lambda: texts.values() == ["hello robot"], what="text")
            text.widget.submit("second")
            _pump(app, lambda: texts.values() == ["hello robot", "second"], what="second text")
            _pump(app, lambda: "sent" in toggle.reason, what="sent count")
            assert app.files.save(tmp / "controls.json")
            saved = json.loads((tmp / "controls.json").read_text())
            by_type = {w["type"]: w for w in saved["widgets"]}
            assert by_type["toggle"]["properties"]["state"] is True
            assert by_type["toggle"]["bindings"][0]["topic"] == "/ctl_ui/autopilot"
            assert by_type["text_field"]["properties"]["text"] == "second"
            assert app.files.open_path(tmp / "controls.json")
            again = next(i for i in app.items if i.config.type == "toggle")
            assert dpg.get_item_configuration(again.widget.button)["label"] == "AUTO"
            app.frame()
            assert flags.values() == [True, False, True], "loading a dashboard must not publish"
        finally:
            app.close()


def scenario_toggle_follows_the_selected_robot(tmp: Path) -> None:
    """A Toggle bound to the selected robot publishes to that robot's topic, and after a switch to the new
    robot's; the other robot gets nothing."""
    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._model import SELECTED_ROBOT, Binding
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    with RosPeer("controls_robot_peer") as peer, Engine() as engine:
        first = peer.subscribe("/ctl_a/ctl_ui/auto", Bool)
        second = peer.subscribe("/ctl_b/ctl_ui/auto", Bool)
        app = ViewerApp(engine, WidgetRegistry.discover(), width=1100, height=720, robot="/ctl_a")
        app.start()
        try:
            toggle = app.add_widget("toggle", 20, 20)
            assert toggle is not None
            app.apply_bindings(toggle, (Binding("/ctl_ui/auto", robot=SELECTED_ROBOT),))
            _pump(app, lambda: toggle.status is Status.LIVE, what="live on /ctl_a")
            w: Any = toggle.widget
            w.on_click()
            _pump(app, lambda: first.values() == [True], what="True on /ctl_a")
            app.robots.select("/ctl_b")
            assert toggle.context().targets == (Binding("/ctl_b/ctl_ui/auto"),)
            assert w.topic == "/ctl_b/ctl_ui/auto"
            _pump(app, lambda: toggle.status is Status.LIVE, what="live on /ctl_b")
            w.on_click()
            _pump(app, lambda: second.values() == [False], what="False on /ctl_b")
            assert first.values() == [True], "the robot no longer selected gets nothing"
            saved = app.doc.dashboard().widgets[0]
            assert saved.bindings == (Binding("/ctl_ui/auto", robot=SELECTED_ROBOT),)
        finally:
            app.close()


def scenario_sliders_teleop(tmp: Path) -> None:
    """Two sliders on one Twist topic (linear.x, angular.z) publish what they show, composed, rate limited."""
    import dearpygui.dearpygui as dpg

    from dbglog.viewer._data._engine import Engine

    with RosPeer("controls_slider_peer") as peer, Engine() as engine:
        cmds = peer.subscribe("/ctl_ui/cmd_vel", Twist)
        levels = peer.subscribe("/ctl_ui/level", Float64)
        app = _viewer(engine)
        try:
            speed = _control(app, "slider", "/ctl_ui/cmd_vel", "linear.x", minimum=-2.0, maximum=2.0)
            turn = _control(app, "slider", "/ctl_ui/cmd_vel", "angular.z", minimum=-2.0, maximum=2.0)
            level = _control(app, "slider", "/ctl_ui/level", "", minimum=0.0, maximum=10.0, step=0.5)
            _pump(app, lambda: all(i.status is Status.LIVE for i in app.items), what="sliders live")
            assert "geometry_msgs/msg/Twist" in speed.reason
            speed.widget.on_change(speed.widget.slider, 1.5)
            _pump(app, lambda: len(cmds.messages) >= 1, what="first twist")
            turn.widget.on_change(turn.widget.slider, -0.8)
            _pump(
                app,
                lambda: (cmds.messages[-1].linear.x, cmds.messages[-1].angular.z) == (1.5, -0.8),
                what="composed twist",
            )
            assert dpg.get_value(speed.widget.slider) == 1.5
            assert dpg.get_value(turn.widget.slider) == -0.8
            turn.widget.on_change(turn.widget.slider, 9.0)  # clamped to the maximum it shows
            _pump(app, lambda: cmds.messages[-1].angular.z == 2.0, what="clamped")
            assert dpg.get_value(turn.widget.slider) == 2.0
            level.widget.on_change(level.widget.slider, 3.3)  # snapped to the step
            _pump(app, lambda: levels.values() == [3.5], what="snapped")
            assert dpg.get_value(level.widget.slider) == 3.5
            # The rate limit: 60 moves in well under a second at 5 Hz.
            level.set_properties({"rate_limit": 5.0})
            start = len(levels.messages)
            t0 = time.monotonic()
            for i in range(60):
                level.widget.on_change(level.widget.slider, i / 6)
                app.frame()
            _pump(app, lambda: levels.values()[-1:] == [slider_value(59 / 6, 0, 10, 0.5)], what="last level")
            span = time.monotonic() - t0
            sent = len(levels.messages) - start
            assert sent <= span * 5 + 2, (sent, span)
            # A property change rebuilds the widget; it keeps its publisher (live) and can send at a rate.
            level.set_properties({"send": "at rate", "rate": 10.0, "rate_limit": 20.0})
            _pump(app, lambda: level.status is Status.LIVE, what="live after a property change")
            n0 = len(levels.messages)
            _pump(app, lambda: len(levels.messages) >= n0 + 5, what="sent at a set rate")
            assert set(levels.values()[n0:]) == {slider_value(59 / 6, 0, 10, 0.5)}
            shot = app.screenshot(tmp / "sliders.png")
            assert shot.stat().st_size > 0
        finally:
            app.close()


def scenario_button_and_publish(tmp: Path) -> None:
    """Button publishes its configured message; the Publish form sends the type and fields it shows."""
    import dearpygui.dearpygui as dpg
    from geometry_msgs.msg import Vector3

    from dbglog.viewer._data._engine import Engine

    with RosPeer("controls_button_peer") as peer, Engine() as engine:
        cmds = peer.subscribe("/ctl_ui/button_cmd", Twist)
        vecs = peer.subscribe("/ctl_ui/vec", Vector3)
        app = _viewer(engine)
        try:
            button = _control(
                app,
                "button",
                "/ctl_ui/button_cmd",
                text="Forward",
                message='{"linear": {"x": 0.3}, "angular.z": 0.1}',
            )
            bad = _control(
                app, "button", "/ctl_ui/bad", msg_type="std_msgs/msg/Bool", message='{"data": "yes"}'
            )
            form = _control(app, "publish", "/ctl_ui/vec")
            _pump(app, lambda: button.status is Status.LIVE, what="button live")
            _pump(app, lambda: bad.status is Status.ERROR, what="bad button error")
            assert "'message'" in bad.reason
            assert "boolean" in bad.reason
            button.widget.click()
            _pump(app, lambda: len(cmds.messages) == 1, what="button twist")
            assert (cmds.messages[0].linear.x, cmds.messages[0].angular.z) == (0.3, 0.1)
            # The Publish form: the topic's type would be picked from the installed list.
            choices = dpg.get_item_configuration(form.widget.type_combo)["items"]
            assert "geometry_msgs/msg/Vector3" in choices
            assert "std_msgs/msg/Bool" in choices
            form.widget.set_type("geometry_msgs/msg/Vector3")
            assert set(form.widget.editors) == {"x", "y", "z"}
            form.widget.set_field("x", 1.5)
            form.widget.set_field("z", -2.0)
            _pump(app, lambda: form.status is Status.LIVE, what="form live")
            form.widget.click()
            _pump(app, lambda: len(vecs.messages) == 1, what="vector")
            assert (vecs.messages[0].x, vecs.messages[0].y, vecs.messages[0].z) == (1.5, 0.0, -2.0)
            app.frame()
            assert app.files.save(tmp / "forms.json")
            saved = {w["type"]: w for w in json.loads((tmp / "forms.json").read_text())["widgets"]}
            assert saved["publish"]["properties"]["msg_type"] == "geometry_msgs/msg/Vector3"
            assert json.loads(saved["publish"]["properties"]["message"]) == {"x": 1.5, "z": -2.0}
        finally:
            app.close()


def scenario_type_clash(tmp: Path) -> None:
    """A control on a topic of another type shows a red error pill naming both types; nothing is sent."""
    from dbglog.viewer._data._engine import Engine

    with RosPeer("controls_clashui_peer") as peer, Engine() as engine:
        flags = peer.subscribe("/ctl_ui/clash_flag", Bool)
        app = _viewer(engine)
        try:
            slider = _control(app, "slider", "/ctl_ui/clash_flag")
            typed = _control(app, "toggle", "/ctl_ui/clash_flag", msg_type="std_msgs/msg/String")
            _pump(app, lambda: slider.status is Status.ERROR and typed.status is Status.ERROR, what="errors")
            assert "type clash" in slider.reason
            assert "boolean" in slider.reason
            assert "std_msgs/msg/Bool" in typed.reason
            assert "std_msgs/msg/String" in typed.reason
            slider.widget.on_change(slider.widget.slider, 0.5)
            typed.widget.on_click()
            for _ in range(30):
                app.frame()
                time.sleep(0.01)
            assert flags.messages == []
            from dbglog.viewer._ui._theme import STATUS_COLORS
            from tests.test_ui import count_color, read_png

            img = read_png(app.screenshot(tmp / "clash.png"))
            assert count_color(img, STATUS_COLORS[Status.ERROR]) > 40, "the error pill is red"
        finally:
            app.close()


def scenario_controls_get_their_own_seam(tmp: Path) -> None:
    """A control gets its publish target and the app's own publisher at mount; the engine never subscribes
    to its topic (only a display widget's series is bound); a new binding retargets it; close stops it."""
    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer.widget_api import WidgetContext

    with RosPeer("controls_seam_peer") as peer, Engine(graph_period=0.1) as engine:
        first = peer.subscribe("/ctl_ui/seam_a", Float64)
        second = peer.subscribe("/ctl_ui/seam_b", Float64)
        app = _viewer(engine)
        try:
            slider = _control(app, "slider", "/ctl_ui/seam_a", minimum=0.0, maximum=10.0)
            dial = app.add_widget("dial", 400, 20)
            assert dial is not None
            app.apply_bindings(dial, (Binding("/ctl_ui/seam_b"),))
            seam = slider.widget.context
            assert (seam.targets, seam.publisher) == ((Binding("/ctl_ui/seam_a"),), app.publisher)
            shown = dial.widget.context
            assert (shown.targets, shown.publisher) == ((), app.publisher), "a display widget has no targets"
            assert isinstance(seam, WidgetContext)
            _pump(app, lambda: slider.status is Status.LIVE, what="slider live")
            slider.widget.on_change(slider.widget.slider, 2.0)
            _pump(app, lambda: first.values() == [2.0], what="2.0 on seam_a")
            assert engine.bindings() == [Binding("/ctl_ui/seam_b")], "only the dial's series is bound"
            endpoints = peer.node.get_subscriptions_info_by_topic("/ctl_ui/seam_a")
            assert [e.node_name for e in endpoints] == ["controls_seam_peer"], "the engine never subscribes"
            # A new binding is a new target: the same publisher, now on seam_b, still no engine series for it.
            app.apply_bindings(slider, (Binding("/ctl_ui/seam_b"),))
            assert slider.widget.context.targets == (Binding("/ctl_ui/seam_b"),)
            _pump(app, lambda: slider.status is Status.LIVE, what="live on seam_b")
            slider.widget.on_change(slider.widget.slider, 3.0)
            _pump(app, lambda: second.values() == [3.0], what="3.0 on seam_b")
            assert first.values() == [2.0]
            assert engine.bindings() == [Binding("/ctl_ui/seam_b")]
            publisher = app.publisher
        finally:
            app.close()
        assert publisher._thread is None, "closing the viewer stops its publishing service"


def scenario_steer_the_demo_robot(tmp: Path) -> None:
    """The demo dashboard's Teleop group steers the simulated turtle: teleop, stopped, autopilot again."""
    import threading

    from dbglog._demo import _robot
    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._document._dashboard import load_dashboard

    stop = threading.Event()
    robot = threading.Thread(target=_robot.run, args=(None, stop), daemon=True)
    robot.start()
    try:
        with Engine() as engine:
            app = _viewer(engine)
            try:
                board = Path(_robot.__file__).with_name("demo_dashboard.json")
                app.load(load_dashboard(board, app.registry.get), board)
                mode = Binding("/rosdashboard/turtle/mode")
                engine.bind(mode)
                items = {i.name: i for i in app.items}
                speed, autopilot = items["Teleop \u00b7 speed (m/s)"], items["Teleop \u00b7 autopilot"]
                _pump(app, lambda: engine.snapshot(mode).last == "autopilot", 30, "the autopilot drives")
                # The Teleop group may lie below this window's view: out of view a widget is not redrawn,
                # so its pill is not asked; what it would show is.
                _pump(
                    app,
                    lambda: all(i.current_status(app.timeline)[0] is Status.LIVE for i in (speed, autopilot)),
                    30,
                    "live",
                )
                speed.widget.set_value(0.7)
                _pump(app, lambda: engine.snapshot(mode).last == "teleop", 20, "teleop from the slider")
                autopilot.widget.on_click()  # off: after the teleop hold the turtle stops
                _pump(app, lambda: engine.snapshot(mode).last == "stopped", 20, "stopped")
                autopilot.widget.on_click()
                _pump(app, lambda: engine.snapshot(mode).last == "autopilot", 20, "autopilot again")
            finally:
                app.close()
    finally:
        stop.set()
        robot.join(10)


def run_here(scenario: str, tmp: str) -> None:
    """Child-process entry point: run one scenario."""
    warnings.simplefilter("error")
    warnings.filterwarnings("ignore", "module 'sre_", DeprecationWarning)
    globals()[f"scenario_{scenario}"](Path(tmp))


SCENARIOS = sorted(n.removeprefix("scenario_") for n in dir() if n.startswith("scenario_"))


@pytest.mark.gui
@pytest.mark.parametrize("scenario", SCENARIOS)
def test_controls_ui(scenario: str, tmp_path: Path) -> None:
    """Each control scenario (see its docstring) passes in the real viewer, in a process of its own."""
    run_scenario("test_controls", scenario, tmp_path, timeout=100)


def test_a_note_is_cut_to_its_one_line_with_an_ellipsis() -> None:
    """A control's note longer than its width is cut where the rest fits with an ellipsis (no wrapping into
    a second line that the widget clips); a short one, and only the first line of several, show whole."""
    from dbglog.viewer._widgets._common import fit_line

    def width(text: str) -> float:
        return 7.0 * len(text)

    assert fit_line("paused: read-only", 200, width) == "paused: read-only"
    cut = fit_line("paused: the value then, read-only", 196, width)
    assert cut == "paused: the value then, rea\u2026"  # 28 characters: 196 px
    assert width(cut) <= 196
    assert fit_line("first\nsecond", 200, width) == "first"
    assert fit_line("x" * 50, 3, width) == "\u2026"
