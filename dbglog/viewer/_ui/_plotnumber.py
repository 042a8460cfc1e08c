"""Plot this number: the dialog a right click on a number in the Log console opens.

It proposes an RE2 pattern for that kind of line (`dbglog._regex._propose`): the words around the number
generalised but the one nearest before it (``bumped into the south wall`` matches the north wall too;
"the same words only" keeps them), previews every stored line the pattern matches with the value it would
take, with the count before OK, and on OK adds a widget bound to the log topic with that pattern (its
capture named after the tag: a plot's legend shows it), node and level (the engine fills it from its
history); "Copy as bridge rule" gives the YAML for ``dbglog bridge``. Callbacks only record what was
clicked; `tick` does the work on the UI thread.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import dearpygui.dearpygui as dpg
import numpy as np

from dbglog._regex._propose import Proposal, ProposalError, find_numbers, propose, suggest_tag, to_bridge_yaml
from dbglog.viewer._data._logstore import LOG_TYPE, LogStore, Matches, level_of
from dbglog.viewer._data._model import Binding
from dbglog.viewer._ui._dialogs import ERROR_COLOR, Dialog
from dbglog.viewer._ui._theme import DIM
from dbglog.viewer._widgets._common import clock_text

__all__ = ["LEVELS", "PREVIEW_ROWS", "NumberPlan", "PlotNumberDialog", "number_binding", "plot_window"]

LEVELS = ("any", "debug", "info", "warn", "error", "fatal")
PREVIEW_ROWS = 200
"""The newest matching lines listed in the preview (the count covers them all)."""


def number_binding(
    topic: str, msg_type: str, proposal: Proposal, *, node: str = "", level: str = "", name: str = ""
) -> Binding:
    """The binding that plots the proposal's number: the log text field, the pattern (its capture named
    `name`, what a plot's legend shows), node and level."""
    field = "msg" if msg_type == LOG_TYPE else ""
    pattern = proposal.named(name) if name else proposal.pattern
    return Binding(topic, field, pattern, node=node if msg_type == LOG_TYPE else "", level=level)


def plot_window(times: Sequence[float] | np.ndarray, now: float) -> float:
    """A plot window (seconds) that shows every matched line up to now: 10 s at least, an hour at most."""
    if not len(times):
        return 10.0
    span = now - float(np.min(times))
    return float(min(3600.0, max(10.0, np.ceil(round(span * 1.1, 6)))))


@dataclass(frozen=True, slots=True)
class NumberPlan:
    """What OK adds: a widget of `type_name` named `name`, bound by `binding`, with `properties`."""

    type_name: str
    name: str
    binding: Binding
    properties: dict[str, float | str | bool]


class PlotNumberDialog(Dialog):
    """Propose a pattern for a clicked number, preview it over the stored lines, add a widget or copy a rule.

    Args:
        store: the console's log store (its lines are previewed).
        topic: the log topic.
        line_id: the clicked line.
        number: which number of the line (0-based).
        widget_types: (type name, label) of the widgets that can show numbers, the first one the default.
        on_ok: adds the widget (`NumberPlan`); returns a message for the status bar.
        on_close: the app's dialog bookkeeping.
    """

    def __init__(
        self,
        store: LogStore,
        topic: str,
        line_id: int,
        number: int,
        widget_types: Sequence[tuple[str, str]],
        on_ok: Callable[[NumberPlan], object],
        on_close: Callable[[Dialog], None],
    ) -> None:
        super().__init__("Plot this number", 700, on_close)
        self.store, self.topic, self.on_ok = store, topic, on_ok
        self.line = store.line(line_id)
        self.numbers = find_numbers(self.line.message)
        self.number = number
        self.widget_types = list(widget_types)
        self.proposal: Proposal | None = None
        self.matches: Matches | None = None
        self.preview_ms = 0.0
        self.copied = ""
        """The YAML last put on the clipboard (tests read it)."""
        w = self.window
        head = f"{clock_text(self.line.time)}  [{self.line.node}]  " if self.line.node else ""
        shown = self.line.message if len(self.line.message) <= 400 else self.line.message[:400] + "\u2026"
        dpg.add_text(head + shown.replace("\n", " \u21b5 "), parent=w, wrap=670)
        labels = [f"{k + 1}) {n.text}{n.unit}" for k, n in enumerate(self.numbers[:50])]
        with dpg.group(horizontal=True, parent=w):
            dpg.add_text("Number", color=DIM)
            self.number_combo = dpg.add_combo(
                labels,
                default_value=labels[number] if number < len(labels) else "",
                width=160,
                callback=lambda _s, v: self._record("number", v),
            )
            dpg.add_text("Minimum level", color=DIM)
            self.level_combo = dpg.add_combo(
                LEVELS, default_value="any", width=80, callback=lambda _s, v: self._record("level", v)
            )
        with dpg.group(horizontal=True, parent=w):
            self.node_box = dpg.add_checkbox(
                label=f"only lines of node {self.line.node}"
                if self.line.node
                else "every line (no nodes here)",
                default_value=bool(self.line.node),
                enabled=bool(self.line.node),
                callback=lambda _s, v: self._record("node", bool(v)),
            )
            self.words_box = dpg.add_checkbox(
                label="the same words only",
                default_value=False,
                callback=lambda _s, v: self._record("words", bool(v)),
            )
        with dpg.tooltip(self.words_box):
            dpg.add_text(
                "Off: any words around the number match but the one nearest before it (its name).\n"
                "On: every word of the line as it is."
            )
        dpg.add_text(
            "Pattern (RE2: the number captured, other numbers and words generalised)",
            color=DIM,
            parent=w,
        )
        self.pattern_text = dpg.add_input_text(width=-1, readonly=True, parent=w)
        self.count_text = dpg.add_text("", parent=w)
        self.preview_list = dpg.add_child_window(height=170, width=-1, parent=w)
        with dpg.group(horizontal=True, parent=w):
            dpg.add_text("Show as", color=DIM)
            self.type_combo = dpg.add_combo(
                [label for _, label in self.widget_types],
                default_value=self.widget_types[0][1] if self.widget_types else "",
                width=120,
            )
            dpg.add_text("Tag / name", color=DIM)
            self.tag_input = dpg.add_input_text(width=200)
        self.error_text = dpg.add_text("", color=ERROR_COLOR, parent=w, wrap=670)
        dpg.add_spacer(height=4, parent=w)
        with dpg.group(horizontal=True, parent=w):
            self.ok_button = dpg.add_button(
                label="OK", width=100, callback=lambda *_: self._record("ok", None)
            )
            self.copy_button = dpg.add_button(
                label="Copy as bridge rule", width=160, callback=lambda *_: self._record("copy", None)
            )
            dpg.add_button(label="Cancel", width=100, callback=lambda *_: self._record("cancel", None))
        self._propose()

    def tick(self) -> None:
        """Apply what was clicked (on the UI thread)."""
        super().tick()
        for what, value in self._take_events():
            if self.closed:
                return
            if what == "number" and isinstance(value, str):
                self.number = int(value.split(")")[0]) - 1
                self._propose()
            elif what == "words":
                self._propose()
            elif what in ("level", "node"):
                self._preview()
            elif what == "ok":
                self.apply()
            elif what == "copy":
                self.copy_rule()
            elif what == "cancel":
                self.close()

    # -- the proposal and its preview --

    @property
    def node(self) -> str:
        """The node filter: the line's logger while the box is ticked."""
        return self.line.node if self.line.node and bool(dpg.get_value(self.node_box)) else ""

    @property
    def level(self) -> str:
        """The minimum level chosen (``""`` for any)."""
        value = str(dpg.get_value(self.level_combo))
        return "" if value == "any" else value

    @property
    def same_words(self) -> bool:
        """Whether the words around the number must be as in the line (the box ticked)."""
        return bool(dpg.get_value(self.words_box))

    def _propose(self) -> None:
        try:
            self.proposal = propose(
                self.line.message,
                self.number,
                node=self.line.node or None,
                generalise_words=not self.same_words,
            )
        except ProposalError as exc:
            self.proposal = None
            dpg.set_value(self.error_text, str(exc))
            dpg.set_value(self.pattern_text, "")
            return
        dpg.set_value(self.error_text, "")
        dpg.set_value(self.pattern_text, self.proposal.pattern)
        dpg.set_value(self.tag_input, suggest_tag(self.proposal))
        self._preview()

    def _preview(self) -> None:
        """Match the proposal over every stored line: the count, and the newest lines with their values."""
        proposal = self.proposal
        if proposal is None:
            return
        started = time.perf_counter()
        self.matches = self.store.preview(proposal, node=self.node, min_level=level_of(self.level))
        self.preview_ms = (time.perf_counter() - started) * 1e3
        matches = self.matches
        dpg.set_value(
            self.count_text,
            f"matches {matches.count:,} of {len(self.store):,} stored lines"
            + (f" (the newest {PREVIEW_ROWS} below)" if matches.count > PREVIEW_ROWS else ""),
        )
        dpg.delete_item(self.preview_list, children_only=True)
        ids = matches.ids[-PREVIEW_ROWS:][::-1]
        values = matches.values[-PREVIEW_ROWS:][::-1]
        messages = self.store.messages(ids.tolist())
        times = self.store.times(ids)
        for t, value, message in zip(times.tolist(), values.tolist(), messages, strict=True):
            text = message if len(message) <= 120 else message[:120] + "\u2026"
            dpg.add_text(
                f"{clock_text(t)}   {value:<12.6g} {text.replace(chr(10), ' ')}", parent=self.preview_list
            )

    # -- the buttons --

    def plan(self) -> NumberPlan | None:
        """What OK would add, or None (no proposal)."""
        if self.proposal is None or not self.widget_types:
            return None
        label = str(dpg.get_value(self.type_combo))
        type_name = next((t for t, lab in self.widget_types if lab == label), self.widget_types[0][0])
        name = str(dpg.get_value(self.tag_input)).strip() or suggest_tag(self.proposal)
        binding = number_binding(
            self.topic, self.store.msg_type, self.proposal, node=self.node, level=self.level, name=name
        )
        props: dict[str, float | str | bool] = {}
        if type_name == "plot" and self.matches is not None:
            props["window"] = plot_window(self.matches.times, time.time())
        return NumberPlan(type_name, name, binding, props)

    def apply(self) -> bool:
        """Add the widget and close."""
        plan = self.plan()
        if plan is None:
            return False
        self.on_ok(plan)
        self.close()
        return True

    def copy_rule(self) -> str:
        """Put a ``dbglog bridge`` rules file for this number on the clipboard; return it."""
        if self.proposal is None:
            return ""
        tag = str(dpg.get_value(self.tag_input)).strip() or suggest_tag(self.proposal)
        proposal = (
            self.proposal
            if self.node
            else propose(self.line.message, self.number, node=None, generalise_words=not self.same_words)
        )
        try:
            text = to_bridge_yaml(proposal, tag, level=self.level or None)
        except ValueError as exc:
            dpg.set_value(self.error_text, str(exc))
            return ""
        dpg.set_clipboard_text(text)
        self.copied = text
        dpg.set_value(self.error_text, "")
        counted = str(dpg.get_value(self.count_text)).split("  \u00b7")[0]
        dpg.set_value(self.count_text, counted + "  \u00b7  rule copied")
        return text
