"""The widget API: what a viewer widget declares and implements, for built-ins and plugins alike.

A widget is a class registered under the entry-point group ``dbglog.widgets``. It declares a type name,
a toolbox label, the value kinds it accepts and its properties; it implements ``create`` (build its Dear
PyGui items inside a parent the viewer gives it), ``update`` (draw new snapshots) and optionally
``resize``. The viewer draws the frame around it: title strip, status pill, move and resize handles,
context menu, topic setup and properties dialogs, saving and loading.

Example::

    import dearpygui.dearpygui as dpg
    from dbglog.viewer.widget_api import Property, PropKind, ValueKind, Widget

    class Big(Widget):
        type_name = "big"
        label = "Big number"
        accepts = frozenset({ValueKind.NUMBER})
        properties = (Property("decimals", PropKind.NUMBER, 2, minimum=0, maximum=9),)

        def create(self, parent, width, height):
            self.text = dpg.add_text("-", parent=parent)

        def update(self, snapshots, now):
            last = snapshots[0].last
            if isinstance(last, (int, float)):
                dpg.set_value(self.text, f"{last:.{int(self.prop('decimals'))}f}")

Only the viewer's UI thread calls these methods; a widget must not start threads that call Dear PyGui.
At mount the viewer hands each widget a `WidgetContext` (``self.context``): the publish targets of a
control's bindings (and the node parameters a widget that declares `Widget.parameters` is bound to), the
app's publishing service (``self.publisher()``), its other services (`WidgetHost`: log lines, the time
cursor, node parameters, the events on the timeline) and the time range the time plots share
(`TimeRange`); the app owns them.
Everything a plugin needs is importable from this module (the data types `SeriesSnapshot`, `ValueKind`,
`Status` and `Binding` are re-exported here); the ``_``-prefixed modules are private. The full reference
and a step-by-step tutorial are in ``docs/plugins.md``.
"""

from __future__ import annotations

import abc
import enum
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import ClassVar, Protocol

import numpy as np

from dbglog._regex._propose import capture_name
from dbglog._ros._params import ParamRange, ParamType, ParamValue
from dbglog._ros._tags import tag_of
from dbglog.viewer._data._interfaces import (
    InterfaceError,
    fill_message,
    form_fields,
    installed_types,
    message_type,
)
from dbglog.viewer._data._logstore import (
    LEVEL_NAMES,
    FilterError,
    LogFilter,
    LogLine,
    LogReader,
    LogStore,
    Shown,
    level_name,
    level_of,
)
from dbglog.viewer._data._model import Binding, SeriesSnapshot, Status, ValueKind
from dbglog.viewer._publishing._params import ParamState
from dbglog.viewer._publishing._requests import DEFAULT_RATE_LIMIT_HZ, PublishRequest, PublishState, Value

__all__ = [
    "DEFAULT_RATE_LIMIT_HZ",
    "LEVEL_NAMES",
    "Binding",
    "Color",
    "EventMark",
    "FilterError",
    "InterfaceError",
    "LogFilter",
    "LogLine",
    "LogReader",
    "LogStore",
    "ParamRange",
    "ParamState",
    "ParamType",
    "ParamValue",
    "PropKind",
    "PropValue",
    "Property",
    "PropertyError",
    "PublishRequest",
    "PublishService",
    "PublishState",
    "SeriesSnapshot",
    "Shown",
    "Status",
    "TimeRange",
    "Value",
    "ValueKind",
    "Widget",
    "WidgetContext",
    "WidgetHost",
    "capture_name",
    "fill_message",
    "form_fields",
    "format_color",
    "installed_types",
    "kind_problem",
    "level_name",
    "level_of",
    "message_type",
    "parse_color",
    "shown_as",
    "tag_of",
]

PropValue = float | str | bool
"""A property value as stored in a dashboard file: numbers are floats, colours are ``#rrggbb[aa]``."""

Color = tuple[int, int, int, int]
"""An RGBA colour, each channel 0-255, as Dear PyGui takes it."""


class PropertyError(ValueError):
    """A property value that its declaration rejects; the message says which property and why."""


class PropKind(enum.StrEnum):
    """The kinds of property a widget can declare; each gets its own editor in the properties dialog."""

    NUMBER = "number"
    TEXT = "text"
    BOOL = "bool"
    COLOR = "color"
    CHOICE = "choice"


_HEX = re.compile(r"#(?:[0-9a-fA-F]{6}|[0-9a-fA-F]{8})")


def parse_color(text: str) -> Color:
    """Turn ``#rrggbb`` or ``#rrggbbaa`` into an RGBA tuple.

    Raises:
        PropertyError: the text is not such a colour.
    """
    if not isinstance(text, str) or not _HEX.fullmatch(text):
        raise PropertyError(f"not a colour {text!r}: use #rrggbb or #rrggbbaa")
    digits = text[1:]
    channels = [int(digits[i : i + 2], 16) for i in range(0, len(digits), 2)]
    if len(channels) == 3:
        channels.append(255)
    return (channels[0], channels[1], channels[2], channels[3])


def format_color(color: Sequence[float]) -> str:
    """Turn RGB(A) channels 0-255 into ``#rrggbbaa`` (the inverse of `parse_color`)."""
    parts = [max(0, min(255, round(float(c)))) for c in list(color)[:4]]
    while len(parts) < 4:
        parts.append(255)
    return "#" + "".join(f"{p:02x}" for p in parts)


@dataclass(frozen=True, slots=True)
class Property:
    """One setting of a widget, shown in its properties dialog and saved in dashboards.

    Args:
        name: key in the dashboard file (``[a-z_][a-z0-9_]*``).
        kind: which editor and which validation.
        default: the value a new widget starts with.
        label: shown in the dialog (defaults to the name).
        minimum / maximum: bounds for numbers (inclusive).
        choices: the allowed values of a CHOICE.
        integer: a NUMBER that must be a whole number.
    """

    name: str
    kind: PropKind
    default: PropValue
    label: str = ""
    minimum: float | None = None
    maximum: float | None = None
    choices: tuple[str, ...] = ()
    integer: bool = False
    help: str = ""

    @property
    def title(self) -> str:
        """The label shown in the properties dialog."""
        return self.label or self.name.replace("_", " ").capitalize()

    def validate(self, value: object) -> PropValue:
        """Return `value` normalised for this property.

        Raises:
            PropertyError: the value has the wrong type or is out of range; the message names the property.
        """
        try:
            return self._validate(value)
        except PropertyError as exc:
            raise PropertyError(f"property {self.name!r}: {exc}") from None

    def _validate(self, value: object) -> PropValue:
        if self.kind is PropKind.NUMBER:
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise PropertyError(f"expected a number, got {_describe(value)}")
            number = float(value)
            if not math.isfinite(number):
                raise PropertyError(f"expected a finite number, got {value!r}")
            if self.integer and not number.is_integer():
                raise PropertyError(f"expected a whole number, got {value!r}")
            if self.minimum is not None and number < self.minimum:
                raise PropertyError(f"{value!r} is below the minimum {self.minimum:g}")
            if self.maximum is not None and number > self.maximum:
                raise PropertyError(f"{value!r} is above the maximum {self.maximum:g}")
            return number
        if self.kind is PropKind.BOOL:
            if not isinstance(value, bool):
                raise PropertyError(f"expected true or false, got {_describe(value)}")
            return value
        if not isinstance(value, str):
            raise PropertyError(f"expected a string, got {_describe(value)}")
        if self.kind is PropKind.COLOR:
            parse_color(value)
            return value.lower()
        if self.kind is PropKind.CHOICE and value not in self.choices:
            raise PropertyError(f"{value!r} is not one of {', '.join(self.choices)}")
        if len(value) > 1000:
            raise PropertyError("text longer than 1000 characters")
        return value


def _describe(value: object) -> str:
    text = repr(value)
    return f"{type(value).__name__} {text[:40]}"


class PublishService(Protocol):
    """What a widget may ask of the app's publishing service (the viewer's own implementation runs a node).

    Widgets reach it through `Widget.publisher`; they never construct one.
    """

    def update(
        self,
        key: object,
        request: PublishRequest,
        *,
        send: bool,
        rate_limit_hz: float = DEFAULT_RATE_LIMIT_HZ,
        repeat_hz: float = 0.0,
    ) -> None:
        """Set what control `key` publishes; with `send`, queue one message (rate limited). Never blocks."""

    def state(self, key: object) -> PublishState:
        """Return the state of control `key`, for its status pill."""

    def release(self, key: object) -> None:
        """Forget control `key`."""


@dataclass(frozen=True, slots=True)
class EventMark:
    """An event on the timeline, as a widget draws it: a parameter change (``pid_node.kp 1.25 → 2.5``) or a
    user's marker (its note)."""

    time: float
    """Source time, epoch seconds (the time axis of every series)."""
    kind: str
    """``changed``, ``deleted``, ``declared`` or ``marker``."""
    label: str
    """One line: ``pid_node.kp 1.25 → 2.5``, ``pid_node.kp deleted (was 1.25)``, a marker's note."""
    subject: str = ""
    """A change's parameter, ``pid_node.kp`` (the node without its leading ``/``); "" for a marker."""
    old: str = ""
    """A change's old value as text (``?`` when unknown)."""
    new: str = ""
    """A change's new value as text."""


class WidgetHost(Protocol):
    """What the viewer offers a widget besides its series: log lines, the time cursor, "plot this number",
    node parameters and the events on the timeline.

    Widgets reach it as ``self.context.host`` (None outside a viewer); every method is for the UI thread.
    """

    def log_store(self, topic: str) -> LogStore | None:
        """Return the store of every line of a log topic (``rcl_interfaces/msg/Log`` or a String topic), fed
        live and already holding what the viewer's history has; None when the data source keeps none.

        A console asks its filter through `LogStore.reader` and takes the answers with `LogStore.step`.
        """

    def seek(self, t: float) -> None:
        """Move the dashboard's time cursor to source time `t` (pausing), as a click on the timeline does."""

    def envelope(
        self, binding: Binding, t0: float, t1: float, pixels: int
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """Return a min/max envelope (times, values) of `binding`'s numbers over ``[t0, t1]`` from the
        viewer's history, up to the time cursor, at most about two points per pixel column of `pixels`:
        what a plot zoomed out past the samples of its snapshot draws. None when the history holds none.
        """

    def plot_number(self, topic: str, line_id: int, number: int) -> None:
        """Open "Plot this number" for number `number` (0-based) of stored line `line_id` of `topic`."""

    def parameter(self, target: str) -> ParamState:
        """Return what a widget bound to a node's parameter (``/pid_node:kp``) shows now: its value (live, or
        as it was at the time cursor), its descriptor, whether it may be set, its status and note. The first
        call asks the node; nothing waits on it. Cheap: a widget may ask every frame."""

    def set_parameter(
        self, target: str, value: object, *, final: bool, rate_hz: float = DEFAULT_RATE_LIMIT_HZ
    ) -> None:
        """Set a node's parameter to `value` (made its type, on its range's grid): while dragged (not
        `final`) at most `rate_hz` values a second, the newest waiting; a `final` one (released, Enter) at
        once. Ignored while `parameter(target).editable` is False. The node's answer (a rejection and its
        reason) shows in later states."""

    def events(self, t0: float, t1: float) -> Sequence[EventMark]:
        """Return the parameter changes (and deletions) and user markers from `t0` to `t1`, oldest first."""

    def events_version(self) -> int:
        """Return a number that changes whenever `events` may answer differently (redraw when it moved)."""


class TimeRange:
    """The time range the dashboard's time plots share: following the newest data, or held by the user.

    The viewer makes one and hands it to every widget (`WidgetContext.time_range`), and tells it each frame
    the newest source time it holds and the time cursor (`sync`). A time plot draws `window(own_length,
    end)`; the user's wheel, drag and box change it (`follow`, `hold`, `reset`), so every plot sharing the
    object shows the same range. A plot the user unlinks keeps a private copy (`copy`). Pure state, no Dear
    PyGui, used on the UI thread only.

    **Following** (`held` is None): the range ends at `end` (the newest sample live, the cursor paused) and
    lasts `length` seconds, or each plot's own window while `length` is None. **Held**: the user zoomed or
    panned into ``held = (start, end)``; it stays there while data arrives, until `reset` (a double click)
    or back to live (`go_live`: End, the Live button). `version` changes with every change a plot must show.

    Example::

        shared = TimeRange()
        shared.sync(newest=1000.0, cursor=None)
        shared.window(10.0, shared.end(1000.0))   # (990.0, 1000.0): following, the plot's own 10 s
        shared.follow(4.0)                        # a wheel zoom while live: 4 s, still at the newest
        shared.hold(950.0, 960.0)                 # a drag: held, whatever arrives
        shared.reset()                            # a double click: following again, each plot its window
    """

    MIN_LENGTH = 1e-3
    """The shortest range a plot shows (seconds)."""
    MAX_LENGTH = 8 * 86400.0
    """The longest range a plot shows (seconds): more than the history can hold."""
    KEEP_MARGIN = 0.06
    """Held and paused, a cursor moved out of the range brings the range to it, this fraction inside."""

    MOVING_FRAMES = 2
    """Frames in a row with the cursor moved before the cursor counts as `moving`."""

    __slots__ = ("_hover_by", "cursor", "held", "hover", "length", "lives", "moves", "newest", "version")

    def __init__(self) -> None:
        self.newest: float | None = None
        """The newest source time the viewer holds (epoch seconds; set by `sync`), None before any data."""
        self.cursor: float | None = None
        """The time cursor while the dashboard is paused (set by `sync`), None while live."""
        self.length: float | None = None
        """Following: the seconds shown (a zoom set it); None: each plot's own window."""
        self.held: tuple[float, float] | None = None
        """The (start, end) source times the user holds, None while following."""
        self.version = 0
        """Counts the changes of `length` and `held` (what a plot compares to know it must redraw)."""
        self.lives = 0
        """Counts `go_live` calls: plots holding a private range follow the newest data again too."""
        self.hover: float | None = None
        """The source time under the pointer over one of the plots sharing the range (`point`), else None:
        the others show it too."""
        self._hover_by: object = None
        self.moves = 0
        """Frames in a row (`sync` calls) in which the paused cursor moved; 0 once it stays or goes live."""

    @property
    def moving(self) -> bool:
        """Whether the paused cursor keeps moving, frame after frame (a drag of the timeline, a held arrow
        key, playback): a widget may then show its heavy parts one frame late to keep the frames coming."""
        return self.moves >= self.MOVING_FRAMES

    @property
    def following(self) -> bool:
        """Whether the range follows the newest data (the cursor, paused) rather than a range held."""
        return self.held is None

    def end(self, fallback: float) -> float:
        """Return where a following range ends: the cursor (paused), else the newest held or `fallback`."""
        if self.cursor is not None:
            return self.cursor
        return self.newest if self.newest is not None else fallback

    def window(self, length: float, end: float) -> tuple[float, float]:
        """Return the (start, end) source times to show: the range held, or `length` seconds (or the zoomed
        `length`) up to `end` (see `end`)."""
        if self.held is not None:
            return self.held
        span = self.length if self.length is not None else _clamp_length(length)
        return (end - span, end)

    def follow(self, length: float | None = None) -> None:
        """Follow the newest data (the cursor, paused), showing `length` seconds (None: each plot's own)."""
        length = None if length is None else _clamp_length(length)
        if self.held is not None or length != self.length:
            self.held, self.length = None, length
            self.version += 1

    def hold(self, start: float, end: float) -> None:
        """Hold the range at [start, end] (source times) whatever arrives; a range too short or long is
        widened or narrowed about its middle."""
        if not (math.isfinite(start) and math.isfinite(end)):
            return
        start, end = min(start, end), max(start, end)
        span = _clamp_length(end - start)
        if span != end - start:
            middle = (start + end) / 2
            start, end = middle - span / 2, middle + span / 2
        if self.held != (start, end):
            self.held = (start, end)
            self.version += 1

    def reset(self) -> None:
        """Follow the newest data again with each plot's own window (a double click on a plot)."""
        self.follow(None)

    def go_live(self) -> None:
        """Back to live (End, the Live button): `reset`, and plots with a private range reset theirs too."""
        self.reset()
        self.lives += 1

    def sync(self, newest: float | None, cursor: float | None) -> None:
        """Take the newest source time held and the time cursor (None while live); the viewer calls it every
        frame. Going live resets the range (`go_live`), and so does a newest time going back (another data
        source: a recording opened); while paused and held, a cursor moved out of the range brings the range
        to it (the length kept)."""
        was, older = self.cursor, self.newest
        self.newest, self.cursor = newest, cursor
        self.moves = self.moves + 1 if was is not None and cursor is not None and cursor != was else 0
        went_back = newest is not None and older is not None and newest < older
        if (was is not None and cursor is None) or went_back:
            self.go_live()
        elif self.held is not None and was is not None and cursor is not None and cursor != was:
            start, end = self.held
            margin = (end - start) * self.KEEP_MARGIN
            if cursor > end - margin:
                self.hold(start + cursor + margin - end, cursor + margin)
            elif cursor < start + margin:
                self.hold(cursor - margin, end + cursor - margin - start)

    def point(self, t: float | None, by: object) -> None:
        """Say that the pointer is over plot `by` at source time `t` (None: it left `by`)."""
        if t is not None:
            self.hover, self._hover_by = t, by
        elif self._hover_by is by:
            self.hover, self._hover_by = None, None

    def copy(self) -> TimeRange:
        """Return an independent range in the same state (a plot being unlinked keeps what it shows)."""
        other = TimeRange()
        other.newest, other.cursor, other.lives = self.newest, self.cursor, self.lives
        other.length, other.held, other.moves = self.length, self.held, self.moves
        return other


def _clamp_length(seconds: float) -> float:
    return min(max(float(seconds), TimeRange.MIN_LENGTH), TimeRange.MAX_LENGTH)


@dataclass(frozen=True, slots=True)
class WidgetContext:
    """What the viewer hands a widget at mount (and again when its bindings change); the app owns it.

    Args:
        targets: where a control publishes: its bindings (topic, and the field a single value sets); empty
            for a display widget, whose bindings are series the data engine fills instead. A widget that
            declares `Widget.parameters` finds its bindings to a node's parameter here too
            (``Binding.parameter``): shown and set through `WidgetHost.parameter`.
        publisher: the app's publishing service (None for a widget mounted outside a viewer).
        host: the viewer's other services (`WidgetHost`); None for a widget mounted outside a viewer.
        time_range: the time range the dashboard's time plots share (`TimeRange`, one per viewer); None for
            a widget mounted outside a viewer.
    """

    targets: tuple[Binding, ...] = ()
    publisher: PublishService | None = None
    host: WidgetHost | None = None
    time_range: TimeRange | None = None


class Widget(abc.ABC):
    """Base class of every viewer widget: declare the class attributes, implement `create` and `update`.

    The viewer constructs a widget with its validated property values, mounts it (`context` set, then
    `create` once with a parent container and the body size in pixels), then calls `update` whenever one
    of its series changed, `set_context` when its bindings change, `resize` when the user resizes it,
    `set_properties` after the properties dialog, and `destroy` at the end.

    All of these run on the viewer's UI thread. An exception from any of them disables this widget only:
    its frame turns red with the reason and it is not called again; the other widgets keep running.
    Plugins register the class under the entry-point group ``dbglog.widgets`` with the entry point's
    name equal to `type_name`; see ``docs/plugins.md``.
    """

    type_name: ClassVar[str]
    """Registry key saved in dashboard files, e.g. ``"dial"``; must equal the entry point's name."""
    label: ClassVar[str]
    """Name shown in the toolbox."""
    description: ClassVar[str] = ""
    """One line shown as the toolbox tooltip."""
    accepts: ClassVar[frozenset[ValueKind]] = frozenset({ValueKind.NUMBER, ValueKind.BOOL})
    """Value kinds this widget can show; the topic setup dialog warns about others."""
    properties: ClassVar[tuple[Property, ...]] = ()
    max_bindings: ClassVar[int] = 1
    """How many series the widget shows (a plot takes several)."""
    publishes: ClassVar[bool] = False
    """True for a control: its binding is where it publishes, so Topic setup offers no regex or transforms."""
    default_size: ClassVar[tuple[int, int]] = (220, 220)
    min_size: ClassVar[tuple[int, int]] = (120, 90)
    default_topic: ClassVar[str] = ""
    """The topic a new widget of this kind is bound to (its Topic setup starts there); empty: none."""
    parameters: ClassVar[bool] = False
    """True for a widget that may bind to a node's parameter (``/pid_node:kp``) instead of a topic: such a
    binding is no series but a target (`WidgetContext.targets`), shown and set through the viewer
    (`WidgetHost.parameter`, `WidgetHost.set_parameter`); Topic setup then suggests parameters too."""
    paused_at: float | None = None
    """The source time (epoch seconds) the dashboard is paused at, or None while live; set by the viewer
    before each `update`. The snapshots are already as they stood then, so most widgets never look at it;
    a time plot does, to end its window there and draw the cursor."""

    def __init__(self, props: Mapping[str, PropValue] | None = None) -> None:
        self.props: dict[str, PropValue] = self.default_properties()
        if props:
            self.props.update({k: v for k, v in props.items() if k in self.props})
        self.parent: int | str = 0
        self.width = 0
        self.height = 0
        self.props_changed = False
        """Set by `save_property`; the viewer copies `props` into the dashboard and clears it."""
        self.context = WidgetContext()
        """The publish targets and the app's publisher, given at mount (`mount`, `set_context`)."""

    @classmethod
    def default_properties(cls) -> dict[str, PropValue]:
        """Return every declared property at its default."""
        return {p.name: p.default for p in cls.properties}

    @classmethod
    def property_named(cls, name: str) -> Property | None:
        """Return the declaration of property `name` (None when not declared)."""
        return next((p for p in cls.properties if p.name == name), None)

    def save_property(self, name: str, value: object) -> None:
        """Change a property from inside the widget (a toggle's state, a form); saved with the dashboard.

        Raises:
            PropertyError: `name` is not declared, or the value fails its declaration.
        """
        decl = self.property_named(name)
        if decl is None:
            raise PropertyError(f"no property {name!r} on a {self.type_name}")
        self.props[name] = decl.validate(value)
        self.props_changed = True

    def prop(self, name: str) -> PropValue:
        """Return the current value of property `name`."""
        return self.props[name]

    def num(self, name: str) -> float:
        """Return a NUMBER property as a float."""
        value = self.props[name]
        return float(value) if not isinstance(value, str) else 0.0

    def color(self, name: str) -> Color:
        """Return a COLOR property as RGBA."""
        return parse_color(str(self.props[name]))

    def mount(self, parent: int | str, width: int, height: int, context: WidgetContext | None = None) -> None:
        """Remember where the widget lives and build it (the viewer calls this, not `create`).

        Args:
            parent / width / height: the container and the body size in pixels.
            context: the targets and publisher the app gives it; None keeps the current one (a rebuild).
        """
        if context is not None:
            self.context = context
        self.parent, self.width, self.height = parent, width, height
        self.create(parent, width, height)

    def set_context(self, context: WidgetContext) -> None:
        """Take a new context (the user changed the widget's bindings); the default stores it."""
        self.context = context

    @abc.abstractmethod
    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build the widget's Dear PyGui items inside `parent`, filling `width` x `height` pixels."""

    @abc.abstractmethod
    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Show new data: one snapshot per binding, in binding order.

        `now` is the moment the dashboard shows, in epoch seconds: the wall clock while live, the cursor's
        time while paused (`paused_at`), so ``now - snapshot.last_time`` is the age of the value then.
        """

    def past_needed(self, at: float) -> float | None:
        """Return how many seconds of samples before the cursor time `at` the widget draws while paused.

        The viewer then reads only those (and the sample just before them) from the history, so moving the
        cursor costs less: 0 for a widget that shows the value at the cursor alone (a gauge), a plot's
        visible range for a plot. The default None: every sample a live series' window holds. Every other
        field of the snapshot is the same either way; asked on the UI thread before each paused update.
        """
        return None

    def status(self) -> tuple[Status, str] | None:
        """Return the widget's own status and reason for its pill, or None (the default) to show its series'.

        Control widgets report their publishing state here; the viewer asks once per frame, so keep it cheap.
        """
        return None

    def redraw_key(self) -> object:
        """Return a value that, when it changes, makes the viewer call `update` though no series changed.

        For a widget with input or data of its own (a console's filters, its scrolling, the mouse over it);
        the default None means "only when a series changes". The viewer asks on the UI thread at every turn
        of its render loop, so keep it cheap (it may read the mouse).
        """
        return None

    def owns_pointer(self, x: float, y: float) -> bool:
        """Whether the mouse at window pixel (x, y) is the widget's own (default: never).

        There the mouse wheel is the widget's (the canvas does not scroll) and a right click is the widget's
        (the viewer's widget menu does not open; the title strip always has it).
        """
        return False

    def publisher(self) -> PublishService:
        """Return the publishing service the app gave this widget at mount (its thread starts on first use).

        Example::

            self.publisher().update(self, PublishRequest("/led", default_type="std_msgs/msg/Bool",
                                                         value=True, value_kind="bool"), send=True)
            state = self.publisher().state(self)   # PublishState(status, reason, ...)

        Raises:
            RuntimeError: the widget was mounted outside a viewer, without a publisher.
        """
        publisher = self.context.publisher
        if publisher is None:
            raise RuntimeError(f"{type(self).__name__} was mounted without a publisher (outside a viewer)")
        return publisher

    def resize(self, width: int, height: int) -> None:
        """Fit the new body size; the default rebuilds the widget (create again in the same parent)."""
        self.destroy()
        self.mount(self.parent, width, height)

    def set_properties(self, props: Mapping[str, PropValue]) -> None:
        """Take new property values; the default stores them and rebuilds."""
        self.props.update({k: v for k, v in props.items() if k in self.props})
        self.resize(self.width, self.height)

    def destroy(self) -> None:
        """Delete the widget's items; the default deletes every child of the parent."""
        import dearpygui.dearpygui as dpg

        if self.parent and dpg.does_item_exist(self.parent):
            dpg.delete_item(self.parent, children_only=True)


_KIND_WORDS = {
    ValueKind.BOOL: "bool",
    ValueKind.NUMBER: "numbers",
    ValueKind.TEXT: "text",
    ValueKind.ARRAY: "arrays",
}


def kind_problem(widget_cls: type[Widget], snapshot: SeriesSnapshot) -> str:
    """Say why a widget cannot show a series of this value kind (``""`` when it can, or while unknown).

    The rule is the class's declared `Widget.accepts`, the same for built-ins and plugins, e.g.
    ``LED shows bool or numbers; /x is std_msgs/msg/String text``.
    """
    kind = snapshot.kind
    accepts: frozenset[ValueKind] = getattr(widget_cls, "accepts", frozenset())
    if kind is None or kind in accepts:
        return ""
    shown = " or ".join(word for k, word in _KIND_WORDS.items() if k in accepts) or "nothing"
    binding = snapshot.binding
    where = binding.topic if not binding.field.strip() else f"{binding.topic} field {binding.field.strip()!r}"
    what = f"{snapshot.msg_type} {_KIND_WORDS[kind]}" if snapshot.msg_type else _KIND_WORDS[kind]
    hint = ""
    if kind is ValueKind.TEXT and accepts & {ValueKind.NUMBER, ValueKind.BOOL}:
        hint = " (a regex can turn text into numbers or bools: right-click \u203a Topic setup)"
    label = getattr(widget_cls, "label", "") or getattr(widget_cls, "type_name", "this widget")
    return f"{label} shows {shown}; {where} is {what}{hint}"


def shown_as(widget_cls: type[Widget], snapshot: SeriesSnapshot) -> SeriesSnapshot:
    """Return the snapshot a widget of `widget_cls` is given: an ERROR without data for a kind it can't show.

    The viewer passes every snapshot through this before `Widget.update`, so a widget only ever sees
    the value kinds it declared, and its status pill says why nothing is shown.
    """
    problem = kind_problem(widget_cls, snapshot)
    if not problem:
        return snapshot
    return replace(
        snapshot,
        status=Status.ERROR,
        reason=problem,
        times=np.empty(0),
        values=np.empty(0),
        texts=(),
        last=None,
        last_time=None,
    )
