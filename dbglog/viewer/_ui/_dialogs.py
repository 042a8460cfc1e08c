"""Modal dialogs: topic setup (type-ahead topics, field list, regex preview), properties, rename, messages."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Protocol

import dearpygui.dearpygui as dpg

from dbglog._regex._compile import RegexError, compile_regex
from dbglog._ros._params import ParamValue, join_name, resolve_node, split_name
from dbglog._ros._tags import TagError, robot_target
from dbglog.viewer._data._model import (
    EVERY_ROBOT,
    SELECTED_ROBOT,
    Binding,
    FieldInfo,
    SeriesSnapshot,
    Status,
    TopicInfo,
    ValueKind,
)
from dbglog.viewer._document._canvas_doc import topic_widget_name
from dbglog.viewer._document._dashboard import WidgetConfig, check_stale_after
from dbglog.viewer._ui._frame import CanvasItem
from dbglog.viewer._ui._theme import DIM, STATUS_COLORS
from dbglog.viewer._values._expr import FormulaError, parse_formula
from dbglog.viewer._values._transforms import (
    Invalid,
    TransformError,
    transforms_from_json,
    transforms_or_invalid,
    written_transforms,
)
from dbglog.viewer.widget_api import PropertyError, PropKind, PropValue, format_color, parse_color

__all__ = [
    "TRANSFORM_KINDS",
    "Dialog",
    "MarkerDialog",
    "MessageDialog",
    "PropertiesDialog",
    "RenameDialog",
    "SaveAsDialog",
    "TopicDialog",
    "TopicHost",
    "dashboard_file_name",
    "file_name",
    "formula_check",
    "parameter_suggestions",
    "regex_preview",
    "topic_widget_name",
    "typed_target",
]

TRANSFORM_KINDS: dict[str, tuple[str, str, str]] = {
    "rad2deg": ("radians \u2192 degrees", "", ""),
    "deg2rad": ("degrees \u2192 radians", "", ""),
    "scale": ("scale and offset", "scale", "offset"),
    "abs": ("absolute value", "", ""),
    "clamp": ("clamp", "min", "max"),
    "derivative": ("derivative (per second)", "", ""),
    "moving_average": ("moving average", "window", ""),
    "unwrap": ("angle unwrap", "period", ""),
    "formula": ("formula", "", ""),
}
"""Transform kind -> (menu label, first parameter, second parameter) for the topic setup dialog."""
_PARAM_DEFAULTS = {
    "scale": 1.0,
    "offset": 0.0,
    "min": 0.0,
    "max": 1.0,
    "window": 5.0,
    "period": 6.283185307179586,
}

LOG_MSG_TYPE = "rcl_interfaces/msg/Log"
LOG_LEVEL_CHOICES = ("any", "debug", "info", "warn", "error", "fatal")
"""A Log binding's minimum levels in Topic setup (`Binding.level`; "any" is none)."""
ERROR_COLOR = STATUS_COLORS[Status.ERROR]
OK_COLOR = STATUS_COLORS[Status.LIVE]


def formula_check(text: str) -> tuple[bool, str]:
    """Return (ok, text) for a formula as it is typed: the fields it reads, or why it is refused."""
    if not text.strip():
        return False, "type a formula of x (the value), e.g. x * 57.2958"
    try:
        formula = parse_formula(text)
    except FormulaError as exc:
        return False, f"not allowed: {exc}"
    fields = ", ".join(sorted(formula.fields))
    return True, "ok" + (f": also reads {fields} from the same message" if fields else "")


def regex_preview(pattern: str, latest: str | None) -> tuple[bool, str]:
    """Return (ok, text) describing what `pattern` extracts from the latest value, or the RE2 error."""
    if not pattern:
        return True, "no regex: the whole value is used"
    try:
        compiled = compile_regex(pattern)
    except RegexError as exc:
        return False, f"regex error: {exc}"
    if latest is None:
        return True, "regex compiles; no value received yet to try it on"
    found = compiled.extract(latest)
    if found is None:
        return False, "no match in the latest value"
    return True, f"extracts: {found!r}"


class Dialog:
    """A modal window; subclasses add content. `close` deletes it."""

    def __init__(self, title: str, width: int, on_close: Callable[[Dialog], None]) -> None:
        self._on_close = on_close
        vw, vh = dpg.get_viewport_client_width() or 1200, dpg.get_viewport_client_height() or 800
        # The height follows the content; the width stays as asked, whatever is typed or shown.
        self.window = dpg.add_window(
            label=title,
            modal=True,
            width=width,
            min_size=(width, 40),
            max_size=(width, max(200, vh - 40)),
            autosize=True,
            no_collapse=True,
            no_saved_settings=True,
            pos=(max(0, (vw - width) // 2), max(0, vh // 5)),
            on_close=lambda *_: self.close(),
        )
        self.closed = False
        self._events: list[tuple[str, object]] = []
        """What was clicked or typed (Dear PyGui's callback thread), for `tick` to take (`_take_events`)."""
        self._events_lock = threading.Lock()
        self._focus_next: tuple[int | str, int] | None = None
        """An item to give the keyboard, and the rendered frame from which to do it."""

    def _record(self, what: str, value: object) -> None:
        """Callback thread: note what was clicked or typed, for the next `tick`."""
        with self._events_lock:
            self._events.append((what, value))

    def _take_events(self) -> list[tuple[str, object]]:
        """UI thread: what was recorded since the last call, in order."""
        with self._events_lock:
            events, self._events = self._events, []
        return events

    def tick(self) -> None:
        """Called once per frame while open (subclasses call this first)."""
        if self._focus_next is not None and dpg.get_frame_count() >= self._focus_next[1]:
            item, self._focus_next = self._focus_next[0], None
            if dpg.does_item_exist(item):
                dpg.focus_item(item)

    def focus_soon(self, item: int | str) -> None:
        """Give `item` the keyboard two frames from now, once the key that opened the dialog has passed.

        A shortcut's own character (the S of Ctrl+Shift+S) reaches Dear ImGui after the key press that
        opened the dialog: a field focused at once would take it.
        """
        self._focus_next = (item, dpg.get_frame_count() + 2)

    def close(self) -> None:
        """Remove the dialog."""
        if self.closed:
            return
        self.closed = True
        if dpg.does_item_exist(self.window):
            dpg.delete_item(self.window)
        self._on_close(self)

    def _buttons(self, ok_label: str, on_ok: Callable[[], object]) -> None:
        dpg.add_spacer(height=4, parent=self.window)
        with dpg.group(horizontal=True, parent=self.window):
            self.ok_button = dpg.add_button(label=ok_label, width=100, callback=lambda *_: on_ok())
            dpg.add_button(label="Cancel", width=100, callback=lambda *_: self.close())


class MessageDialog(Dialog):
    """Shows a message (e.g. why a file could not be opened) with an OK button."""

    def __init__(self, title: str, message: str, on_close: Callable[[Dialog], None]) -> None:
        super().__init__(title, 560, on_close)
        self.message = message
        dpg.add_text(message, parent=self.window, wrap=530)
        dpg.add_spacer(height=4, parent=self.window)
        dpg.add_button(label="OK", width=100, parent=self.window, callback=lambda *_: self.close())


class RenameDialog(Dialog):
    """Edit a widget's title."""

    def __init__(self, item: CanvasItem, on_close: Callable[[Dialog], None]) -> None:
        super().__init__(f"Rename \u2014 {item.name}", 380, on_close)
        self.item = item
        self.input = dpg.add_input_text(
            default_value=item.name,
            width=-1,
            parent=self.window,
            on_enter=True,
            callback=lambda *_: self.apply(),
        )
        self.error = dpg.add_text("", color=ERROR_COLOR, parent=self.window)
        self._buttons("Rename", self.apply)

    def apply(self, name: str | None = None) -> bool:
        """Rename the widget (a blank name is refused)."""
        text = (name if name is not None else str(dpg.get_value(self.input))).strip()
        if not text:
            dpg.set_value(self.error, "The name cannot be empty.")
            return False
        self.item.rename(text[:200])
        self.close()
        return True


class MarkerDialog(Dialog):
    """A note for a marker at a moment ("robot bumped here"): Enter or Add adds it, Esc cancels.

    Args:
        when: the moment marked, as the dialog says it (``12:03:04.512, the cursor``).
        add: adds the marker with the note typed; returns "" or why it could not.
        on_close: the dialogs' close callback.
    """

    def __init__(self, when: str, add: Callable[[str], str], on_close: Callable[[Dialog], None]) -> None:
        super().__init__("Add a marker", 460, on_close)
        self._add = add
        dpg.add_text(f"A note at {when}", color=DIM, parent=self.window)
        self.input = dpg.add_input_text(
            width=-1,
            hint="e.g. robot bumped here",
            parent=self.window,
            on_enter=True,
            callback=lambda *_: self.apply(),
        )
        self.error = dpg.add_text("", color=ERROR_COLOR, parent=self.window, wrap=430)
        self._buttons("Add", self.apply)
        self.focus_soon(self.input)

    def apply(self, note: str | None = None) -> bool:
        """Add the marker with the note (typed, or `note`); a blank note is refused."""
        text = (note if note is not None else str(dpg.get_value(self.input))).strip()
        if not text:
            dpg.set_value(self.error, "Type a note: what happened here?")
            return False
        problem = self._add(text)
        if problem:
            dpg.set_value(self.error, problem)
            return False
        self.close()
        return True


def file_name(text: str, extension: str) -> str:
    """Return the file name to save as for what was typed: `extension` (``.json``, ``.mcap``) added once.

    Raises:
        ValueError: the name is blank, or names a folder rather than a file.
    """
    name = text.strip()
    if not name:
        raise ValueError(f"type a file name, e.g. name{extension}")
    if name.endswith(("/", os.sep)) or Path(name).name in (".", ".."):
        raise ValueError(f"{name!r} is a folder: add a file name")
    return name if name.lower().endswith(extension.lower()) else name + extension


def dashboard_file_name(text: str) -> str:
    """Return the file name to save a dashboard as for what was typed: ``.json`` added once.

    Raises:
        ValueError: the name is blank, or names a folder rather than a file.
    """
    return file_name(text, ".json")


class SaveAsDialog(Dialog):
    """Save the dashboard under a new name: the name field has the keyboard, Enter saves, Esc cancels.

    The same dialog saves other files (a recording, a CSV export) and opens one (`opening`): a name field
    that starts filled in, the folder's entries of that kind, the extension added once.

    Args:
        folder: where the file goes unless the name says otherwise (the dashboard's folder).
        name: the name the field starts with (the dashboard's file name, or ``dashboard.json``).
        on_save: called with the chosen path; the caller saves and closes the dialog.
        on_close: called whenever the dialog closes, as for every `Dialog`.
        title: the dialog's title.
        extension: the files listed and the extension added to a typed name that lacks it.
        action: the main button's label.
        opening: open an existing file (or folder) instead: nothing is replaced, the path must exist.
    """

    def __init__(
        self,
        folder: Path,
        name: str,
        on_save: Callable[[Path], object],
        on_close: Callable[[Dialog], None],
        *,
        title: str = "Save dashboard as",
        extension: str = ".json",
        action: str = "Save",
        opening: bool = False,
    ) -> None:
        super().__init__(title, 560, on_close)
        self.folder = folder
        self.extension = extension
        self.action = action
        self.opening = opening
        self._on_save = on_save
        self._replace: Path | None = None
        w = self.window
        hint = "File name" if opening else f"File name ({extension} is added if missing)"
        dpg.add_text(hint, color=DIM, parent=w)
        self.name_input = dpg.add_input_text(
            default_value=name,
            width=-1,
            parent=w,
            on_enter=True,
            auto_select_all=True,
            callback=lambda *_: self.apply(),
        )
        self.folder_text = dpg.add_text("", color=DIM, parent=w, wrap=530)
        self.entries = dpg.add_child_window(height=150, width=-1, parent=w)
        self.options = dpg.add_group(parent=w, show=False)
        """Where a caller adds its own choices (shown once it has some: `show_options`)."""
        self.error = dpg.add_text("", color=ERROR_COLOR, parent=w, wrap=530)
        dpg.add_spacer(height=4, parent=w)
        with dpg.group(horizontal=True, parent=w):
            self.save_button = dpg.add_button(label=action, width=100, callback=lambda *_: self.apply())
            self.cancel_button = dpg.add_button(label="Cancel", width=100, callback=lambda *_: self.close())
        self._list_folder()
        self.focus_soon(self.name_input)

    def _list_folder(self) -> None:
        dpg.set_value(self.folder_text, f"in {self.folder}")
        dpg.delete_item(self.entries, children_only=True)
        try:
            found = sorted(os.scandir(self.folder), key=lambda e: e.name.lower())
        except OSError as exc:
            dpg.set_value(self.error, f"cannot list {self.folder}: {exc.strerror or exc}")
            return
        dirs = [e.name + "/" for e in found if e.is_dir() and not e.name.startswith(".")]
        files = [e.name for e in found if e.is_file() and e.name.lower().endswith(self.extension.lower())]
        up = ["../"] if self.folder.parent != self.folder else []
        for entry in up + dirs + files:
            dpg.add_selectable(
                label=entry, parent=self.entries, callback=lambda *_, e=entry: self._on_entry(e)
            )

    def _on_entry(self, entry: str) -> None:
        if entry.endswith("/"):
            self.folder = (self.folder / entry[:-1]).resolve()
            self._list_folder()
        else:
            dpg.set_value(self.name_input, entry)
        dpg.focus_item(self.name_input)

    def target(self) -> Path:
        """The path the typed name stands for (relative names are inside the shown folder).

        Raises:
            ValueError: the name is blank or names a folder.
        """
        typed = str(dpg.get_value(self.name_input))
        if self.opening and typed.strip() and (self.folder / Path(typed.strip()).expanduser()).exists():
            return (self.folder / Path(typed.strip()).expanduser()).absolute()  # as typed: a file or folder
        return (self.folder / Path(file_name(typed, self.extension)).expanduser()).absolute()

    def show_options(self) -> int | str:
        """Show the options group (between the folder's entries and the buttons) and return it."""
        dpg.configure_item(self.options, show=True)
        group: int | str = self.options
        return group

    def set_note(self, text: str, *, error: bool = True) -> None:
        """Show `text` above the buttons: an error (red), or how the work goes (dim)."""
        dpg.set_value(self.error, text)
        dpg.configure_item(self.error, color=ERROR_COLOR if error else DIM)

    def apply(self) -> bool:
        """Save as the typed name; an existing file is replaced only when Save is pressed a second time."""
        try:
            path = self.target()
        except ValueError as exc:
            self.set_note(str(exc))
            return False
        if self.opening:
            if not path.exists():
                self.set_note(f"no such file: {path}")
                return False
            self._on_save(path)
            return True
        if not path.parent.is_dir():
            self.set_note(f"no such folder: {path.parent}")
            return False
        if path.is_dir():
            self.set_note(f"{path} is a folder: type a file name")
            return False
        if path.exists() and path != self._replace:
            self._replace = path
            self.set_note(f"{path.name} already exists: {self.action} (or Enter) again to replace it.")
            dpg.focus_item(self.name_input)
            return False
        self._on_save(path)
        return True


class PropertiesDialog(Dialog):
    """An editor per declared property (number, text, bool, colour, choice), validated on OK."""

    def __init__(self, item: CanvasItem, on_close: Callable[[Dialog], None]) -> None:
        super().__init__(f"Properties \u2014 {item.name}", 440, on_close)
        self.item = item
        self.editors: dict[str, int | str] = {}
        self.errors: dict[str, int | str] = {}
        cls = item.widget_cls
        props = dict(item.config.properties) if hasattr(item.config, "properties") else {}
        self.name_input = dpg.add_input_text(
            label="Name", default_value=item.name, width=240, parent=self.window
        )
        own = item.config.stale_after if isinstance(item.config, WidgetConfig) else None
        self.stale_input = dpg.add_input_text(
            label="Stale after (s)",
            default_value="" if own is None else f"{own:g}",
            hint="viewer default",
            width=240,
            parent=self.window,
        )
        with dpg.tooltip(self.stale_input):
            dpg.add_text(
                "Seconds without a message before this widget shows 'stale'.\n"
                "Blank: the viewer's --stale-after. Give event topics (hits, button presses) more."
            )
        self.stale_error = dpg.add_text("", color=ERROR_COLOR, parent=self.window, show=False)
        dpg.add_separator(parent=self.window)
        for decl in cls.properties if cls is not None else ():
            value = props.get(decl.name, decl.default)
            if decl.kind is PropKind.NUMBER:
                editor = dpg.add_input_double(
                    label=decl.title,
                    default_value=float(value),
                    width=240,
                    format="%.0f" if decl.integer else "%.6g",
                    parent=self.window,
                )
            elif decl.kind is PropKind.BOOL:
                editor = dpg.add_checkbox(label=decl.title, default_value=bool(value), parent=self.window)
            elif decl.kind is PropKind.CHOICE:
                editor = dpg.add_combo(
                    list(decl.choices),
                    label=decl.title,
                    default_value=str(value),
                    width=240,
                    parent=self.window,
                )
            elif decl.kind is PropKind.COLOR:
                editor = dpg.add_color_edit(
                    list(parse_color(str(value))),
                    label=decl.title,
                    width=240,
                    alpha_bar=True,
                    parent=self.window,
                )
            else:
                editor = dpg.add_input_text(
                    label=decl.title, default_value=str(value), width=240, parent=self.window
                )
            if decl.help:
                with dpg.tooltip(editor):
                    dpg.add_text(decl.help)
            self.editors[decl.name] = editor
            self.errors[decl.name] = dpg.add_text("", color=ERROR_COLOR, parent=self.window, show=False)
        self._buttons("Apply", self.apply)

    def set_value(self, name: str, value: object) -> None:
        """Put a value into an editor as a user would type it (for tests and scripting)."""
        editor = self.editors[name]
        if isinstance(value, str) and value.startswith("#") and self._decl(name).kind is PropKind.COLOR:
            dpg.set_value(editor, list(parse_color(value)))
        else:
            dpg.set_value(editor, value)

    def _decl(self, name: str):  # type: ignore[no-untyped-def]
        cls = self.item.widget_cls
        assert cls is not None
        decl = cls.property_named(name)
        assert decl is not None
        return decl

    def apply(self) -> bool:
        """Validate every editor; on success apply and close, else show each problem beside its editor."""
        cls = self.item.widget_cls
        values: dict[str, PropValue] = {}
        ok = True
        for decl in cls.properties if cls is not None else ():
            raw = dpg.get_value(self.editors[decl.name])
            if decl.kind is PropKind.COLOR:
                raw = format_color(
                    [c * 255 if isinstance(c, float) and c <= 1.0 and _is_unit(raw) else c for c in raw]
                )
            try:
                values[decl.name] = decl.validate(raw)
                dpg.configure_item(self.errors[decl.name], show=False)
            except PropertyError as exc:
                ok = False
                dpg.set_value(self.errors[decl.name], str(exc))
                dpg.configure_item(self.errors[decl.name], show=True)
        stale_after: float | None = None
        stale_text = str(dpg.get_value(self.stale_input)).strip()
        if stale_text:
            try:
                stale_after = check_stale_after(float(stale_text))
                dpg.configure_item(self.stale_error, show=False)
            except ValueError as exc:
                ok = False
                detail = (
                    str(exc) if "seconds" in str(exc) else f"must be a number of seconds, got {stale_text!r}"
                )
                dpg.set_value(self.stale_error, f"Stale after {detail}")
                dpg.configure_item(self.stale_error, show=True)
        name = str(dpg.get_value(self.name_input)).strip()
        if not ok:
            return False
        if name and name != self.item.name:
            self.item.rename(name[:200])
        self.item.set_stale_after(stale_after)
        self.item.set_properties(values)
        self.close()
        return True


def _is_unit(raw: list[float]) -> bool:
    return all(isinstance(c, float) and 0.0 <= c <= 1.0 for c in raw)


def topic_suggestions(topics: list[TopicInfo], typed: str) -> list[str]:
    """The suggestion lines for `typed`: topics whose name or tag as shown (``速度``, ``robot1:speed``)
    holds it, prefix matches first; a tag whose text differs from its topic name shows the text too."""
    typed = typed.strip().lower()

    def names(t: TopicInfo) -> tuple[str, str]:
        return t.name.lower(), (t.tag or "").lower()

    prefix = [t for t in topics if any(n.startswith(typed) for n in names(t))]
    inner = [t for t in topics if any(typed in n for n in names(t)) and t not in prefix]
    lines = []
    for t in prefix + inner:
        tag = t.tag_name
        shown = f"   {t.tag}" if tag is not None and (tag.robot or tag.text != tag.tag) else ""
        lines.append(f"{t.name}   [{', '.join(t.types)}]{shown}")
    return lines


def typed_topic(text: str) -> str:
    """The topic typed in the Topic field: a robot's tag as tools show it (``robot1:speed``) is its topic;
    anything else is taken as typed."""
    try:
        name = robot_target(text.strip())
    except TagError:
        name = None
    return name.topic if name is not None else text.strip()


def parameter_suggestions(params: Sequence[tuple[str, ParamValue]], typed: str) -> list[str]:
    """The suggestion lines of nodes' parameters (``/pid_node:kp``) that hold `typed`, prefix matches first
    (a name typed alone, ``kp``, matches every node's): the parameter, its type and its value."""
    typed = typed.strip().lower()
    named = [(target, value) for target, value in params if typed in target.lower()]

    def rank(item: tuple[str, ParamValue]) -> tuple[int, str]:
        target = item[0].lower()
        name = target.rpartition(":")[2]
        return (0 if target.startswith(typed) or name.startswith(typed) else 1, target)

    lines = []
    for target, value in sorted(named, key=rank):
        text = value.text if len(value.text) <= 40 else value.text[:39] + "\u2026"
        lines.append(f"{target}   [parameter: {value.type.label} = {text}]")
    return lines


def typed_target(text: str, parameters: Sequence[str] | None = None) -> str:
    """The binding typed in the Topic field. For a widget that takes parameters (`parameters` lists the
    known ones, ``/pid_node:kp``): ``NODE:NAME`` is a node's parameter when that node is known (a bare
    ``pid_node`` found in any namespace) or the text starts with ``/``; anything else, and every text for
    other widgets, is `typed_topic` (``robot1:speed`` is a robot's tag)."""
    text = text.strip()
    if parameters is None or ":" not in text:
        return typed_topic(text)
    if text in parameters:
        return text
    try:
        node, name = split_name(text)
    except ValueError:
        return typed_topic(text)
    nodes = sorted({target.rpartition(":")[0] for target in parameters})
    found = resolve_node(text.rpartition(":")[0], nodes)
    if isinstance(found, str):
        return join_name(found, name)
    return join_name(node, name) if text.startswith("/") else typed_topic(text)


def robot_choices(robot: str | None, *, several: bool) -> list[tuple[str, str]]:
    """Topic setup's robot choices, (mode, label): the topic as typed, the selected robot's (named), and for
    a widget of several series every robot's."""
    now = f" (now {robot})" if robot is not None else ""
    choices = [("", "this topic as typed"), (SELECTED_ROBOT, f"the selected robot's{now}")]
    if several:
        choices.append((EVERY_ROBOT, "every robot's: one series each"))
    return choices


class TopicHost(Protocol):
    """What the Topic setup dialog reaches: the graph, a previewed series, and where its result goes."""

    def topics(self) -> list[TopicInfo]:
        """The topics of the live graph."""
        ...

    def fields(self, topic: str) -> list[FieldInfo]:
        """The fields of `topic`'s message type."""
        ...

    def snapshot(self, binding: Binding) -> SeriesSnapshot:
        """The series of a previewed binding."""
        ...

    def preview(self, binding: Binding) -> None:
        """Keep `binding` bound while its latest value is shown."""

    def end_preview(self, binding: Binding) -> None:
        """Release a previewed binding."""

    def apply(self, bindings: tuple[Binding, ...]) -> None:
        """Give the widget its new bindings."""

    def shown(self, binding: Binding) -> Binding:
        """The concrete binding to edit for `binding` (a robot-relative one: the selected robot's)."""
        ...

    def relative(self, binding: Binding, mode: str) -> Binding:
        """`binding` made to follow the selected robot or show every robot (`Binding.robot` `mode`)."""
        ...

    def robot(self) -> str | None:
        """The selected robot's name when robots have namespaces (None: there is nothing to follow)."""


class TopicDialog(Dialog):
    """Pick the topic (type-ahead from the live graph), the field (from the message type) and a regex."""

    def __init__(
        self,
        item: CanvasItem,
        setup: TopicHost,
        on_close: Callable[[Dialog], None],
        parameters: Callable[[], list[tuple[str, ParamValue]]] = list,
    ) -> None:
        super().__init__(f"Topic setup \u2014 {item.name}", 620, on_close)
        self.item = item
        self.setup = setup
        """The graph to choose from, the preview's series, and where the result goes."""
        self.params = parameters if item.widget_cls is not None and item.widget_cls.parameters else None
        """The nodes' parameters known (``/pid_node:kp`` and value), for a widget that takes parameters."""
        cls = item.widget_cls
        self.max_bindings = cls.max_bindings if cls is not None else 1
        self.accepts = cls.accepts if cls is not None else frozenset()
        self.bindings: list[Binding] = [setup.shown(b) for b in item.bindings] or [Binding("")]
        """The series being edited, concrete (a robot-relative one as the selected robot's)."""
        self.modes: list[str] = [b.robot for b in item.bindings] or [""]
        """Each series' robot: ``""`` (the topic as typed), the selected robot's, every robot's."""
        self.index = 0
        self._fields: list[FieldInfo] = []
        self._preview_binding: Binding | None = None
        self._suggestions: list[str] = []
        self._typed = ""
        """The topic field's text when last seen: a change refreshes the suggestions."""
        self.control = bool(cls is not None and cls.publishes)
        """A control publishes to its topic: no regex or transforms apply to what it sends."""
        self.preview_ok = True
        self.preview_text = ""
        w = self.window
        if self.max_bindings > 1:
            with dpg.group(horizontal=True, parent=w):
                self.series_combo = dpg.add_combo([], label="Series", width=300, callback=self._on_series)
                dpg.add_button(label="Add series", callback=lambda *_: self.add_series())
                dpg.add_button(label="Remove", callback=lambda *_: self.remove_series())
        topic_help = "Topic this control publishes to" if self.control else "Topic"
        if self.params is not None:
            topic_help += ", or a node's parameter NODE:NAME"
        dpg.add_text(
            f"{topic_help}   (Enter takes the highlighted one, \u2191/\u2193 pick another)",
            color=DIM,
            parent=w,
        )
        # Enter is the dialog's (take the suggestion, then OK); each keystroke is seen by `tick`.
        self.topic_input = dpg.add_input_text(
            width=-1,
            hint="start typing, e.g. /rosdashboard/",
            parent=w,
            on_enter=True,
            callback=lambda *_: self.enter(),
        )
        self.suggest_list = dpg.add_listbox(
            [], num_items=5, width=-1, parent=w, callback=lambda s, a: self.choose_topic(a.split("   ")[0])
        )
        robot = setup.robot()
        self.robot_choices = robot_choices(robot, several=self.max_bindings > 1 and not self.control)
        with dpg.group(horizontal=True, parent=w, show=robot is not None or any(self.modes)):
            dpg.add_text("Robot", color=DIM)
            self.robot_combo = dpg.add_combo(
                [label for _, label in self.robot_choices],
                width=-1,
                callback=lambda s, a: self.choose_robot_mode(str(a)),
            )
        dpg.add_text("Field", color=DIM, parent=w)
        self.field_combo = dpg.add_combo([], width=-1, parent=w, callback=lambda s, a: self._on_field(a))
        self.field_note = dpg.add_text("", color=DIM, parent=w, wrap=590)
        self.data_only = dpg.add_group(parent=w, show=not self.control)
        """The regex and transform sections, which only apply to widgets that show data."""
        with dpg.group(horizontal=True, parent=self.data_only, show=False) as self.log_group:
            # A Log topic's lines, as a bridge rule filters them (Binding.node, Binding.level).
            dpg.add_text("Log lines of node", color=DIM)
            self.node_input = dpg.add_input_text(
                width=220, hint="any, or a glob: planner*", callback=lambda *_: self._store()
            )
            dpg.add_text("minimum level", color=DIM)
            self.level_combo = dpg.add_combo(
                LOG_LEVEL_CHOICES, default_value="any", width=90, callback=lambda *_: self._store()
            )
        dpg.add_text(
            "Regex (optional, RE2: the first group or the whole match is used)",
            color=DIM,
            parent=self.data_only,
        )
        self.regex_input = dpg.add_input_text(
            width=-1, hint="e.g. speed=([0-9.]+)", parent=self.data_only, callback=lambda *_: self._store()
        )
        self.preview = dpg.add_text("", parent=self.data_only, wrap=590)
        self.latest = dpg.add_text("", color=DIM, parent=w, wrap=590)
        self._build_transforms(self.data_only)
        self._buttons("OK", self.apply)
        self._load_current()
        self.focus_soon(self.topic_input)

    # -- series list (plots) ------------------------------------------------------------------------

    def _series_labels(self) -> list[str]:
        return [
            f"{i + 1}: {b.topic or '(no topic)'}" + (f" \u203a {b.field}" if b.field else "")
            for i, b in enumerate(self.bindings)
        ]

    def _on_series(self, sender: int | str, label: str) -> None:
        self._store()
        self.index = self._series_labels().index(label) if label in self._series_labels() else 0
        self._load_current()

    def add_series(self) -> None:
        """Add an empty series (up to the widget's maximum) and edit it."""
        self._store()
        if len(self.bindings) < self.max_bindings:
            self.bindings.append(Binding(""))
            self.modes.append("")
            self.index = len(self.bindings) - 1
            self._load_current()

    def remove_series(self) -> None:
        """Remove the series being edited (one always stays)."""
        if len(self.bindings) > 1:
            del self.bindings[self.index]
            del self.modes[self.index]
            self.index = max(0, self.index - 1)
        else:
            self.bindings, self.modes = [Binding("")], [""]
        self._load_current()

    def _load_current(self) -> None:
        b = self.bindings[self.index]
        if self.max_bindings > 1:
            labels = self._series_labels()
            dpg.configure_item(self.series_combo, items=labels)
            dpg.set_value(self.series_combo, labels[self.index])
        dpg.set_value(self.topic_input, b.topic)
        self._typed = b.topic
        dpg.set_value(self.regex_input, b.regex)
        dpg.set_value(self.node_input, b.node)
        dpg.set_value(self.level_combo, b.level or "any")
        mode = self.modes[self.index]
        dpg.set_value(self.robot_combo, next(label for m, label in self.robot_choices if m == mode))
        self._refresh_suggestions()
        self._refresh_fields(b.field)
        self._show_transforms()

    def _known_parameters(self) -> list[tuple[str, ParamValue]]:
        """The parameters Topic setup knows (none for a widget that does not take them)."""
        return self.params() if self.params is not None else []

    def _store(self) -> None:
        known = [target for target, _ in self._known_parameters()] if self.params is not None else None
        topic = typed_target(str(dpg.get_value(self.topic_input)), known)
        field = self._selected_field()
        regex = str(dpg.get_value(self.regex_input))
        # A log binding's node and level while the topic is a Log topic (none otherwise: they would be its
        # error); replace, not a new Binding: what this dialog does not edit (transforms) stays as it was.
        log = self._is_log_topic(topic)
        node = str(dpg.get_value(self.node_input)).strip() if log else ""
        level = str(dpg.get_value(self.level_combo)) if log else ""
        self.bindings[self.index] = replace(
            self.bindings[self.index],
            topic=topic,
            field=field,
            regex=regex,
            node=node,
            level="" if level == "any" else level,
        )
        if self.max_bindings > 1:
            labels = self._series_labels()
            dpg.configure_item(self.series_combo, items=labels)
            dpg.set_value(self.series_combo, labels[self.index])

    # -- topic and field ----------------------------------------------------------------------------

    def choose_robot_mode(self, label: str) -> None:
        """The series follows the selected robot, shows every robot, or keeps the topic as typed."""
        mode = next((m for m, text in self.robot_choices if text == label), "")
        self.modes[self.index] = mode

    def _on_topic_typed(self) -> None:
        self._refresh_suggestions()
        self._refresh_fields("")
        self._store()

    def suggestions(self) -> list[str]:
        """Return the topics on the graph matching what is typed (prefix matches first), and for a widget
        that takes parameters the nodes' parameters (first when the text has a colon)."""
        typed = str(dpg.get_value(self.topic_input))
        lines = topic_suggestions(self.setup.topics(), typed)
        if self.params is None:
            return lines
        params = parameter_suggestions(self._known_parameters(), typed)
        return params + lines if ":" in typed else lines + params

    def _refresh_suggestions(self) -> None:
        self._suggestions = self.suggestions()
        dpg.configure_item(self.suggest_list, items=self._suggestions)
        self.highlight(0)

    def highlighted(self) -> str | None:
        """The topic Enter would take (the highlighted suggestion), or None when nothing matches."""
        label = str(dpg.get_value(self.suggest_list) or "")
        return label.split("   ")[0] if label in self._suggestions else None

    def highlight(self, index: int) -> None:
        """Highlight suggestion `index` (kept within the list)."""
        if self._suggestions:
            index = max(0, min(len(self._suggestions) - 1, index))
            dpg.set_value(self.suggest_list, self._suggestions[index])

    def move_highlight(self, step: int) -> None:
        """Highlight the next (+1) or previous (-1) suggestion, as the arrow keys do."""
        current = str(dpg.get_value(self.suggest_list) or "")
        index = self._suggestions.index(current) if current in self._suggestions else -step
        self.highlight(index + step)

    def enter(self) -> None:
        """Enter in the topic field: take the highlighted suggestion; once a known topic is there, OK."""
        typed = str(dpg.get_value(self.topic_input)).strip()
        known = {t.name for t in self.setup.topics()} | {p for p, _ in self._known_parameters()}
        choice = self.highlighted()
        if typed in known or choice is None:
            self.apply()  # a topic not on the graph yet (its node not started) is taken as typed
            return
        self.choose_topic(choice)
        self.focus_soon(self.topic_input)

    def choose_topic(self, topic: str) -> None:
        """Take a topic (as clicking a suggestion does) and list its fields."""
        dpg.set_value(self.topic_input, topic.strip())
        self._typed = topic.strip()
        self._refresh_suggestions()
        self._refresh_fields("")
        self._store()

    def _field_label(self, f: FieldInfo) -> str:
        depth = f.path.count(".")
        mark = "" if f.numeric or ValueKind.TEXT in self.accepts else "   (not numeric)"
        return f"{'    ' * depth}{f.path}   : {f.type_name}{mark}"

    def _is_log_topic(self, topic: str) -> bool:
        """Whether `topic` carries Log lines (says the graph; off the graph: the binding filters lines)."""
        name = topic if topic.startswith("/") else "/" + topic
        for info in self.setup.topics():
            if info.name == name:
                return LOG_MSG_TYPE in info.types
        b = self.bindings[self.index]
        return bool(b.node or b.level) and b.topic == topic

    def _refresh_fields(self, selected: str) -> None:
        topic = str(dpg.get_value(self.topic_input)).strip()
        known = [target for target, _ in self._known_parameters()]
        if self.params is not None and Binding(typed_target(topic, known)).parameter is not None:
            dpg.configure_item(self.field_combo, items=[])
            dpg.set_value(self.field_combo, "")
            dpg.set_value(self.field_note, "A node's parameter: the widget shows its value and sets it.")
            self._fields = []
            return
        dpg.configure_item(self.log_group, show=self._is_log_topic(topic))
        self._fields = self.setup.fields(topic) if topic else []
        labels = ["(whole message)"] + [self._field_label(f) for f in self._fields]
        dpg.configure_item(self.field_combo, items=labels)
        current = next((self._field_label(f) for f in self._fields if f.path == selected), None)
        if current is None and selected:
            labels.append(selected)
            dpg.configure_item(self.field_combo, items=labels)
            current = selected
        dpg.set_value(self.field_combo, current or "(whole message)")
        if topic and not self._fields:
            dpg.set_value(self.field_note, "The topic's message type is not known yet (not on the graph?).")
        else:
            dpg.set_value(self.field_note, "")

    def _selected_field(self) -> str:
        label = str(dpg.get_value(self.field_combo) or "")
        if label in ("", "(whole message)"):
            return ""
        for f in self._fields:
            if self._field_label(f) == label:
                return f.path
        return label.strip()

    def choose_field(self, path: str) -> None:
        """Select a field by path (as picking it in the list does)."""
        self._refresh_fields(path)
        self._store()

    def _on_field(self, label: str) -> None:
        self._store()

    def set_regex(self, pattern: str) -> None:
        """Type a regex (as the user would)."""
        dpg.set_value(self.regex_input, pattern)
        self._store()

    # -- transforms ---------------------------------------------------------------------------------

    def _build_transforms(self, w: int | str) -> None:
        dpg.add_text("Transforms (applied in order; see docs/transforms.md)", color=DIM, parent=w)
        self.xf_list = dpg.add_group(parent=w)
        with dpg.group(horizontal=True, parent=w):
            self.xf_kind = dpg.add_combo(
                [label for label, _, _ in TRANSFORM_KINDS.values()],
                default_value=TRANSFORM_KINDS["rad2deg"][0],
                width=190,
                callback=lambda *_: self._on_kind(),
            )
            self.xf_a = dpg.add_input_double(width=110, show=False, format="%.6g")
            self.xf_b = dpg.add_input_double(width=110, show=False, format="%.6g")
            self.xf_add = dpg.add_button(label="Add", width=60, callback=lambda *_: self.add_transform())
        self.xf_expr = dpg.add_input_text(
            width=-1,
            hint="formula, e.g. x * 57.2958 or sqrt(linear.x**2 + linear.y**2)",
            parent=w,
            show=False,
            callback=lambda *_: self._check_formula(),
        )
        self.xf_note = dpg.add_text("", parent=w, wrap=590)
        self.formula_ok = True
        self.formula_text = ""

    def _kind(self) -> str:
        label = str(dpg.get_value(self.xf_kind))
        return next((k for k, (lab, _, _) in TRANSFORM_KINDS.items() if lab == label), "rad2deg")

    def choose_transform_kind(self, kind: str) -> None:
        """Select a transform kind in the Add row (as picking it in the list does)."""
        dpg.set_value(self.xf_kind, TRANSFORM_KINDS[kind][0])
        self._on_kind()

    def _on_kind(self) -> None:
        kind = self._kind()
        _, a, b = TRANSFORM_KINDS[kind]
        for editor, name in ((self.xf_a, a), (self.xf_b, b)):
            dpg.configure_item(editor, show=bool(name), label=name)
            if name:
                dpg.set_value(editor, _PARAM_DEFAULTS[name])
        dpg.configure_item(self.xf_expr, show=kind == "formula")
        if kind == "formula":
            self._check_formula()
        else:
            dpg.set_value(self.xf_note, "")

    def set_formula(self, text: str) -> tuple[bool, str]:
        """Type a formula into the Add row (as the user would) and return its live check."""
        self.choose_transform_kind("formula")
        dpg.set_value(self.xf_expr, text)
        return self._check_formula()

    def _check_formula(self) -> tuple[bool, str]:
        ok, text = formula_check(str(dpg.get_value(self.xf_expr)))
        self.formula_ok, self.formula_text = ok, text
        dpg.set_value(self.xf_note, text)
        dpg.configure_item(self.xf_note, color=OK_COLOR if ok else ERROR_COLOR)
        return ok, text

    def transforms(self) -> list[dict[str, object]]:
        """Return the transforms of the series being edited, in their file form."""
        written = written_transforms(self.bindings[self.index].transforms)
        return written if isinstance(written, list) else []

    def add_transform(self) -> bool:
        """Add the transform set up in the Add row to the series being edited; False (and why) if invalid."""
        kind = self._kind()
        _, a, b = TRANSFORM_KINDS[kind]
        item: dict[str, object] = {"kind": kind}
        if kind == "formula":
            item["expr"] = str(dpg.get_value(self.xf_expr))
        for editor, name in ((self.xf_a, a), (self.xf_b, b)):
            if name:
                value = float(dpg.get_value(editor))
                item[name] = int(value) if name == "window" and value.is_integer() else value
        items = [*self.transforms(), item]
        try:
            checked = transforms_from_json(items)
        except TransformError as exc:
            dpg.set_value(self.xf_note, str(exc))
            dpg.configure_item(self.xf_note, color=ERROR_COLOR)
            return False
        self._set_transforms([t.to_json() for t in checked])
        dpg.set_value(self.xf_note, f"added: {checked[-1].describe()}")
        dpg.configure_item(self.xf_note, color=OK_COLOR)
        return True

    def remove_transform(self, index: int) -> None:
        """Remove the transform at `index` from the series being edited."""
        items = self.transforms()
        if 0 <= index < len(items):
            del items[index]
            self._set_transforms(items)

    def _set_transforms(self, items: list[dict[str, object]]) -> None:
        b = self.bindings[self.index]
        self.bindings[self.index] = replace(b, transforms=transforms_or_invalid(items))
        self._show_transforms()

    def _show_transforms(self) -> None:
        dpg.delete_item(self.xf_list, children_only=True)
        shown = self.bindings[self.index].transforms
        rejected = next((t for t in shown if isinstance(t, Invalid)), None)
        if rejected is not None:
            dpg.add_text(rejected.describe(), parent=self.xf_list, color=ERROR_COLOR, wrap=590)
            return
        if not shown:
            dpg.add_text("none: the value is shown as it arrives", parent=self.xf_list, color=DIM)
        for i, t in enumerate(shown):
            with dpg.group(horizontal=True, parent=self.xf_list):
                dpg.add_button(label="x", width=24, callback=lambda *_, k=i: self.remove_transform(k))
                dpg.add_text(f"{i + 1}. {t.describe()}")

    # -- live preview -------------------------------------------------------------------------------

    def tick(self) -> None:
        """Follow the typing; keep the edited topic/field's preview series bound; show the regex result."""
        super().tick()
        typed = str(dpg.get_value(self.topic_input))
        if typed != self._typed:
            self._typed = typed
            self._on_topic_typed()
        b = self.bindings[self.index]
        want = Binding(b.topic, b.field) if b.topic and b.parameter is None else None
        if want != self._preview_binding:
            if self._preview_binding is not None:
                self.setup.end_preview(self._preview_binding)
            if want is not None:
                self.setup.preview(want)
            self._preview_binding = want
        latest: str | None = None
        if b.parameter is not None:
            value = dict(self._known_parameters()).get(b.topic)
            dpg.set_value(
                self.latest,
                f"value now: {value.text}   ({value.type.label})"
                if value is not None
                else "the node's value is not known yet (not on the graph?)",
            )
        elif want is not None:
            snap = self.setup.snapshot(want)
            if snap.last is not None:
                latest = str(snap.last)
                dpg.set_value(self.latest, f"latest value: {latest[:200]!r}   ({snap.status.value})")
            else:
                dpg.set_value(
                    self.latest,
                    f"no value yet ({snap.status.value}{': ' + snap.reason if snap.reason else ''})",
                )
        else:
            dpg.set_value(self.latest, "")
        ok, text = regex_preview(b.regex, latest)
        dpg.set_value(self.preview, text)
        dpg.configure_item(self.preview, color=OK_COLOR if ok else ERROR_COLOR)
        self.preview_text = text
        self.preview_ok = ok

    def apply(self) -> bool:
        """Check the regexes compile, then give the bindings to the widget and close."""
        self._store()
        modes = [m for b, m in zip(self.bindings, self.modes, strict=True) if b.topic]
        bindings = tuple(b for b in self.bindings if b.topic)
        for b in bindings:
            if b.regex:
                try:
                    compile_regex(b.regex)
                except RegexError as exc:
                    dpg.set_value(self.preview, f"regex error: {exc}")
                    dpg.configure_item(self.preview, color=ERROR_COLOR)
                    return False
        bindings = tuple(
            replace(b, topic=b.topic if b.topic.startswith("/") else "/" + b.topic) for b in bindings
        )
        bindings = tuple(
            self.setup.relative(b, mode) if mode else replace(b, robot="")
            for b, mode in zip(bindings, modes, strict=True)
        )
        self.setup.apply(bindings)
        self.close()
        return True

    def close(self) -> None:
        """Drop the preview series and remove the dialog."""
        if self._preview_binding is not None:
            self.setup.end_preview(self._preview_binding)
            self._preview_binding = None
        super().close()
