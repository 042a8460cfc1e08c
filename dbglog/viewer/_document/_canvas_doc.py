"""The open dashboard as a headless document: its widgets, their bindings' reference counts, selection, file.

No Dear PyGui here: the window draws what this holds, and every edit that changes what would be saved
marks it modified (`on_change` tells the window, e.g. to retitle itself). A widget's robot-relative bindings
(the selected robot's, every robot's) are resolved against the document's `Fleet`: switching robots rebinds
them (`sync_robots`), which is viewer state, not an edit.
"""

from __future__ import annotations

import collections
import re
import weakref
from collections.abc import Callable, Collection, Sequence
from pathlib import Path
from typing import Generic, Protocol, TypeVar

from dbglog._ros._tags import tag_of
from dbglog.viewer._data._model import Binding, DataSource, FieldInfo, SeriesSnapshot, TopicInfo
from dbglog.viewer._data._robots import Fleet, robot_name
from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig
from dbglog.viewer._widgets._geometry import Part, Rect, hit_test

__all__ = ["CanvasDoc", "DocItem", "TopicSetup", "topic_widget_name"]


class DocItem(Protocol):
    """What the document needs of a placed widget (the window's frame, or any stand-in in a test)."""

    @property
    def config(self) -> WidgetConfig | RawWidget:
        """The entry as it would be saved."""
        ...

    @property
    def name(self) -> str:
        """The title."""
        ...

    @property
    def label(self) -> str | None:
        """The widget type's label (None for a placeholder)."""
        ...

    @property
    def series(self) -> tuple[Binding, ...]:
        """The bindings the data source fills for it (concrete: as last resolved)."""
        ...

    @property
    def rect(self) -> Rect:
        """Place and size in canvas pixels."""
        ...

    def set_bindings(self, bindings: tuple[Binding, ...]) -> None:
        """Point the widget at new series."""

    def rename(self, name: str) -> None:
        """Change the title."""

    def resolve(self, fleet: Fleet) -> tuple[Binding, ...]:
        """Resolve its robot-relative bindings against `fleet` (its `series`, a control's publish targets)
        and return the concrete series the data source is to fill."""
        ...


ItemT = TypeVar("ItemT", bound=DocItem)


def _tag_parts(topic: str) -> list[str]:
    tag = tag_of(topic) or topic
    return [p for p in tag.split("/") if p]


def topic_widget_name(bindings: Sequence[Binding], taken: Collection[str] = ()) -> str | None:
    """Return a title for a widget showing `bindings`, or None when none has a topic.

    The last component of the tag (``/rosdashboard/motor/speed`` -> ``speed``), with the field unless it
    is ``data`` (``cmd_vel.linear.x``); several topics are listed. A name in `taken` gets the tag's
    components before it, then a number.
    """
    bound = [b for b in bindings if b.topic.strip("/")]
    if not bound:
        return None
    topics = list(dict.fromkeys(b.topic for b in bound))
    field = bound[0].field.strip() if len(bound) == 1 else ""
    suffix = f".{field}" if field and field != "data" else ""
    parts = [_tag_parts(t) for t in topics]
    for depth in range(1, max(len(p) for p in parts) + 1):
        name = ", ".join("/".join(p[-depth:]) for p in parts[:3]) + ("\u2026" if len(parts) > 3 else "")
        name = (name + suffix)[:200]
        if name not in taken:
            return name
    n = 2
    while f"{name} {n}" in taken:
        n += 1
    return f"{name} {n}"


class CanvasDoc(Generic[ItemT]):
    """The widgets in drawing order (last on top), what they bind, the selection, the file and its state.

    Args:
        source: where the widgets' series come from; each binding is bound once however many use it.
        on_change: called when the saved state or the file changes (title, modified mark).
    """

    def __init__(
        self, source: DataSource, on_change: Callable[[], None] | None = None, *, fleet: Fleet | None = None
    ) -> None:
        self.source = source
        self.on_change = on_change
        self.fleet = fleet if fleet is not None else Fleet()
        """The robots seen and the one selected: what robot-relative bindings resolve to."""
        self._held: dict[ItemT, tuple[Binding, ...]] = {}
        """Widget -> the concrete series bound for it (what `sync_robots` releases when they change)."""
        self._fleet_seen = self.fleet.version
        self.items: list[ItemT] = []
        self.selected: ItemT | None = None
        self.path: Path | None = None
        self.dirty = False
        self.grid_size = 20
        self.snap = True
        self.load_messages: list[str] = []
        self.refs: collections.Counter[Binding] = collections.Counter()
        """Binding -> how many users (widgets, an open Topic setup's preview) hold it bound."""
        self._auto_names: weakref.WeakKeyDictionary[ItemT, str] = weakref.WeakKeyDictionary()
        """Widget -> the name its topic gave it (while it keeps that name, a new topic renames it)."""

    # -- bindings -----------------------------------------------------------------------------------

    def bind(self, binding: Binding) -> None:
        """Take one reference to `binding`; the first binds it at the source."""
        if self.refs[binding] == 0:
            self.source.bind(binding)
        self.refs[binding] += 1

    def unbind(self, binding: Binding) -> None:
        """Drop one reference to `binding`; the last unbinds it at the source (extra drops do nothing)."""
        if self.refs[binding] <= 0:
            return
        self.refs[binding] -= 1
        if self.refs[binding] == 0:
            del self.refs[binding]
            self.source.unbind(binding)

    def release_all(self) -> None:
        """Unbind everything (the window closes)."""
        for binding in list(self.refs):
            self.source.unbind(binding)
        self.refs.clear()
        self._held.clear()

    def _hold(self, item: ItemT) -> bool:
        """Resolve `item`'s bindings and bind its series (the new ones first); True if they changed."""
        new = item.resolve(self.fleet)
        old = self._held.get(item, ())
        for b in new:
            self.bind(b)
        self._held[item] = new
        for b in old:
            self.unbind(b)
        return new != old

    def _release(self, item: ItemT) -> None:
        for b in self._held.pop(item, ()):
            self.unbind(b)

    def sync_robots(self) -> int:
        """After the fleet changed (a robot selected, robots or topics seen): resolve every widget's
        robot-relative bindings again and rebind what changed. Not an edit. Returns the widgets changed."""
        if self.fleet.version == self._fleet_seen:
            return 0
        self._fleet_seen = self.fleet.version
        return sum(self._hold(item) for item in self.items)

    # -- state --------------------------------------------------------------------------------------

    def mark_dirty(self) -> bool:
        """Note an unsaved change; True when the document was unmodified until now."""
        if self.dirty:  # a dragged slider marks it every frame: tell the window once
            return False
        self.dirty = True
        self._changed()
        return True

    def _changed(self) -> None:
        if self.on_change is not None:
            self.on_change()

    def file_name(self) -> str:
        """The file's name, or "untitled"."""
        return self.path.name if self.path else "untitled"

    def title(self, base: str) -> str:
        """The window title: `base`, the file's name, and a star when modified."""
        return f"{base} \u2014 {self.file_name()}{' *' if self.dirty else ''}"

    def summary(self) -> list[str]:
        """The status bar's parts: the file (and whether modified), the widget count, the grid."""
        count = len(self.items)
        return [
            f"{self.path if self.path else 'untitled'}{' (modified)' if self.dirty else ''}",
            f"{count} widget{'' if count == 1 else 's'}",
            f"grid {self.grid_size}px {'on' if self.snap else 'off'}",
        ]

    def dashboard(self) -> Dashboard:
        """The document as it would be saved."""
        return Dashboard([i.config for i in self.items], self.grid_size, self.snap)

    def opened(self, dashboard: Dashboard, path: Path | None, messages: Sequence[str]) -> None:
        """Take a loaded file's settings (its widgets are `add`ed by the caller); unmodified."""
        self.grid_size, self.snap = dashboard.grid_size, dashboard.snap
        self.path = path
        self.dirty = False
        self.load_messages = list(messages)
        self._changed()

    def saved(self, path: Path) -> None:
        """The document was written to `path`: that is its file now, unmodified."""
        self.path = path
        self.dirty = False
        self._changed()

    def renew(self, path: Path | None) -> None:
        """An empty document (that Save writes to `path`, when given); call after `clear`."""
        self.path = path
        self.dirty = False
        self.load_messages = []
        self._changed()

    def set_snap(self, on: bool) -> None:
        """Switch snap-to-grid on or off (a saved setting)."""
        self.snap = on
        self.mark_dirty()

    def set_grid_size(self, size: int) -> None:
        """Change the grid spacing in pixels, kept within 2-400 (a saved setting)."""
        self.grid_size = max(2, min(400, int(size)))
        self.mark_dirty()

    # -- widgets ------------------------------------------------------------------------------------

    def add(self, item: ItemT) -> ItemT:
        """Put `item` on top of the others and bind its series (not an edit by itself: see `mark_dirty`)."""
        self.items.append(item)
        self._hold(item)
        return item

    def remove(self, item: ItemT) -> bool:
        """Take `item` off and release its series; False if it was not there."""
        if item not in self.items:
            return False
        self._release(item)
        self.items.remove(item)
        if self.selected is item:
            self.selected = None
        self.mark_dirty()
        return True

    def clear(self) -> list[ItemT]:
        """Take every widget off and release their series; return them (the window destroys them)."""
        removed = list(self.items)
        for item in removed:
            self._release(item)
        self.items.clear()
        self.selected = None
        return removed

    def replace(self, old: ItemT, new: ItemT) -> None:
        """Put `new` where `old` is (same place in the drawing order), binding new series before releasing."""
        self.items[self.items.index(old)] = new
        if self._auto_names.get(old) == old.name:
            self._auto_names[new] = new.name
        self._hold(new)
        self._release(old)
        if self.selected is old:
            self.selected = None
        self.mark_dirty()

    def to_front(self, item: ItemT) -> bool:
        """Draw `item` above the others; True if it moved in the drawing order."""
        if not self.items or self.items[-1] is item:
            return False
        self.items.remove(item)
        self.items.append(item)
        return True

    def rename(self, item: ItemT, name: str) -> None:
        """Give a widget a new title."""
        item.rename(name)
        self.mark_dirty()

    def unique_name(self, label: str) -> str:
        """`label`, or "label 2", "label 3"... whichever no widget has yet."""
        taken = {i.name for i in self.items}
        name, n = label, 1
        while name in taken:
            n += 1
            name = f"{label} {n}"
        return name

    def set_bindings(self, item: ItemT, bindings: tuple[Binding, ...], *, edit: bool = True) -> None:
        """Point a widget at new series (binding the new ones before releasing the old).

        A widget still called by its type ("Dial 2") or by the name its last topic gave it is named
        after its new topic; a name the user gave it stays. Without `edit`, the bindings follow from
        what the document already holds (a watch's topics) and leave it unmodified.
        """
        auto = self._auto_named(item)
        item.set_bindings(bindings)
        self._hold(item)  # a control's bindings are where it publishes: no series for them
        if auto:
            name = topic_widget_name(bindings, {i.name for i in self.items if i is not item})
            if name is not None and name != item.name:
                item.rename(name)
                self._auto_names[item] = name
        if edit:
            self.mark_dirty()

    def _auto_named(self, item: ItemT) -> bool:
        if self._auto_names.get(item) == item.name:
            return True
        label = item.label
        return label is not None and re.fullmatch(re.escape(label) + r"( \d+)?", item.name) is not None

    def hit(self, x: float, y: float, *, title_h: float, corner: float) -> tuple[ItemT, Part] | None:
        """The topmost widget at canvas point (x, y) and the part hit (title, corner grip, body), or None."""
        found = hit_test([i.rect for i in self.items], x, y, title_h=title_h, corner=corner)
        return None if found is None else (self.items[found[0]], found[1])


class TopicSetup(Generic[ItemT]):
    """What the Topic setup dialog may do: read the graph, preview a series, and apply the result."""

    def __init__(self, doc: CanvasDoc[ItemT], item: ItemT) -> None:
        self.doc, self.item = doc, item

    def topics(self) -> list[TopicInfo]:
        """The topics of the live graph."""
        return self.doc.source.topics()

    def shown(self, binding: Binding) -> Binding:
        """The concrete binding the dialog edits for `binding` (a relative one: the selected robot's)."""
        return self.doc.fleet.shown(binding)

    def relative(self, binding: Binding, mode: str) -> Binding:
        """A concrete binding made to follow the selected robot, show every robot (`mode`), or stay."""
        return self.doc.fleet.relative(binding, mode)

    def robot(self) -> str | None:
        """The selected robot's name when the viewer has seen robots in namespaces (None: there are none)."""
        fleet = self.doc.fleet
        return robot_name(fleet.selected) if fleet.namespaced else None

    def fields(self, topic: str) -> list[FieldInfo]:
        """The fields of `topic`'s message type."""
        return self.doc.source.fields(topic)

    def snapshot(self, binding: Binding) -> SeriesSnapshot:
        """The series of a previewed binding."""
        return self.doc.source.snapshot(binding)

    def preview(self, binding: Binding) -> None:
        """Keep `binding` bound while the dialog shows its latest value."""
        self.doc.bind(binding)

    def end_preview(self, binding: Binding) -> None:
        """Release a previewed binding."""
        self.doc.unbind(binding)

    def apply(self, bindings: tuple[Binding, ...]) -> None:
        """Give the widget its new bindings."""
        self.doc.set_bindings(self.item, bindings)
