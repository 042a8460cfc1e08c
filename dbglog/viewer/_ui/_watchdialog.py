"""Watch a variable: the dialog that picks a running process, a file, a line and an expression to plot.

As a debugger's logpoint is set: choose a watchable process, type part of a file name and pick it from the
files the process loaded, click a line of its source (sent by the process, the chosen line highlighted),
then type an expression with completion over the names the code at that line can read. OK adds a widget
that shows it (docs/watch.md, *In the viewer*). The dialog never waits: every question to the process is a
`Future` that `tick` polls once a frame, and each part says what it waits for meanwhile. Callbacks only
record what was clicked or typed; `tick` does the work on the UI thread.
"""

from __future__ import annotations

import ast
import os
import re
from collections.abc import Callable, Sequence
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any, Final, Protocol

import dearpygui.dearpygui as dpg

from dbglog.viewer._data._model import Status
from dbglog.viewer._document._dashboard import WatchConfig
from dbglog.viewer._ui._dialogs import ERROR_COLOR, OK_COLOR, Dialog
from dbglog.viewer._ui._theme import DIM, STATUS_COLORS
from dbglog.watch.client import Names, Process, Source, WatchError, WatchSpec

__all__ = [
    "CONTEXT_LINES",
    "SHOW_AS",
    "WatchDialog",
    "WatchPlan",
    "WatchQueries",
    "complete",
    "completions",
    "condition_check",
    "expression_check",
    "file_suggestions",
    "process_label",
    "source_row",
    "typed_token",
    "unknown_names",
]

CONTEXT_LINES: Final = 200
"""Lines asked for on each side of the line shown (the process sends at most this many)."""
SHOW_AS: Final = (
    ("plot", "Plot"),
    ("dial", "Dial"),
    ("thermo", "Thermo"),
    ("string", "String"),
    ("led", "LED"),
)
"""The widgets a watch can show as (type, label), the default first."""
MAX_SUGGESTIONS: Final = 60
TALLEST_H: Final = 840
"""The dialog's height with its longest lists shown (it is placed so that this fits the window)."""
ROW_H: Final = 21
"""The height of a row of a list (a selectable in the window's font, with the lists' spacing)."""
_WAITING = STATUS_COLORS[Status.WAITING]
_ENTERS: Final = frozenset({"file_enter", "line_enter", "expr_enter", "when_enter"})
"""What an Enter in a field records (one per press: a held key's repeats are dropped)."""
_TOKEN = re.compile(r"(?<![\w.])([A-Za-z_]\w*)$")


# -- the logic, plain functions ----------------------------------------------------------------------------


def process_label(process: Process) -> str:
    """One line naming a watchable process: its name, pid (and host when not this one), its program."""
    host = "" if process.host in ("", os.uname().nodename) else f" on {process.host}"
    program = " ".join(process.program)
    if len(program) > 70:
        program = "\u2026" + program[-69:]
    return f"{process.name}   pid {process.pid}{host}   {program}"


def file_suggestions(files: Sequence[str], typed: str, limit: int = MAX_SUGGESTIONS) -> list[str]:
    """The files matching what is typed: names that start with it first, then names, then paths holding it.

    Case does not matter; an empty text lists every file (by name).
    """
    text = typed.strip().lower()
    ranked: list[tuple[int, str, str]] = []
    for path in files:
        name = os.path.basename(path).lower()
        if name.startswith(text):
            rank = 0
        elif text in name:
            rank = 1
        elif text in path.lower():
            rank = 2
        else:
            continue
        ranked.append((rank, name, path))
    ranked.sort()
    return [path for _rank, _name, path in ranked[:limit]]


def source_row(number: int, text: str, width: int) -> str:
    """A line of source as the dialog lists it: its number right-aligned in `width`, tabs as 4 spaces."""
    return f"{number:>{width}}  {text.expandtabs(4).rstrip()}"


def typed_token(text: str) -> str:
    """The name being typed at the end of an expression (``""`` after a dot: attributes are not known)."""
    found = _TOKEN.search(text)
    return found.group(1) if found is not None else ""


def completions(names: Names | None, text: str, limit: int = MAX_SUGGESTIONS) -> list[str]:
    """The names the code at the line can read that complete the name typed last: its locals first.

    Nothing after a dot (an attribute) or an operator; dunder names are left out (the reader refuses them).
    """
    if names is None:
        return []
    token = typed_token(text)
    if not token and text.strip():
        return []
    seen: dict[str, None] = {}
    for name in (*names.locals, *names.globals):
        if name.startswith("__") or name in seen:
            continue
        if name.startswith(token) or (token and name.lower().startswith(token.lower())):
            seen[name] = None
    return list(seen)[:limit]


def complete(text: str, name: str) -> str:
    """`text` with the name typed last replaced by `name` (appended when none is being typed)."""
    token = typed_token(text)
    return text[: len(text) - len(token)] + name


def expression_check(text: str) -> tuple[bool, str]:
    """Whether an expression may be watched, and what to say: ``ok`` or why it is refused (no code runs)."""
    if not text.strip():
        return False, "type a name, an attribute or an item: speed, self.pose.x, ranges[0]"
    try:
        WatchSpec("file.py", 1, (text.strip(),)).check()
    except WatchError as exc:
        return False, str(exc)
    return True, "ok: read as the line is about to run; nothing of the program runs"


def condition_check(text: str) -> tuple[bool, str]:
    """Whether a condition (only the hits where it is true, as a conditional breakpoint's) may be watched,
    and why not (``""``: allowed; an empty condition is every hit)."""
    if not text.strip():
        return True, ""
    try:
        WatchSpec("file.py", 1, ("x",), when=text.strip()).check()
    except WatchError as exc:
        return False, f"only when: {exc}"
    return True, ""


def unknown_names(text: str, names: Names | None) -> list[str]:
    """The names `text` reads that the code at the line does not have now (no local, no global of it).

    Python's parser only reads the text: nothing is evaluated. Empty when `names` is not known yet or the
    text is no expression (`expression_check` says why).
    """
    if names is None:
        return []
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        return []
    known = {*names.locals, *names.globals}
    read = dict.fromkeys(n.id for n in ast.walk(tree) if isinstance(n, ast.Name))
    return [name for name in read if name not in known]


@dataclass(frozen=True, slots=True)
class WatchPlan:
    """What OK adds: a widget of `type_name` named `name` that shows `watch`."""

    type_name: str
    name: str
    watch: WatchConfig


class WatchQueries(Protocol):
    """What the dialog asks of the watch service: the processes, and questions answered later."""

    @property
    def failure(self) -> str:
        """Why watching cannot work here (no ROS), or ``""``."""
        ...

    @property
    def ready(self) -> bool:
        """Whether the client is up."""
        ...

    def processes(self) -> list[Process]:
        """The watchable processes known now."""
        ...

    def discovering(self) -> bool:
        """Whether processes already running may still be on their way."""
        ...

    def files(self, process: Process, *, everything: bool = False) -> Future[list[str]]:
        """The user's source files `process` loaded (`everything`: libraries too)."""
        ...

    def source(self, process: Process, file: str, line: int, *, context: int = 10) -> Future[Source]:
        """Lines of `file` around `line`."""
        ...

    def names(self, process: Process, file: str, line: int) -> Future[Names]:
        """The names an expression at `line` can read."""
        ...


class _Ask:
    """A question to the process and its answer once the `Future` is done (read on the UI thread)."""

    def __init__(self, future: Future[Any], about: object) -> None:
        self.future = future
        self.about = about
        """What was asked (an answer to an older question is dropped)."""

    def answer(self) -> tuple[object, BaseException | None] | None:
        """(value, error) once answered, else None."""
        if not self.future.done():
            return None
        if self.future.cancelled():
            return None, WatchError("the question was cancelled", "timeout")
        error = self.future.exception()
        return (None, error) if error is not None else (self.future.result(), None)


# -- the dialog ------------------------------------------------------------------------------------------


class WatchDialog(Dialog):
    """Pick a process, a file, a line and an expression; OK adds a widget that shows the variable.

    Args:
        queries: the watch service (every question is answered later, polled by `tick`).
        on_ok: adds the widget (`WatchPlan`).
        on_close: the app's dialog bookkeeping.
        code_font: a monospaced font for the source, or None.
    """

    def __init__(
        self,
        queries: WatchQueries,
        on_ok: Callable[[WatchPlan], object],
        on_close: Callable[[Dialog], None],
        *,
        code_font: int | str | None = None,
    ) -> None:
        super().__init__("Watch a variable", 780, on_close)
        self.queries, self.on_ok, self.code_font = queries, on_ok, code_font
        self.procs: list[Process] = []
        self.process: Process | None = None
        self.files: list[str] | None = None
        self.file = ""
        """The chosen file, as the process loaded it."""
        self.file_shown: list[str] = []
        self.file_highlight = 0
        """The highlighted file (Enter takes it)."""
        self.source: Source | None = None
        self.line: int | None = None
        self.names: Names | None = None
        self.line_error = ""
        self.completion: list[str] = []
        self.highlight = 0
        """The highlighted completion (Enter takes it)."""
        self._asks: dict[str, _Ask] = {}
        self._typed_file = ""
        self._typed_expr = ""
        self._typed_when = ""
        self._scroll_to: int | None = None
        self._enter_held = False
        """An Enter was taken and the key has not been seen up since (its repeats are dropped)."""
        self._rows: dict[int, int | str] = {}
        self._chosen_theme = _chosen_row_theme()
        self._build()
        # Placed once, high enough for its tallest state (a file's list, or the completions, and a note),
        # so that it never moves under the pointer as its lists come and go.
        x, y = dpg.get_item_pos(self.window)
        room = (dpg.get_viewport_client_height() or 800) - TALLEST_H - 8
        dpg.configure_item(self.window, pos=(x, max(0, min(y, room))))
        self._show_processes()

    # -- building -------------------------------------------------------------------------------------------

    def _build(self) -> None:
        w = self.window
        dpg.add_text("Process", color=DIM, parent=w)
        self.proc_note = dpg.add_text("", parent=w, wrap=750)
        # Three rows whatever the count: a process coming or going never moves what is under the pointer.
        self.proc_box = dpg.add_group(parent=w)  # (a group reports its rectangle; the list itself, none)
        self.proc_list = dpg.add_child_window(height=_rows_h(3), width=-1, parent=self.proc_box)
        with dpg.group(horizontal=True, parent=w):
            dpg.add_text("File", color=DIM)
            self.file_note = dpg.add_text("", color=DIM)
            self.every_box = dpg.add_checkbox(
                label="libraries too", callback=lambda *_: self._record("every", None)
            )
        self.file_input = dpg.add_input_text(
            width=-1,
            hint="type part of a file name, e.g. controller.py",
            parent=w,
            on_enter=True,
            callback=lambda *_: self._record("file_enter", None),
        )
        self.file_list = dpg.add_child_window(height=_rows_h(1), width=-1, parent=w)
        with dpg.group(horizontal=True, parent=w):
            dpg.add_text("Line", color=DIM)
            self.line_input = dpg.add_input_text(
                width=110,
                hint="number",
                decimal=True,
                on_enter=True,
                callback=lambda *_: self._record("line_enter", None),
            )
            self.source_note = dpg.add_text("choose a file: its source shows here", color=DIM)
        # In a group: a child window reports no rectangle of its own, a group does (the wheel goes there).
        self.source_box = dpg.add_group(parent=w)
        self.source_view = dpg.add_child_window(
            height=250, width=-1, parent=self.source_box, horizontal_scrollbar=True
        )
        self._code_theme = _code_theme()
        dpg.bind_item_theme(self.source_view, self._code_theme)
        if self.code_font is not None:
            dpg.bind_item_font(self.source_view, self.code_font)
        with dpg.group(horizontal=True, parent=w):
            dpg.add_text("Expression", color=DIM)
            self.names_note = dpg.add_text("", color=DIM)
        self.expr_input = dpg.add_input_text(
            width=-1,
            hint="a name, attribute or item at that line: speed, self.pose.x, ranges[0]",
            parent=w,
            on_enter=True,
            callback=lambda *_: self._record("expr_enter", None),
        )
        self.completion_list = dpg.add_child_window(height=_rows_h(1), width=-1, parent=w, show=False)
        self.expr_note = dpg.add_text("", parent=w, wrap=750)
        with dpg.group(horizontal=True, parent=w):
            dpg.add_text("Show as", color=DIM)
            self.show_as = dpg.add_radio_button(
                [label for _type, label in SHOW_AS], default_value=SHOW_AS[0][1], horizontal=True
            )
            dpg.add_text("  only when", color=DIM)
            self.when_input = dpg.add_input_text(  # a conditional breakpoint's condition
                width=-1,
                hint="every hit",
                on_enter=True,
                callback=lambda *_: self._record("when_enter", None),
            )
        self.error_text = dpg.add_text("", color=ERROR_COLOR, parent=w, wrap=750, show=False)
        dpg.add_spacer(height=4, parent=w)
        with dpg.group(horizontal=True, parent=w):
            self.ok_button = dpg.add_button(
                label="Watch", width=100, enabled=False, callback=lambda *_: self._record("ok", None)
            )
            dpg.add_button(label="Cancel", width=100, callback=lambda *_: self._record("cancel", None))
        self._list_theme = _list_theme()
        for listing in (self.proc_list, self.file_list, self.completion_list):
            dpg.bind_item_theme(listing, self._list_theme)
        self._button_theme = _button_theme()
        dpg.bind_item_theme(self.ok_button, self._button_theme)

    # -- each frame -----------------------------------------------------------------------------------------

    def news(self) -> bool:
        """Whether an answer came or the processes changed since the last frame (a frame should show it)."""
        if any(ask.future.done() for ask in self._asks.values()):
            return True
        return _rows_of(self.queries.processes()) != _rows_of(self.procs)

    def tick(self) -> None:
        """Take the answers that came and what was clicked or typed; keep every part's note current."""
        super().tick()
        for what, value in self._take_events():
            if self.closed:
                return
            if what in _ENTERS:
                if self._enter_held:  # Dear ImGui repeats a held Enter (or one a slow frame kept down)
                    after = {"file_enter": self.line_input, "when_enter": self.when_input}
                    self.focus_soon(after.get(what, self.expr_input))  # where the Enter taken sent it
                    continue
                self._enter_held = True
            self._on(what, value)
        if self.closed:
            return
        self._enter_held = self._enter_held and dpg.is_key_down(dpg.mvKey_Return)
        self._show_processes()
        self._take_answers()
        typed = str(dpg.get_value(self.file_input))
        if typed != self._typed_file:
            self._typed_file = typed
            self._show_files()
        expr = str(dpg.get_value(self.expr_input))
        if expr != self._typed_expr:
            self._typed_expr = expr
            self._show_completions()
            self._check()
        when = str(dpg.get_value(self.when_input))
        if when != self._typed_when:
            self._typed_when = when
            self._check()
        if self._scroll_to is not None:
            self._scroll()

    def _on(self, what: str, value: object) -> None:
        if what == "process" and isinstance(value, str):
            self.choose_process(value)
        elif what == "file" and isinstance(value, str):
            self.choose_file(value)
        elif what == "file_enter":
            if self.file_shown:
                self.choose_file(self.file_shown[min(self.file_highlight, len(self.file_shown) - 1)])
        elif what == "every":
            self._ask_files()
        elif what == "line" and isinstance(value, int):
            self.choose_line(value)
        elif what == "line_enter":
            typed = str(dpg.get_value(self.line_input)).strip()
            if typed.isdigit():
                self.choose_line(int(typed))
        elif what == "name" and isinstance(value, str):
            self.take_completion(value)
        elif what == "expr_enter":
            self.enter()
        elif what in ("ok", "when_enter"):
            self.apply()
        elif what == "cancel":
            self.close()

    # -- the process ----------------------------------------------------------------------------------------

    def _show_processes(self) -> None:
        procs = self.queries.processes()
        if _rows_of(procs) != _rows_of(self.procs):  # one came or went, or one's name changed (its node came)
            self.procs = procs
            if self.process is not None:
                self.process = next((p for p in procs if p.agent == self.process.agent), self.process)
            dpg.delete_item(self.proc_list, children_only=True)
            for p in procs:
                dpg.add_selectable(
                    label=process_label(p),
                    parent=self.proc_list,
                    default_value=self.process is not None and p.agent == self.process.agent,
                    callback=lambda *_, a=p.agent: self._record("process", a),
                )
        if self.process is None and len(self.procs) == 1 and not self.queries.discovering():
            self.choose_process(self.procs[0].agent)  # the only one, once no other may still come
        note, color = self._process_note()
        if dpg.get_value(self.proc_note) != note:
            dpg.set_value(self.proc_note, note)
            dpg.configure_item(self.proc_note, color=color)

    def _process_note(self) -> tuple[str, tuple[int, ...]]:
        q = self.queries
        if q.failure:
            return q.failure, ERROR_COLOR
        if not q.ready:
            return "Starting the watch client\u2026", _WAITING
        if not self.procs:
            if q.discovering():
                return "Looking for watchable processes\u2026", _WAITING
            return (
                "No watchable process. A Python program is watchable when started with "
                "dbglog run SCRIPT (or -m MODULE), or with DBGLOG_WATCH=1 when it imports dbglog.",
                _WAITING,
            )
        if self.process is not None and all(p.agent != self.process.agent for p in self.procs):
            return f"{self.process.name} (pid {self.process.pid}) exited: choose a process", ERROR_COLOR
        if self.process is None:
            return f"{len(self.procs)} watchable processes: choose one", DIM
        return f"watching in {self.process.name} (pid {self.process.pid})", DIM

    def choose_process(self, agent: str) -> None:
        """Take a process (as clicking it does) and ask for its files."""
        found = next((p for p in self.procs if p.agent == agent), None)
        if found is None:
            return
        for child, p in zip(dpg.get_item_children(self.proc_list, 1) or [], self.procs, strict=False):
            dpg.set_value(child, p.agent == agent)  # a click on the chosen row keeps it chosen
        if self.process is not None and found.agent == self.process.agent:
            self.focus_soon(self.file_input)
            return
        self.process = found
        self._ask_files()
        if self.file:
            self.choose_file(self.file)  # the same file in the restarted program, say
        self.focus_soon(self.file_input)

    # -- the file -------------------------------------------------------------------------------------------

    def _ask_files(self) -> None:
        """Ask the process for its files: those of the user's tree, or every one (libraries too)."""
        if self.process is None:
            return
        self.files = None
        everything = bool(dpg.get_value(self.every_box))
        self._ask("files", self.queries.files(self.process, everything=everything), self.process.agent)
        self._show_files()

    def _show_files(self) -> None:
        if self.process is None:
            note = "choose a process first"
        elif self.files is None:
            note = "reading the files the process loaded\u2026"
        else:
            count, whose = len(self.files), "" if dpg.get_value(self.every_box) else " of your code"
            note = f"{count} file{'' if count == 1 else 's'}{whose} loaded by {self.process.name}"
        dpg.set_value(self.file_note, note)
        shown = file_suggestions(self.files or [], self._typed_file)
        picked = bool(self.file) and self._typed_file == self.file
        if shown == self.file_shown and dpg.get_item_children(self.file_list, 1):
            dpg.configure_item(self.file_list, show=not picked)
            return
        self.file_shown = shown
        self.file_highlight = 0
        dpg.delete_item(self.file_list, children_only=True)
        picked = bool(self.file) and self._typed_file == self.file
        dpg.configure_item(self.file_list, height=_rows_h(min(5, max(1, len(shown)))), show=not picked)
        for i, path in enumerate(shown):
            dpg.add_selectable(
                label=f"{os.path.basename(path)}    {os.path.dirname(path)}",
                parent=self.file_list,
                default_value=i == 0,
                callback=lambda *_, f=path: self._record("file", f),
            )
        if self.files is not None and not shown:
            dpg.add_text("no loaded file matches", color=DIM, parent=self.file_list)

    def choose_file(self, path: str) -> None:
        """Take a file (as clicking it in the list does) and ask for its source."""
        if self.process is None:
            return
        changed = path != self.file
        self.file = path
        dpg.set_value(self.file_input, path)
        self._typed_file = path
        self._show_files()
        if changed:
            self.line, self.names, self.line_error = None, None, ""
            dpg.set_value(self.line_input, "")
        self._ask_source(self.line or 1)
        self.focus_soon(self.line_input)

    # -- the line -------------------------------------------------------------------------------------------

    def _ask_source(self, line: int) -> None:
        if self.process is None:
            return
        dpg.set_value(self.source_note, f"reading {os.path.basename(self.file)} from the process\u2026")
        dpg.configure_item(self.source_note, color=_WAITING)
        future = self.queries.source(self.process, self.file, line, context=CONTEXT_LINES)
        self._ask("source", future, (self.process.agent, self.file, line))

    def _show_source(self) -> None:
        source = self.source
        dpg.delete_item(self.source_view, children_only=True)
        self._rows = {}
        if source is None:
            return
        last = source.first + len(source.lines) - 1
        dpg.set_value(
            self.source_note,
            f"{os.path.basename(source.path)}: lines {source.first}\u2013{last} of {source.total}"
            + ("" if (source.first, last) == (1, source.total) else " (type a line number for others)")
            + "; click the line to watch",
        )
        dpg.configure_item(self.source_note, color=DIM)
        width = len(str(last))
        for number, text in enumerate(source.lines, source.first):
            self._rows[number] = dpg.add_selectable(
                label=source_row(number, text, width),
                parent=self.source_view,
                default_value=number == self.line,
                callback=lambda *_, n=number: self._record("line", n),
            )
            if number == self.line:
                dpg.bind_item_theme(self._rows[number], self._chosen_theme)

    def choose_line(self, line: int) -> None:
        """Take a line (as clicking it does): highlight it and ask which names the code there reads."""
        if self.process is None or not self.file or line < 1:
            return
        self.line = line
        dpg.set_value(self.line_input, str(line))
        source = self.source
        inside = source is not None and source.first <= line < source.first + len(source.lines)
        if inside:
            for number, row in self._rows.items():
                dpg.set_value(row, number == line)
                dpg.bind_item_theme(row, self._chosen_theme if number == line else 0)
        else:
            self._ask_source(line)
        self._scroll_to = line
        self.names, self.line_error = None, ""
        dpg.set_value(self.names_note, f"reading the names at line {line}\u2026")
        dpg.configure_item(self.names_note, color=_WAITING)
        self._ask("names", self.queries.names(self.process, self.file, line), (self.file, line))
        self._show_completions()
        self._check()
        self.focus_soon(self.expr_input)

    def _scroll(self) -> None:
        """Bring the chosen line into view, a few lines from the top (once its row has been laid out)."""
        line = self._scroll_to
        row = self._rows.get(line) if line is not None else None
        if row is None or self.source is None:
            return
        first = dpg.get_item_state(next(iter(self._rows.values())))
        state = dpg.get_item_state(row)
        if not state.get("rect_size", (0, 0))[1] and line != self.source.first:
            return  # not laid out yet
        y0, y1 = first.get("pos", (0, 0))[1], state.get("pos", (0, 0))[1]
        dpg.set_y_scroll(self.source_view, max(0.0, float(y1 - y0) - 80.0))
        self._scroll_to = None

    # -- the expression -------------------------------------------------------------------------------------

    def _show_completions(self) -> None:
        names = completions(self.names, self._typed_expr)
        token = typed_token(self._typed_expr)
        if names == [token]:
            names = []  # typed in full: nothing to complete
        self.completion = names
        self.highlight = 0
        dpg.delete_item(self.completion_list, children_only=True)
        dpg.configure_item(self.completion_list, height=_rows_h(min(4, len(names))), show=bool(names))
        local = set(self.names.locals) if self.names is not None else set()
        for i, name in enumerate(names):
            dpg.add_selectable(
                label=f"{name}    {'local' if name in local else 'global'}",
                parent=self.completion_list,
                default_value=i == 0,
                callback=lambda *_, n=name: self._record("name", n),
            )

    def move_highlight(self, step: int) -> None:
        """Up/Down: highlight the previous/next file or completion, whichever field is typed in (Enter
        takes it)."""
        if dpg.is_item_active(self.file_input) and self.file_shown:
            self.file_highlight = max(0, min(len(self.file_shown) - 1, self.file_highlight + step))
            _highlight(self.file_list, self.file_highlight)
        elif self.completion:
            self.highlight = max(0, min(len(self.completion) - 1, self.highlight + step))
            _highlight(self.completion_list, self.highlight)

    def take_completion(self, name: str) -> None:
        """Complete the name typed last with `name` (as clicking it does)."""
        text = complete(str(dpg.get_value(self.expr_input)), name)
        dpg.set_value(self.expr_input, text)
        self._typed_expr = text
        self._show_completions()
        self._check()
        self.focus_soon(self.expr_input)

    def enter(self) -> None:
        """Enter in the expression: take the highlighted completion, or with the name complete, OK."""
        if self.completion and typed_token(self._typed_expr) != self.completion[self.highlight]:
            self.take_completion(self.completion[self.highlight])
            return
        if not self.apply():
            self.focus_soon(self.expr_input)

    def _check(self) -> bool:
        ok, text = expression_check(self._typed_expr)
        color = OK_COLOR if ok else ERROR_COLOR if self._typed_expr else DIM
        unknown = unknown_names(self._typed_expr, self.names) if ok else []
        if self.completion:  # the name being typed is still being completed
            unknown = [name for name in unknown if name != typed_token(self._typed_expr)]
        when_ok, when_text = condition_check(self._typed_when)
        if ok and not when_ok:
            ok, text, color = False, when_text, ERROR_COLOR
        elif ok:
            unknown += [n for n in unknown_names(self._typed_when, self.names) if n not in unknown]
        if unknown:  # allowed (a global may be made later), but it would say "expr error" now
            color = _WAITING
            text = (
                f"{', '.join(unknown)}: no such name at line {self.line} now (a local or a global of its "
                "code); the widget says 'expr error' while there is none"
            )
        dpg.set_value(self.expr_note, text)
        dpg.configure_item(self.expr_note, color=color)
        ready = ok and self.plan() is not None
        dpg.configure_item(self.ok_button, enabled=ready)
        if ready:
            self._error("")
        return ready

    def _error(self, text: str) -> None:
        """Say what stops OK above the buttons (nothing: the line goes)."""
        dpg.set_value(self.error_text, text)
        dpg.configure_item(self.error_text, show=bool(text))

    # -- answers --------------------------------------------------------------------------------------------

    def _ask(self, what: str, future: Future[Any], about: object) -> None:
        self._asks[what] = _Ask(future, about)

    def _take_answers(self) -> None:
        for what, ask in list(self._asks.items()):
            got = ask.answer()
            if got is None:
                continue
            del self._asks[what]
            value, error = got
            if what == "files":
                self._take_files(value, error, ask.about)
            elif what == "source":
                self._take_source(value, error, ask.about)
            elif what == "names":
                self._take_names(value, error, ask.about)

    def _take_files(self, value: object, error: BaseException | None, about: object) -> None:
        if self.process is None or about != self.process.agent:
            return
        if error is not None:
            self.files = []
            self._error(f"cannot list the process's files: {error}")
        else:
            self.files = [str(f) for f in value] if isinstance(value, list) else []
        self._show_files()

    def _take_source(self, value: object, error: BaseException | None, about: object) -> None:
        if error is not None:
            dpg.set_value(self.source_note, f"cannot read the source: {error}")
            dpg.configure_item(self.source_note, color=ERROR_COLOR)
            return
        if isinstance(value, Source):
            self.source = value
            self._show_source()
            if self.line is not None:
                self._scroll_to = self.line

    def _take_names(self, value: object, error: BaseException | None, about: object) -> None:
        if about != (self.file, self.line):
            return
        if isinstance(error, WatchError) and error.state == "no_line":
            self.names, self.line_error = None, f"Line {self.line} has no code: click a line with code."
            dpg.set_value(self.names_note, self.line_error)
            dpg.configure_item(self.names_note, color=ERROR_COLOR)
        elif error is not None:
            self.names, self.line_error = None, f"cannot read the names at line {self.line}: {error}"
            dpg.set_value(self.names_note, self.line_error)
            dpg.configure_item(self.names_note, color=ERROR_COLOR)
        elif isinstance(value, Names):
            self.names, self.line_error = value, ""
            where = f"{os.path.basename(self.file)}:{self.line}"
            dpg.set_value(
                self.names_note,
                f"at {where}: {len(value.locals)} local and {len(value.globals)} global names",
            )
            dpg.configure_item(self.names_note, color=DIM)
        self._show_completions()
        self._check()

    # -- OK -------------------------------------------------------------------------------------------------

    def plan(self) -> WatchPlan | None:
        """What OK would add, or None (no process, file, line with code, or expression yet)."""
        expr = self._typed_expr.strip()
        if self.process is None or not self.file or self.line is None or self.names is None or not expr:
            return None
        label = str(dpg.get_value(self.show_as))
        type_name = next((t for t, lab in SHOW_AS if lab == label), SHOW_AS[0][0])
        node = self.process.nodes[0] if self.process.nodes else ""
        when = self._typed_when.strip()
        return WatchPlan(type_name, expr, WatchConfig(self.file, self.line, (expr,), node=node, when=when))

    def apply(self) -> bool:
        """Add the widget and close; False (and why) while something is missing or refused."""
        ok, text = expression_check(self._typed_expr)
        if ok:
            ok, text = condition_check(self._typed_when)
        plan = self.plan() if ok else None
        if plan is None:
            self._error(text if not ok and self.names is not None else _missing_step(self))
            return False
        self.on_ok(plan)
        self.close()
        return True

    def close(self) -> None:
        """Remove the dialog (answers still on their way are dropped)."""
        super().close()
        for theme in (self._chosen_theme, self._code_theme, self._list_theme, self._button_theme):
            if dpg.does_item_exist(theme):
                dpg.delete_item(theme)


def _rows_of(procs: Sequence[Process]) -> list[tuple[str, str]]:
    """The process list as shown: each process's agent and label."""
    return [(p.agent, process_label(p)) for p in procs]


def _missing_step(dialog: WatchDialog) -> str:
    """What the dialog still needs before OK, in the order a person gives it."""
    if dialog.process is None:
        return "choose a process"
    if not dialog.file:
        return "choose a file"
    if dialog.line is None:
        return "click the line to watch"
    if dialog.names is None:
        return dialog.line_error or "reading the names at that line…"
    return "type an expression"


def _highlight(listing: int | str, index: int) -> None:
    """Select row `index` of a list of selectables (and no other)."""
    for i, row in enumerate(dpg.get_item_children(listing, 1) or []):
        dpg.set_value(row, i == index)


def _rows_h(rows: int) -> int:
    """The height of a list of `rows` rows (and its padding)."""
    return rows * ROW_H + 14


def _code_theme() -> int | str:
    """The source's rows close together, as an editor shows them; the row under the pointer barely lit."""
    with dpg.theme() as theme, dpg.theme_component(dpg.mvAll):
        dpg.add_theme_style(dpg.mvStyleVar_ItemSpacing, 8, 1)
        dpg.add_theme_color(dpg.mvThemeCol_HeaderHovered, (46, 52, 64, 255))
        dpg.add_theme_color(dpg.mvThemeCol_HeaderActive, (52, 96, 150, 255))
    result: int | str = theme
    return result


def _list_theme() -> int | str:
    """A list's rows close together."""
    with dpg.theme() as theme, dpg.theme_component(dpg.mvAll):
        dpg.add_theme_style(dpg.mvStyleVar_ItemSpacing, 8, 3)
    result: int | str = theme
    return result


def _button_theme() -> int | str:
    """A button that cannot be pressed yet looks it: its text dim."""
    with dpg.theme() as theme, dpg.theme_component(dpg.mvButton, enabled_state=False):
        dpg.add_theme_color(dpg.mvThemeCol_Text, DIM)
        dpg.add_theme_color(dpg.mvThemeCol_ButtonHovered, (48, 53, 64, 255))
        dpg.add_theme_color(dpg.mvThemeCol_ButtonActive, (48, 53, 64, 255))
    result: int | str = theme
    return result


def _chosen_row_theme() -> int | str:
    """The chosen line's highlight: the accent blue behind the whole row."""
    with dpg.theme() as theme, dpg.theme_component(dpg.mvSelectable):
        dpg.add_theme_color(dpg.mvThemeCol_Header, (52, 96, 150, 255))
        dpg.add_theme_color(dpg.mvThemeCol_HeaderHovered, (62, 110, 170, 255))
    result: int | str = theme
    return result
