"""Control widgets that publish: Button, Toggle, Slider, Text field and a generic Publish form.

A control's binding (set in Topic setup) is where it publishes: the topic and, for a single value, the
field (``linear.x`` of a ``geometry_msgs/msg/Twist``). The viewer hands it as the control's publish target
in its `WidgetContext` (the data engine does not subscribe to it). The type comes from the ROS graph when
the topic exists, else from the ``msg_type`` property or the control's default; a clash is the widget's
error. The app's publishing service sends off the UI thread, at most ``rate_limit`` messages per second. The
value logic (parsing a message property, stepping a slider) is in plain functions tested without a display.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import dearpygui.dearpygui as dpg

from dbglog.viewer._widgets._common import DIM
from dbglog.viewer.widget_api import (
    DEFAULT_RATE_LIMIT_HZ,
    InterfaceError,
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

    # -- the viewer's calls -------------------------------------------------------------------------

    def status(self) -> tuple[Status, str] | None:
        """The publisher's state: error (type clash...), waiting (no subscriber) or live."""
        if not self.topic:
            return None
        if self.problem:
            return Status.ERROR, self.problem
        state = self.publisher().state(self)
        return state.status, state.reason

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Show the target line (a control reads no series: its target comes with its context)."""
        self._show_note()

    def set_context(self, context: WidgetContext) -> None:
        """Take the new target (the user changed the binding) and keep the publisher ready."""
        super().set_context(context)
        if self._retarget():
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
        """Take topic and field from the context's first target; True when they changed."""
        targets = self.context.targets
        target = (targets[0].topic, targets[0].field) if targets else ("", "")
        if target == (self.topic, self.field):
            return False
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
        if not self.topic:
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
        if not self.topic:
            self.problem = ""
            self._show_note("no topic: right-click \u203a Topic setup")
            return
        self._prepare(send=True)

    def _show_note(self, text: str | None = None) -> None:
        if not self.note or not dpg.does_item_exist(self.note):
            return
        if text is None:
            if self.problem:
                text = self.problem
            elif self.topic:
                target = self.topic + (f" \u203a {self.field}" if self.field else "")
                text = f"\u2192 {target}"
            else:
                text = "no topic: right-click \u203a Topic setup"
        dpg.set_value(self.note, text)
        dpg.configure_item(self.note, color=_ERROR_COLOR if self.problem else DIM)

    def _add_note(self, parent: int | str, width: int, room: int = NOTE_H) -> None:
        """Add the one-line target/problem note when `room` pixels are left for it."""
        if room < NOTE_H:
            self.note = 0
            return
        self.note = dpg.add_text("", parent=parent, color=DIM, wrap=max(60, width - 4))
        self._show_note()


class ToggleWidget(_Control):
    """Publishes true/false (std_msgs/msg/Bool) each time it is switched."""

    type_name = "toggle"
    label = "Toggle"
    description = "Publishes true/false (std_msgs/Bool) when switched"
    accepts = frozenset({ValueKind.BOOL})
    default_type = "std_msgs/msg/Bool"
    value_kind = "bool"
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
        self._draw()

    def destroy(self) -> None:
        """Release the publisher and delete the items and theme."""
        super().destroy()
        if dpg.does_item_exist(self._on_theme):
            dpg.delete_item(self._on_theme)

    def _draw(self) -> None:
        on = bool(self.prop("state"))
        dpg.configure_item(self.button, label=str(self.prop("on_text" if on else "off_text")))
        dpg.bind_item_theme(self.button, self._on_theme if on else 0)

    def value(self) -> Value | None:
        """The state shown."""
        return bool(self.prop("state"))

    def on_click(self, *_: object) -> None:
        """Switch and publish the new state."""
        self.set_state(not bool(self.prop("state")))

    def set_state(self, on: bool) -> None:
        """Show `on` and publish it."""
        self.save_property("state", bool(on))
        self._draw()
        self.send()


class SliderWidget(_Control):
    """Publishes a number within min/max: when moved, or continuously at a set rate."""

    type_name = "slider"
    label = "Slider"
    description = "Publishes a number (Float64, or a field such as linear.x of a Twist) when moved"
    accepts = frozenset({ValueKind.NUMBER})
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
        """Build the slider, a zero button and the target line."""
        decimals = int(self.num("decimals"))
        with dpg.group(horizontal=True, parent=parent):
            self.slider = dpg.add_slider_double(
                default_value=self.num("value"),
                min_value=min(self.num("minimum"), self.num("maximum")),
                max_value=max(self.num("minimum"), self.num("maximum")),
                format=f"%.{decimals}f",
                width=max(60, width - 56),
                callback=self.on_change,
            )
            self.zero = dpg.add_button(label="0", width=40, callback=lambda *_: self.set_value(0.0))
        self._add_note(parent, width, height - ROW_H)

    def value(self) -> Value | None:
        """The number shown."""
        return self.num("value")

    def repeat_hz(self) -> float:
        """The send rate in "at rate" mode."""
        return self.num("rate") if self.prop("send") == "at rate" else 0.0

    def on_change(self, sender: object = None, app_data: object = None, *_: object) -> None:
        """Slider callback: take the new position and publish it."""
        value = app_data if isinstance(app_data, int | float) else dpg.get_value(self.slider)
        self.set_value(float(value))

    def set_value(self, value: float) -> None:
        """Show `value` (clamped and snapped) and publish it."""
        v = slider_value(value, self.num("minimum"), self.num("maximum"), self.num("step"))
        self.save_property("value", v)
        if dpg.does_item_exist(self.slider) and dpg.get_value(self.slider) != v:
            dpg.set_value(self.slider, v)
        self.send()


class TextFieldWidget(_Control):
    """Publishes the typed text (std_msgs/msg/String) on Enter or Send."""

    type_name = "text_field"
    label = "Text field"
    description = "Publishes the typed text (std_msgs/String) on Enter or Send"
    accepts = frozenset({ValueKind.TEXT})
    default_type = "std_msgs/msg/String"
    value_kind = "string"
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
            dpg.add_button(label="Send", width=56, callback=lambda *_: self.submit())
        self._add_note(parent, width, height - ROW_H)

    def value(self) -> Value | None:
        """The text shown."""
        return str(self.prop("text"))

    def submit(self, text: str | None = None) -> None:
        """Publish `text` (default: what is typed)."""
        typed = str(dpg.get_value(self.input)) if text is None else text
        self.save_property("text", typed[:1000])
        if text is not None:
            dpg.set_value(self.input, typed)
        self.send()


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
