"""Control widgets that publish: Button, Toggle, Slider, Text field and a generic Publish form.

A control's binding (set in Topic setup) is where it publishes: the topic and, for a single value, the
field (``linear.x`` of a ``geometry_msgs/msg/Twist``). The viewer hands it as the control's publish target
in its `WidgetContext` (the data engine does not subscribe to it). The type comes from the ROS graph when
the topic exists, else from the ``msg_type`` property or the control's default; a clash is the widget's
error. The app's publishing service sends off the UI thread, at most ``rate_limit`` messages per second. The
value logic (parsing a message property, stepping a slider) is in plain functions tested without a display.

Toggle, Slider and Text field may bind to a node's parameter instead (``/pid_node:kp``, `ParamLink`): they
show the node's value (the one it had at the time cursor while paused, read-only) and set it, a slider on
its descriptor's range and step, as it is released (rate limited while dragged). Their input is read on the
UI thread each frame (`redraw_key`); Dear PyGui's callbacks only count clicks and Enter presses.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import dearpygui.dearpygui as dpg

from dbglog.viewer._widgets._common import (
    DIM,
    ERROR,
    NUMBER_TYPES,
    ParamLink,
    fit_line,
    param_bounds,
    param_kind_problem,
)
from dbglog.viewer.widget_api import (
    DEFAULT_RATE_LIMIT_HZ,
    InterfaceError,
    ParamState,
    ParamType,
    Property,
    PropKind,
    PublishRequest,
    SeriesSnapshot,
    Status,
    Value,
    ValueKind,
    Widget,
    WidgetContext,
    fill_message,
    form_fields,
    installed_types,
    message_type,
)

__all__ = [
    "ButtonWidget",
    "PublishWidget",
    "SliderWidget",
    "TextFieldWidget",
    "ToggleWidget",
    "parse_message",
    "slider_value",
]

MAX_MESSAGE_CHARS = 1000
NOTE_H = 18
"""Pixels the one-line note under a control needs (it is left out when the body is shorter)."""
ROW_H = 22
_ERROR_COLOR = (236, 96, 110, 255)
_MAX_FORM_ROWS = 40


def parse_message(text: str) -> dict[str, object]:
    """Parse a message property: a JSON object of field values (nested or dotted), ``""`` for none.

    Raises:
        ValueError: not JSON, not an object, or too long; the message says what was wrong.
    """
    if not text.strip():
        return {}
    if len(text) > MAX_MESSAGE_CHARS:
        raise ValueError(f"message is longer than {MAX_MESSAGE_CHARS} characters")
    try:
        value = json.loads(text, parse_constant=_no_constant)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise ValueError(f"message is not valid JSON: {exc}") from None
    if not isinstance(value, dict):
        raise ValueError(f"message must be a JSON object of field values, got {type(value).__name__}")
    return value


def _no_constant(name: str) -> object:
    raise ValueError(f"{name} is not a valid field value")


def slider_value(value: float, minimum: float, maximum: float, step: float) -> float:
    """Clamp `value` to [minimum, maximum] and snap it to `step` (0 = no snapping) counted from `minimum`."""
    low, high = min(minimum, maximum), max(minimum, maximum)
    if not math.isfinite(value):
        value = low
    v = min(high, max(low, value))
    if step > 0:
        v = low + round((v - low) / step) * step
        v = min(high, max(low, v))
        v = round(v, 12)
    return v


_RATE = Property(
    "rate_limit",
    PropKind.NUMBER,
    DEFAULT_RATE_LIMIT_HZ,
    label="Rate limit (Hz)",
    minimum=0.1,
    maximum=100.0,
    help="The most messages per second this control sends; the latest value always goes out.",
)
_TYPE_HELP = (
    "Empty: the topic's type from the ROS graph, or the default for a new topic. "
    "A type that differs from the graph's is shown as an error."
)


class _Control(Widget):
    """What every control shares: its target from the context, the publisher state as its status."""

    publishes = True
    default_type: ClassVar[str] = "std_msgs/msg/Float64"
    value_kind: ClassVar[str] = "number"

    def __init__(self, props: Mapping[str, Any] | None = None) -> None:
        super().__init__(props)
        self.topic = ""
        self.field = ""
        self.problem = ""
        """A configuration problem found by the widget itself (bad message JSON), shown as its error."""
        self.note: int | str = 0
        self._note_w = 60
        self._note_tip: int | str = 0
        self._note_tipbox: int | str = 0
        self.link = ParamLink(self)
        """The node's parameter the control is bound to instead of a topic (`parameters` controls)."""
        self.param_note = ""
        """A problem the control found with what it was to set (typed text of another type), "" for none."""
        self.asks = 0
        """Clicks (Toggle) or Enter presses and Send clicks (Text field) while bound to a parameter: Dear
        PyGui's callback thread counts them, `update` (the UI thread) sets the parameter."""
        self._asks_done = 0
        self._param_shown: tuple[str, bool] | None = None

    # -- the viewer's calls -------------------------------------------------------------------------

    def status(self) -> tuple[Status, str] | None:
        """The publisher's state: error (type clash...), waiting (no subscriber) or live; bound to a node's
        parameter, the parameter's (asked, answered, the node's error)."""
        if self.link.target:
            param = self.link.state()
            return param.status, param.reason
        if not self.topic:
            return None
        if self.problem:
            return Status.ERROR, self.problem
        state = self.publisher().state(self)
        return state.status, state.reason

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Show the target line (a control reads no series: its target comes with its context); bound to a
        node's parameter, send what the user did and show the parameter."""
        if self.link.target:
            self.show_parameter(self.link.state())
            return
        self._show_note()

    def redraw_key(self) -> object:
        """Bound to a node's parameter: its state and the user's input (a drag, a click, Enter)."""
        if not self.link.target:
            return None
        return (self.link.state().version, self.input_key())

    def input_key(self) -> object:
        """What the user did to the control (read every frame while bound to a parameter)."""
        return None

    def show_parameter(self, state: ParamState) -> None:
        """Send what the user did, and show the parameter's value and note (bound to a parameter)."""
        self._show_param_note(state)

    def _show_param_note(self, state: ParamState, problem: str = "") -> None:
        """The line under the control: a problem, the last set's outcome, or the target and its range."""
        if not self.note or not dpg.does_item_exist(self.note):
            return
        text, bad = problem, bool(problem)
        if not text:
            text, bad = state.note, state.problem
        if not text:
            span = state.range
            text = f"\u2192 {self.link.target}" + (f"   {span.text}" if span is not None else "")
        if (text, bad) != self._param_shown:
            self._param_shown = (text, bad)
            self._set_note(text)
            dpg.configure_item(self.note, color=ERROR if bad else DIM)

    def set_context(self, context: WidgetContext) -> None:
        """Take the new target (the user changed the binding) and keep the publisher ready."""
        super().set_context(context)
        was = self.link.target
        if self._retarget():
            if self.link.target or was:  # built for a parameter, or for a topic again
                if self.link.target:
                    self.publisher().release(self)  # a topic no more: nothing to publish
                self.resize(self.width, self.height)
            self._prepare(send=self.repeat_hz() > 0)
        self._show_note()

    def destroy(self) -> None:
        """Release the publisher, then delete the items."""
        self.publisher().release(self)
        super().destroy()

    def mount(self, parent: int | str, width: int, height: int, context: WidgetContext | None = None) -> None:
        """Take the target, build the widget and make the publisher ready (again after a rebuild)."""
        if context is not None:
            self.context = context
        self._retarget()
        super().mount(parent, width, height)
        self._prepare(send=self.repeat_hz() > 0)

    def _retarget(self) -> bool:
        """Take topic and field from the context's first target (or the node's parameter it names, for a
        control that sets parameters); True when they changed."""
        targets = self.context.targets
        target = (targets[0].topic, targets[0].field) if targets else ("", "")
        param = self.link.retarget() if self.parameters else False
        if target == (self.topic, self.field):
            return param
        self.topic, self.field = target
        return True

    # -- publishing ---------------------------------------------------------------------------------

    def value(self) -> Value | None:
        """The single value the control shows (None for whole-message controls)."""
        return None

    def request(self) -> PublishRequest:
        """What the control publishes now."""
        return PublishRequest(
            self.topic,
            msg_type=str(self.prop("msg_type")).strip(),
            default_type=self.default_type,
            field=self.field,
            value=self.value(),
            value_kind=self.value_kind,
        )

    def _prepare(self, *, send: bool = False) -> None:
        if not self.topic or self.link.target:
            return
        self.publisher().update(
            self,
            self.request(),
            send=send and not self.problem,
            rate_limit_hz=self.num("rate_limit"),
            repeat_hz=self.repeat_hz(),
        )

    def repeat_hz(self) -> float:
        """Send the current value again this often (0 = only on change)."""
        return 0.0

    def send(self) -> None:
        """Publish the current value (rate limited; never blocks)."""
        if self.link.target:
            return  # a parameter is set from `update`, on the UI thread
        if not self.topic:
            self.problem = ""
            self._show_note("no topic: right-click \u203a Topic setup")
            return
        self._prepare(send=True)

    def _show_note(self, text: str | None = None) -> None:
        if not self.note or not dpg.does_item_exist(self.note) or self.link.target:
            return
        if text is None:
            if self.problem:
                text = self.problem
            elif self.topic:
                target = self.topic + (f" \u203a {self.field}" if self.field else "")
                text = f"\u2192 {target}"
            else:
                text = "no topic: right-click \u203a Topic setup"
        self._set_note(text)
        dpg.configure_item(self.note, color=_ERROR_COLOR if self.problem else DIM)

    def _set_note(self, text: str) -> None:
        """Show `text` on the note's one line (cut with an ellipsis where longer; all of it on hover)."""
        width = self._note_w

        def measure(line: str) -> float:
            size = dpg.get_text_size(line)
            return float(size[0]) if size else 0.0

        shown = fit_line(text, width, measure)
        dpg.set_value(self.note, shown)
        dpg.set_value(self._note_tip, text)
        dpg.configure_item(self._note_tipbox, show=shown != text)

    def _add_note(self, parent: int | str, width: int, room: int = NOTE_H) -> None:
        """Add the one-line target/problem note when `room` pixels are left for it."""
        if room < NOTE_H:
            self.note = 0
            return
        self._note_w = max(60, width - 4)
        self.note = dpg.add_text("", parent=parent, color=DIM)
        with dpg.tooltip(self.note, show=False) as self._note_tipbox:
            self._note_tip = dpg.add_text("", wrap=400)
        self._param_shown = None
        self._show_note()


class ToggleWidget(_Control):
    """Publishes true/false (std_msgs/msg/Bool) each time it is switched, or sets a boolean parameter."""

    type_name = "toggle"
    label = "Toggle"
    description = "Publishes true/false (std_msgs/Bool) when switched, or sets a node's boolean parameter"
    accepts = frozenset({ValueKind.BOOL})
    default_type = "std_msgs/msg/Bool"
    value_kind = "bool"
    parameters = True
    properties = (
        Property("state", PropKind.BOOL, False, help="The current state; saved with the dashboard."),
        Property("on_text", PropKind.TEXT, "ON"),
        Property("off_text", PropKind.TEXT, "OFF"),
        Property("msg_type", PropKind.TEXT, "", label="Message type", help=_TYPE_HELP),
        _RATE,
    )
    default_size = (200, 70)
    min_size = (120, 40)

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build one wide switch button and the target line."""
        room = height - ROW_H
        self.button = dpg.add_button(
            parent=parent,
            width=max(60, width - 4),
            height=max(ROW_H, height - NOTE_H - 4 if room >= NOTE_H else height),
            callback=self.on_click,
        )
        with dpg.theme() as self._on_theme, dpg.theme_component(dpg.mvButton):
            dpg.add_theme_color(dpg.mvThemeCol_Button, (46, 120, 70, 255))
            dpg.add_theme_color(dpg.mvThemeCol_ButtonHovered, (56, 140, 84, 255))
            dpg.add_theme_color(dpg.mvThemeCol_ButtonActive, (66, 160, 96, 255))
        self._add_note(parent, width, room)
        self._look: tuple[bool, bool] | None = None
        if self.link.target:
            dpg.configure_item(self.button, label="\u2014", enabled=False)  # until the node's value is known
        else:
            self._draw()

    def destroy(self) -> None:
        """Release the publisher and delete the items and theme."""
        super().destroy()
        if dpg.does_item_exist(self._on_theme):
            dpg.delete_item(self._on_theme)

    def _draw(self, on: bool | None = None, *, enabled: bool = True) -> None:
        if on is None:
            on = bool(self.prop("state"))
        dpg.configure_item(
            self.button, label=str(self.prop("on_text" if on else "off_text")), enabled=enabled
        )
        dpg.bind_item_theme(self.button, self._on_theme if on else 0)

    def value(self) -> Value | None:
        """The state shown."""
        return bool(self.prop("state"))

    def on_click(self, *_: object) -> None:
        """Switch and publish the new state (bound to a parameter: counted, and set by `update`)."""
        if self.link.target:
            self.asks += 1
            return
        self.set_state(not bool(self.prop("state")))

    def input_key(self) -> object:
        """The clicks so far."""
        return self.asks

    def show_parameter(self, state: ParamState) -> None:
        """A click sets the parameter to the opposite of the node's value; show the node's value."""
        problem = param_kind_problem(state, (ParamType.BOOL,), "Toggle", "true or false")
        if self.asks != self._asks_done:
            self._asks_done = self.asks
            if state.editable and not problem and state.value is not None:
                self.link.set(not bool(state.value.value), final=True, rate_hz=self.num("rate_limit"))
        on = state.value is not None and state.value.value is True
        look = (on, state.editable and not problem)
        if look != self._look:
            self._look = look
            self._draw(on, enabled=look[1])
        self._show_param_note(state, problem)

    def set_state(self, on: bool) -> None:
        """Show `on` and publish it."""
        self.save_property("state", bool(on))
        self._draw()
        self.send()


class SliderWidget(_Control):
    """Publishes a number within min/max: when moved, or continuously at a set rate; or sets a node's number
    parameter on its descriptor's range and step."""

    type_name = "slider"
    label = "Slider"
    description = "Publishes a number (Float64, or a field such as linear.x of a Twist) when moved"
    accepts = frozenset({ValueKind.NUMBER})
    parameters = True
    properties = (
        Property("value", PropKind.NUMBER, 0.0, help="The current value; saved with the dashboard."),
        Property("minimum", PropKind.NUMBER, -1.0),
        Property("maximum", PropKind.NUMBER, 1.0),
        Property("step", PropKind.NUMBER, 0.0, minimum=0.0, help="Snap to multiples of this (0 = off)."),
        Property("decimals", PropKind.NUMBER, 2.0, minimum=0, maximum=9, integer=True),
        Property("send", PropKind.CHOICE, "on change", choices=("on change", "at rate")),
        Property("rate", PropKind.NUMBER, 10.0, label="Send rate (Hz)", minimum=0.1, maximum=100.0),
        Property("msg_type", PropKind.TEXT, "", label="Message type", help=_TYPE_HELP),
        _RATE,
    )
    default_size = (320, 44)
    min_size = (160, 24)

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build the slider, a zero button (not for a parameter) and the target line."""
        decimals = int(self.num("decimals"))
        param = bool(self.link.target)
        self._look: tuple[object, ...] | None = None
        self._dragged: float | None = None
        with dpg.group(horizontal=True, parent=parent):
            self.slider = dpg.add_slider_double(
                default_value=self.num("value"),
                min_value=min(self.num("minimum"), self.num("maximum")),
                max_value=max(self.num("minimum"), self.num("maximum")),
                format=f"%.{decimals}f",
                width=max(60, width - 4 if param else width - 56),
                callback=self.on_change,
                enabled=not param,
            )
            self.zero = dpg.add_button(
                label="0", width=40, callback=lambda *_: self.set_value(0.0), show=not param
            )
        self._add_note(parent, width, height - ROW_H)

    def value(self) -> Value | None:
        """The number shown."""
        return self.num("value")

    def repeat_hz(self) -> float:
        """The send rate in "at rate" mode."""
        return self.num("rate") if self.prop("send") == "at rate" else 0.0

    def on_change(self, sender: object = None, app_data: object = None, *_: object) -> None:
        """Slider callback: take the new position and publish it (a parameter's is read by `update`)."""
        if self.link.target:
            return
        value = app_data if isinstance(app_data, int | float) else dpg.get_value(self.slider)
        self.set_value(float(value))

    def input_key(self) -> object:
        """Whether the slider is held, and where."""
        if not dpg.does_item_exist(self.slider):
            return None
        active = bool(dpg.is_item_active(self.slider))
        return (active, float(dpg.get_value(self.slider)) if active else None)

    def show_parameter(self, state: ParamState) -> None:
        """While the slider is dragged, send its value (rate limited); let go, send the last one at once;
        otherwise show the node's value, on the descriptor's range (or the slider's minimum and maximum)."""
        problem = param_kind_problem(state, NUMBER_TYPES, "Slider", "numbers")
        lo, hi, _step, integer = param_bounds(state, self.num("minimum"), self.num("maximum"))
        editable = state.editable and not problem
        decimals = 0 if integer else int(self.num("decimals"))
        look = (lo, hi, decimals, editable)
        if look != self._look:
            self._look = look
            dpg.configure_item(
                self.slider, min_value=lo, max_value=hi, format=f"%.{decimals}f", enabled=editable
            )
        active = bool(dpg.is_item_active(self.slider))
        at = float(dpg.get_value(self.slider))
        rate = self.num("rate_limit")
        if active and editable:
            if at != self._dragged:
                self._dragged = at
                self.link.set(at, final=False, rate_hz=rate)
        else:
            if self._dragged is not None:  # let go: the last value goes out now
                last, self._dragged = self._dragged, None
                if editable:
                    self.link.set(last, final=True, rate_hz=rate)
                    state = self.link.state()  # what was sent (on the step), or the node's value
            shown = state.number
            if shown is not None and shown != at:
                dpg.set_value(self.slider, shown)
        self._show_param_note(state, problem)

    def set_value(self, value: float) -> None:
        """Show `value` (clamped and snapped) and publish it."""
        v = slider_value(value, self.num("minimum"), self.num("maximum"), self.num("step"))
        self.save_property("value", v)
        if dpg.does_item_exist(self.slider) and dpg.get_value(self.slider) != v:
            dpg.set_value(self.slider, v)
        self.send()


class TextFieldWidget(_Control):
    """Publishes the typed text (std_msgs/msg/String) on Enter or Send, or sets a node's parameter to the
    typed value (read as ``ros2 param set`` reads it)."""

    type_name = "text_field"
    label = "Text field"
    description = "Publishes the typed text (std_msgs/String) on Enter or Send, or sets a node's parameter"
    accepts = frozenset({ValueKind.TEXT})
    default_type = "std_msgs/msg/String"
    value_kind = "string"
    parameters = True
    properties = (
        Property("text", PropKind.TEXT, "", help="The text last sent; saved with the dashboard."),
        Property("msg_type", PropKind.TEXT, "", label="Message type", help=_TYPE_HELP),
        _RATE,
    )
    default_size = (320, 44)
    min_size = (160, 24)

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build the input, the Send button and the target line."""
        with dpg.group(horizontal=True, parent=parent):
            self.input = dpg.add_input_text(
                default_value=str(self.prop("text")),
                width=max(60, width - 70),
                on_enter=True,
                hint="type, then Enter",
                callback=lambda *_: self.submit(),
            )
            self.send_button = dpg.add_button(label="Send", width=56, callback=lambda *_: self.submit())
        self._add_note(parent, width, height - ROW_H)
        self._readonly: bool | None = None
        self._param_text: str | None = None

    def value(self) -> Value | None:
        """The text shown."""
        return str(self.prop("text"))

    def submit(self, text: str | None = None) -> None:
        """Publish `text` (default: what is typed); bound to a parameter, counted and set by `update`."""
        if self.link.target:
            self.asks += 1
            return
        typed = str(dpg.get_value(self.input)) if text is None else text
        self.save_property("text", typed[:1000])
        if text is not None:
            dpg.set_value(self.input, typed)
        self.send()

    def input_key(self) -> object:
        """Enter presses and Send clicks so far, and whether the field is being typed in."""
        active = bool(dpg.does_item_exist(self.input) and dpg.is_item_active(self.input))
        return (self.asks, active)

    def show_parameter(self, state: ParamState) -> None:
        """Enter or Send sets the parameter to the typed value; while not typed in, the field shows the
        node's value (read-only when it may not be set)."""
        if self.asks != self._asks_done:
            self._asks_done = self.asks
            typed = str(dpg.get_value(self.input))
            self.param_note = ""
            if state.editable:
                try:
                    self.link.set(state.parse(typed), final=True, rate_hz=self.num("rate_limit"))
                except ValueError as exc:
                    self.param_note = f"not set: {exc}"
        readonly = not state.editable
        if readonly != self._readonly:
            self._readonly = readonly
            dpg.configure_item(self.input, readonly=readonly)
            dpg.configure_item(self.send_button, enabled=not readonly)
        if not dpg.is_item_active(self.input):  # not being typed in: the node's value (a refused one undone)
            text = "" if state.value is None else state.value.text
            if text != self._param_text:
                self._param_text = text
                self.param_note = ""
            if text != dpg.get_value(self.input):
                dpg.set_value(self.input, text)
        self._show_param_note(state, self.param_note)


class ButtonWidget(_Control):
    """Publishes one configured message each time it is clicked."""

    type_name = "button"
    label = "Button"
    description = "Publishes a configured message when clicked"
    accepts = frozenset({ValueKind.NUMBER, ValueKind.BOOL, ValueKind.TEXT})
    default_type = "std_msgs/msg/Empty"
    properties = (
        Property("text", PropKind.TEXT, "Send", label="Button text"),
        Property("msg_type", PropKind.TEXT, "", label="Message type", help=_TYPE_HELP),
        Property(
            "message",
            PropKind.TEXT,
            "{}",
            help='The message as JSON field values, e.g. {"linear": {"x": 0.5}} or {"data": true}.',
        ),
        _RATE,
    )
    default_size = (200, 70)
    min_size = (120, 40)

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build the button and the target line; check the message now."""
        room = height - ROW_H
        self.button = dpg.add_button(
            label=str(self.prop("text")),
            parent=parent,
            width=max(60, width - 4),
            height=max(ROW_H, height - NOTE_H - 4 if room >= NOTE_H else height),
            callback=lambda *_: self.click(),
        )
        self._check()
        self._add_note(parent, width, room)
        self._prepare()

    def _check(self) -> dict[str, object]:
        try:
            fields = parse_message(str(self.prop("message")))
            explicit = str(self.prop("msg_type")).strip()
            if explicit:
                fill_message(message_type(explicit), fields)  # checked against the type at load
        except (ValueError, InterfaceError) as exc:
            self.problem = f"property 'message': {exc}"
            return {}
        self.problem = ""
        return fields

    def request(self) -> PublishRequest:
        """The configured message."""
        return PublishRequest(
            self.topic,
            msg_type=str(self.prop("msg_type")).strip(),
            default_type=self.default_type,
            fields=self._check(),
        )

    def click(self) -> None:
        """Publish the configured message."""
        self.send()


class PublishWidget(_Control):
    """Any installed message type, its fields filled in a form, published on click."""

    type_name = "publish"
    label = "Publish"
    description = "Pick any installed message type, fill its fields, publish"
    accepts = frozenset({ValueKind.NUMBER, ValueKind.BOOL, ValueKind.TEXT})
    default_type = "std_msgs/msg/String"
    properties = (
        Property("msg_type", PropKind.TEXT, "std_msgs/msg/String", label="Message type"),
        Property("message", PropKind.TEXT, "{}", help="The form's values as JSON; saved with the dashboard."),
        _RATE,
    )
    default_size = (380, 300)
    min_size = (240, 160)

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build the type picker, one editor per field, and the Publish button."""
        self.editors: dict[str, tuple[int | str, str]] = {}
        types = list(installed_types())
        current = str(self.prop("msg_type")).strip()
        self.type_combo = dpg.add_combo(
            types, default_value=current, width=max(80, width - 4), parent=parent, callback=self.on_type
        )
        values = self._values()
        with dpg.child_window(
            parent=parent, width=max(80, width - 4), height=max(40, height - 100), border=False
        ):
            try:
                fields = form_fields(message_type(current)) if current else []
            except InterfaceError as exc:
                self.problem = str(exc)
                fields = []
            for f in fields[:_MAX_FORM_ROWS]:
                self.editors[f.path] = (self._editor(f.path, f.kind, values.get(f.path)), f.kind)
            if len(fields) > _MAX_FORM_ROWS:
                dpg.add_text(f"(first {_MAX_FORM_ROWS} of {len(fields)} fields)", color=DIM)
            if current and not fields and not self.problem:
                dpg.add_text("(a message without fields)", color=DIM)
        self.button = dpg.add_button(
            label="Publish", parent=parent, width=120, callback=lambda *_: self.click()
        )
        self._add_note(parent, width)

    def _editor(self, path: str, kind: str, value: object) -> int | str:
        label = path
        callback = self.on_field
        item: int | str
        if kind == "bool":
            item = dpg.add_checkbox(label=label, default_value=bool(value), callback=callback, user_data=path)
        elif kind == "string":
            item = dpg.add_input_text(
                label=label, default_value=str(value or ""), width=-160, callback=callback, user_data=path
            )
        else:
            number = float(value) if isinstance(value, int | float) and not isinstance(value, bool) else 0.0
            item = dpg.add_input_double(
                label=label,
                default_value=number,
                width=-160,
                format="%.0f" if kind == "int" else "%.6g",
                callback=callback,
                user_data=path,
            )
        return item

    def _values(self) -> dict[str, object]:
        try:
            raw = parse_message(str(self.prop("message")))
        except ValueError:
            return {}
        flat: dict[str, object] = {}

        def walk(d: Mapping[str, object], prefix: str) -> None:
            for k, v in d.items():
                if isinstance(v, Mapping):
                    walk(v, f"{prefix}{k}.")
                else:
                    flat[f"{prefix}{k}"] = v

        walk(raw, "")
        return flat

    def on_type(self, sender: object = None, app_data: object = None, *_: object) -> None:
        """Type picker callback: take the new type, clear the form values and rebuild."""
        self.set_type(str(app_data if isinstance(app_data, str) else dpg.get_value(self.type_combo)))

    def set_type(self, msg_type: str) -> None:
        """Switch to `msg_type` (as picking it does)."""
        self.save_property("msg_type", msg_type)
        self.save_property("message", "{}")
        self.problem = ""
        self.resize(self.width, self.height)
        self._prepare()

    def on_field(self, sender: object = None, app_data: object = None, user_data: object = None) -> None:
        """Form callback: store the edited value in the ``message`` property."""
        if isinstance(user_data, str):
            self.set_field(user_data, app_data)

    def set_field(self, path: str, value: object) -> None:
        """Put `value` into the form field `path` (as typing it does) and store the form."""
        editor, kind = self.editors[path]
        if kind == "int" and isinstance(value, float):
            value = round(value)
        if dpg.get_value(editor) != value:
            dpg.set_value(editor, value)
        values = self._values()
        values[path] = value
        text = json.dumps(values, allow_nan=False)
        if len(text) <= MAX_MESSAGE_CHARS:
            self.save_property("message", text)

    def request(self) -> PublishRequest:
        """The form's message."""
        values = self._values()
        for path, (_, kind) in self.editors.items():
            if kind == "int" and isinstance(values.get(path), float):
                values[path] = round(float(values[path]))  # type: ignore[arg-type]
        return PublishRequest(
            self.topic,
            msg_type=str(self.prop("msg_type")).strip(),
            default_type=self.default_type,
            fields=values,
        )

    def click(self) -> None:
        """Publish the form's message."""
        self.send()
