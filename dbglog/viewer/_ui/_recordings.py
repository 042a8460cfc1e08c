"""File menu commands for recordings and exports: Open recording, Save history as recording, Export CSV.

Each opens the viewer's own file dialog (`SaveAsDialog`: a name filled in, the extension added once, asks
before replacing); the reading or writing then runs on a worker thread (the history is read without locks,
docs/history.md) while the window keeps drawing, and the result comes back on the UI thread through a frame
hook: the recording replaces the data source (`TimeControl.use_source`), a file written is named in the
status bar, and what went wrong is said in the dialog, never as a traceback.

Opening a recording swaps the data source inside this window rather than starting another viewer: the
dashboard, its bindings and the time bar stay, and File > Back to live returns to the live engine, which
kept recording its history meanwhile.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Generic, TypeVar

import dearpygui.dearpygui as dpg

from dbglog._ros._markers import MARKER_TOPIC, MARKER_TYPE
from dbglog.record import RecordingError
from dbglog.viewer._data._events import unsaved_markers
from dbglog.viewer._data._export import ExportError, export_csv, save_recording
from dbglog.viewer._data._model import Binding, DataSource
from dbglog.viewer._data._replay import ReplaySource, load_replay
from dbglog.viewer._publishing._republish import Republisher
from dbglog.viewer._ui._actions import Actions
from dbglog.viewer._ui._canvas import Canvas
from dbglog.viewer._ui._dialogs import SaveAsDialog
from dbglog.viewer._ui._modal import Dialogs
from dbglog.viewer._ui._theme import DIM
from dbglog.viewer._ui._time import TimeControl
from dbglog.viewer._ui._timescale import format_clock, format_duration

__all__ = ["ExportRange", "RecordingCommands", "default_name", "import_ros", "plot_window"]

T = TypeVar("T")


@dataclass(frozen=True, slots=True)
class ExportRange:
    """A choice of source times to save or export, with how the dialog words it."""

    t0: float
    t1: float
    what: str
    """e.g. ``Everything held``, ``What the plots show``."""
    whole: bool = False
    """Everything held when the file is written (what arrives while the dialog is open too)."""

    @property
    def bounds(self) -> tuple[float, float]:
        """The times to write: open-ended for `whole`."""
        return (-math.inf, math.inf) if self.whole else (self.t0, self.t1)

    @property
    def label(self) -> str:
        """The choice as the dialog lists it: what, how long, from when to when."""
        return (
            f"{self.what}: {format_duration(self.t1 - self.t0)}, "
            f"{format_clock(self.t0, millis=False)} to {format_clock(self.t1, millis=False)}"
        )


def plot_window(window_s: float, cursor: float | None, newest: float | None) -> tuple[float, float] | None:
    """Return the time range a plot shows: `window_s` seconds up to the cursor (live: its newest sample)."""
    end = cursor if cursor is not None else newest
    if end is None or not math.isfinite(window_s) or window_s <= 0:
        return None
    return end - window_s, end


def _visible_range(widget: object) -> tuple[float, float] | None:
    """The source times a plot widget shows, when it tells them (`visible_range`), else None."""
    ask = getattr(widget, "visible_range", None)
    if not callable(ask):
        return None
    try:
        shown = ask()
    except Exception:  # a widget's bug never stops an export: the plot's window is used instead
        return None
    if isinstance(shown, tuple) and len(shown) == 2 and all(isinstance(t, float | int) for t in shown):
        return float(shown[0]), float(shown[1])
    return None


def import_ros() -> None:
    """Import rclpy (what a replay deserializes with) on this thread now, if it is installed.

    Without a live engine nothing has imported it yet, and two threads importing it at once (a replay
    filling a binding, the controls' publishing service starting) can meet Python's import deadlock
    check, which fails one of them.
    """
    try:
        import rclpy
        import rclpy.serialization  # noqa: F401
    except ImportError:  # a viewer without ROS: a recording's std_msgs numbers still play
        pass


def default_name(stem: str, extension: str, at: float | None = None) -> str:
    """Return a file name that says what and when: ``history-20250101-120304.mcap``."""
    return f"{stem}-{time.strftime('%Y%m%d-%H%M%S', time.localtime(at))}{extension}"


class _Job(Generic[T]):
    """A function run on a worker thread; `poll` it from the UI thread."""

    def __init__(self, work: Callable[[], T]) -> None:
        self.result: T | None = None
        self.error: Exception | None = None
        self.done = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(work,), name="dbglog-file-job", daemon=True)
        self._thread.start()

    def _run(self, work: Callable[[], T]) -> None:
        try:
            self.result = work()
        except Exception as exc:  # shown to the user by the caller (the dialog or the status bar)
            self.error = exc
        finally:
            self.done.set()


@dataclass
class _Pending:
    """A job and what to do with its outcome on the UI thread."""

    job: _Job[object]
    dialog: SaveAsDialog
    finish: Callable[[object], None]
    """Called with the job's result (the dialog is closed first)."""
    cancellable: bool = False
    """The result is dropped when the dialog was closed meanwhile (a recording loading: Cancel means no)."""


class RecordingCommands:
    """The File menu's recording and export entries of one window, and their dialogs.

    Args:
        time: the window's time control (the span held, the cursor, the data source).
        canvas: its widgets (what the plots show, the series to export).
        dialogs: its dialogs (each command opens one; one at a time).
        close_file_dialog: closes the dashboard file dialog (one modal at a time).
        use_source: shows another data source (a recording opened: True; live again: False).
        say: shows a message in the status bar.
        wake: renders frames soon (a worker thread's result is waited for by the frame loop).
    """

    def __init__(
        self,
        time: TimeControl,
        canvas: Canvas,
        dialogs: Dialogs,
        *,
        close_file_dialog: Callable[[], None],
        use_source: Callable[[DataSource, bool], None],
        say: Callable[[str], None],
        wake: Callable[[], None],
    ) -> None:
        self.time, self.canvas, self.dialogs = time, canvas, dialogs
        self._close_file_dialog, self._use_source = close_file_dialog, use_source
        self.say, self.wake = say, wake
        self.republisher: Republisher | None = None
        """``--republish``'s, set before the window starts: View \u203a Republish on ROS 2 switches it."""
        self.live_source: DataSource | None = None
        """The live source a recording opened from the menu replaced (File > Back to live returns to it)."""
        self.folder: Path | None = None
        """Where the last recording was opened or a file written (the dialogs start there)."""
        self._pending: _Pending | None = None
        self._choice: int | str | None = None
        self._ranges: list[ExportRange] = []

    # -- the commands -------------------------------------------------------------------------------

    def register(self, actions: Actions) -> None:
        """Register the File menu's recording commands (`poll` must run every frame: a frame hook)."""
        add = actions.register
        add("recording.open", "Open recording\u2026", "Replay an MCAP file in this window", self.ask_open)
        add(
            "recording.save",
            "Save history as recording\u2026",
            "Everything held, or what the plots show, as an MCAP file",
            self.ask_save_recording,
        )
        add("recording.export_csv", "Export CSV\u2026", "Every widget's series as CSV", self.ask_export_csv)
        add(
            "recording.back_to_live",
            "Back to live",
            "Show the live data again (the recording opened from the menu closes)",
            self.back_to_live,
            shown=lambda: self.live_source is not None,
        )
        add(
            "view.republish",
            "Republish on ROS 2",
            "The replay follows the cursor on the ROS 2 graph",
            self.toggle_republish,
            checked=lambda: self.republisher is not None and self.republisher.enabled,
            shown=lambda: self.republisher is not None,
        )

    def toggle_republish(self) -> None:
        """View \u203a Republish on ROS 2: the replay follows the cursor on the graph again, or stops."""
        if self.republisher is not None:
            on = not self.republisher.enabled
            self.republisher.set_enabled(on)
            self.say("republishing on ROS 2 at the cursor" if on else "republishing on ROS 2 stopped")

    # -- dialogs --------------------------------------------------------------------------------------

    def _start_folder(self) -> Path:
        if self.folder is not None and self.folder.is_dir():
            return self.folder
        path = self.canvas.doc.path
        return path.parent if path is not None else Path.cwd()

    def _dialog(
        self, title: str, name: str, extension: str, action: str, on_ok: Callable[[Path], object]
    ) -> SaveAsDialog:
        self.dialogs.close()
        self._close_file_dialog()
        dialog = SaveAsDialog(
            self._start_folder(),
            name,
            on_ok,
            self.dialogs.closed,
            title=title,
            extension=extension,
            action=action,
            opening=action == "Open",
        )
        return self.dialogs.open(dialog)

    def _range_options(self, dialog: SaveAsDialog, ranges: Sequence[ExportRange]) -> None:
        """Offer the time ranges as radio buttons (the first chosen) under the folder's entries."""
        self._ranges = list(ranges)
        group = dialog.show_options()
        dpg.add_text("Time range", color=DIM, parent=group)
        self._choice = dpg.add_radio_button(
            [r.label for r in ranges], default_value=ranges[0].label, parent=group
        )

    def chosen_range(self) -> ExportRange:
        """The time range ticked in the open dialog."""
        if self._choice is not None and dpg.does_item_exist(self._choice):
            label = str(dpg.get_value(self._choice))
            for r in self._ranges:
                if r.label == label:
                    return r
        return self._ranges[0]

    def _run(
        self,
        dialog: SaveAsDialog,
        note: str,
        work: Callable[[], object],
        finish: Callable[[object], None],
        *,
        cancellable: bool = False,
    ) -> None:
        """Start `work` on a worker thread; `poll` calls `finish` with its result, or shows its error."""
        if self._pending is not None and not self._pending.job.done.is_set():
            dialog.set_note("still busy with the last file: wait a moment", error=True)
            return
        dialog.set_note(note, error=False)
        dpg.configure_item(dialog.save_button, enabled=False)
        self._pending = _Pending(_Job(work), dialog, finish, cancellable)
        self.wake()

    def poll(self) -> None:
        """Frame hook: take a finished job's outcome (on the UI thread)."""
        pending = self._pending
        if pending is None or not pending.job.done.is_set():
            return
        self._pending = None
        dialog, job = pending.dialog, pending.job
        self.wake()
        if job.error is not None:
            message = (
                str(job.error) if isinstance(job.error, RecordingError | ExportError) else repr(job.error)
            )
            self.say(f"failed: {message}")
            if not dialog.closed:
                dpg.configure_item(dialog.save_button, enabled=True)
                dialog.set_note(message)
            else:
                self.dialogs.message("File error", message)
            return
        if dialog.closed and pending.cancellable:
            self.say("not opened: cancelled")
            return
        dialog.close()
        pending.finish(job.result)

    # -- Open recording -----------------------------------------------------------------------------

    def ask_open(self) -> SaveAsDialog:
        """File > Open recording…: choose an MCAP file (or a rosbag2 folder) to replay in this window."""
        dialog = self._dialog("Open recording", "", ".mcap", "Open", lambda p: self.open_path(p, dialog))
        return dialog

    def open_path(self, path: str | Path, dialog: SaveAsDialog | None = None) -> None:
        """Load the recording at `path` on a worker thread; replay it in this window once loaded."""
        target = Path(path)
        if dialog is None:
            dialog = self.ask_open()
            dpg.set_value(dialog.name_input, str(target))
        stale = float(getattr(self.time.source, "stale_after", 2.0))
        self.folder = target.parent if target.is_file() else target
        import_ros()
        self._run(
            dialog,
            f"loading {target.name}\u2026",
            lambda: load_replay(target, stale_after=stale),
            lambda replay: self._replay(replay),  # type: ignore[arg-type]
            cancellable=True,
        )

    def _replay(self, replay: ReplaySource) -> None:
        if not self.time.timeline.recording:
            self.live_source = self.time.source
        self._use_source(replay, True)
        name = Path(replay.name).name
        span = replay.time_span()
        length = format_duration(replay.duration) if span is not None else "no message"
        if replay.problems:
            self.dialogs.message(
                f"Problems in {name}", "\n".join(replay.problems) + "\n\nThe readable part plays."
            )
            self.say(f"replaying {name} ({length}); {len(replay.problems)} problem(s) with the file")
        else:
            self.say(f"replaying {name} ({length}): Space plays, the time bar seeks")

    def back_to_live(self) -> None:
        """File > Back to live: the live source a recording replaced shows again."""
        if self.live_source is None:
            return
        self._use_source(self.live_source, False)
        self.live_source = None
        self.say("live again")

    # -- Save history as recording ------------------------------------------------------------------

    def _ranges_now(self, *, selected_plot: bool) -> list[ExportRange] | None:
        """Everything held, then what the plots show (the selected plot's window, else every plot's)."""
        span = self.time.time_span()
        if span is None:
            return None
        out = [ExportRange(span[0], span[1], "Everything held", whole=True)]
        shown = self.plots_range(selected_only=selected_plot)
        if shown is not None:
            out.append(shown)
        return out

    def plots_range(self, *, selected_only: bool = False) -> ExportRange | None:
        """The time range the plots show (within the span held); only the selected plot's if asked."""
        timeline = self.time.timeline
        plots = [i for i in self.canvas.doc.items if i.config.type == "plot" and i.series]
        selected = self.canvas.selected
        what = "What the plots show"
        if selected_only and selected is not None and selected in plots:
            plots, what = [selected], f"The window of {selected.name!r}"
        span = self.time.time_span()
        lo, hi = math.inf, -math.inf
        for item in plots:
            shown = _visible_range(item.widget)  # a plot zoomed or panned says what it shows
            if shown is None:  # else: its time window, up to the cursor or its newest sample
                props = getattr(item.config, "properties", {})
                window = float(props.get("window", 10.0))
                newest = max(
                    (s.last_time for s in item.snapshots(timeline) if s.last_time is not None),
                    default=None,
                )
                shown = plot_window(window, timeline.cursor, newest)
            if shown is not None:
                lo, hi = min(lo, shown[0]), max(hi, shown[1])
        if hi < lo:
            return None
        if span is not None:
            lo, hi = max(lo, span[0]), min(hi, span[1])
        if timeline.cursor is not None:  # paused, a plot draws what had arrived by the cursor, no later
            hi = min(hi, timeline.cursor)
        return ExportRange(lo, hi, what) if hi >= lo else None

    def ask_save_recording(self) -> SaveAsDialog | None:
        """File > Save history as recording…: everything held, or what the plots show, as an MCAP file."""
        source = self.time.source
        store, types = getattr(source, "store", None), getattr(source, "held_types", None)
        if store is None or not callable(types):
            self.dialogs.message("Nothing to save", "This data source keeps no history to save.")
            return None
        ranges = self._ranges_now(selected_plot=False)
        if ranges is None:
            self.dialogs.message("Nothing to save", "The history is empty: nothing has arrived yet.")
            return None

        def save(path: Path) -> None:
            chosen = self.chosen_range()
            self.folder = path.parent
            held = dict(types())
            events = getattr(source, "events", None)
            markers = unsaved_markers(events(), store) if callable(events) else None
            extra = [(MARKER_TOPIC, MARKER_TYPE, *markers)] if markers is not None and markers[1] else []
            self._run(
                dialog,
                f"saving {path.name}\u2026",
                lambda: save_recording(
                    store, held, path, t0=chosen.bounds[0], t1=chosen.bounds[1], force=True, extra=extra
                ),
                lambda n: self.say(f"saved {n:,} messages ({chosen.what.lower()}) to {path}"),
            )

        dialog = self._dialog(
            "Save history as recording", default_name("history", ".mcap"), ".mcap", "Save", save
        )
        self._range_options(dialog, ranges)
        return dialog

    # -- Export CSV ---------------------------------------------------------------------------------

    def export_bindings(self) -> list[Binding]:
        """Every series a widget shows (each once, in the dashboard's order)."""
        return self.canvas.step_series(all_widgets=True)

    def ask_export_csv(self) -> SaveAsDialog | None:
        """File > Export CSV…: every widget's series between two times (the span held, or a plot's window)."""
        bindings = self.export_bindings()
        if not bindings:
            self.dialogs.message("Nothing to export", "No widget shows a series: bind one to a topic first.")
            return None
        ranges = self._ranges_now(selected_plot=True)
        if ranges is None:
            self.dialogs.message("Nothing to export", "The history is empty: nothing has arrived yet.")
            return None

        def export(path: Path) -> None:
            chosen = self.chosen_range()
            self.folder = path.parent
            timeline = self.time.timeline
            self._run(
                dialog,
                f"exporting {path.name}\u2026",
                lambda: export_csv(timeline, bindings, *chosen.bounds, path, force=True),
                lambda rows: self.say(f"exported {rows:,} rows of {len(bindings)} series to {path}"),
            )

        dialog = self._dialog("Export CSV", default_name("export", ".csv"), ".csv", "Export", export)
        self._range_options(dialog, ranges)
        return dialog
