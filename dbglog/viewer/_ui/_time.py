"""Time control of the viewer: the cursor (live, paused, playing), its speed and loop, stepping, and the
keys and buttons that drive it, as named actions. Plain Python over a `Timeline`: no Dear PyGui.

The window hands it the few things it needs (`StepScope`: which series the arrow keys step through; a
way to show a message) and binds the timeline bar's buttons and the keys to its actions by name.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Protocol

from dbglog.viewer._data._model import Binding, DataSource
from dbglog.viewer._data._timeline import Timeline, TimeSource
from dbglog.viewer._ui._actions import Actions
from dbglog.viewer.widget_api import TimeRange

__all__ = ["KEYS_HINT", "StepScope", "TimeControl"]

KEYS_HINT = (
    ("time.toggle_live", "pause/resume"),
    ("time.previous", "previous"),
    ("time.next", "next message"),
    ("time.back", "\u22121 s"),
    ("time.ahead", "+1 s"),
    ("time.newest", "live"),
    ("time.oldest", "oldest"),
)
"""The time keys the timeline bar's tooltip lists: (action, what it is called there)."""


class StepScope(Protocol):
    """The series the time keys work on: the selected widget's, or every widget's."""

    def step_series(self, *, all_widgets: bool = False) -> list[Binding]:
        """The selected widget's series (if it has any and `all_widgets` is False), else every widget's."""
        ...

    def step_owner(self) -> str | None:
        """The name of the selected widget when it has series (messages name it), else None."""
        ...


class TimeControl:
    """Everything about the time cursor: live, pause, seek, play, speed, loop, step, and the data source.

    Args:
        timeline: the window's time cursor over its data source.
        scope: which series the arrow keys step through.
        say: shows a message in the status bar.
        time_range: the range the time plots share (End makes them follow the newest data again).
        clock: wall clock (epoch seconds) for a pause with nothing held; monotonic clock for the span cache.
    """

    def __init__(
        self,
        timeline: Timeline,
        scope: StepScope,
        say: Callable[[str], None],
        time_range: TimeRange,
        *,
        clock: Callable[[], float] = time.time,
        ticks: Callable[[], float] = time.monotonic,
    ) -> None:
        self.timeline = timeline
        self.scope = scope
        self.say = say
        self.time_range = time_range
        self._clock, self._ticks = clock, ticks
        self._fallback_span: tuple[float, float] | None = None
        self._span_checked = -1.0
        self.source_changes = 0
        """How many times `use_source` swapped the data source (the status bar starts its figures over)."""

    # -- state ----------------------------------------------------------------------------------------

    @property
    def source(self) -> DataSource:
        """The data source shown (the live engine, or a recording)."""
        return self.timeline.source

    @property
    def live(self) -> bool:
        """Whether the widgets follow the newest data (not paused at a moment of the past)."""
        return self.timeline.live

    @property
    def replay_name(self) -> str | None:
        """The recording shown (its file name), or None for a live source."""
        if not self.timeline.recording:
            return None
        return Path(str(getattr(self.source, "name", "recording"))).name

    def time_span(self) -> tuple[float, float] | None:
        """Return the (oldest, newest) source time the dashboard can show, None while nothing is held.

        The source's history when it has one (`TimeSource`), else what the widgets' series hold.
        """
        if isinstance(self.source, TimeSource):
            return self.timeline.span()
        now = self._ticks()
        if now - self._span_checked >= 0.1:
            self._span_checked = now
            self._fallback_span = self._series_span()
        return self._fallback_span

    def _series_span(self) -> tuple[float, float] | None:
        lo, hi = math.inf, -math.inf
        for binding in self.scope.step_series(all_widgets=True):
            snap = self.source.snapshot(binding)
            if len(snap.times):
                lo, hi = min(lo, float(snap.times[0])), max(hi, float(snap.times[-1]))
            elif snap.last_time is not None:
                lo, hi = min(lo, snap.last_time), max(hi, snap.last_time)
        return (lo, hi) if hi >= lo else None

    # -- commands -------------------------------------------------------------------------------------

    def pause(self, at: float | None = None) -> None:
        """Hold every widget at source time `at` (default: the newest sample held)."""
        if at is None:
            span = self.time_span()
            at = span[1] if span is not None else self._clock()
        self.seek(at)

    def seek(self, t: float) -> None:
        """Move the time cursor to `t` (pausing), kept within the span held."""
        span = self.time_span()
        if span is not None:
            t = min(max(t, span[0]), span[1])
        self.timeline.seek(t)

    def go_live(self) -> None:
        """Follow the newest data again (a recording: go to its end, paused)."""
        if self.timeline.recording:
            span = self.time_span()
            self.timeline.pause()
            if span is not None:
                self.timeline.seek(span[1])
            return
        self.timeline.resume()

    def toggle_live(self) -> None:
        """Pause at the newest sample, or go back to live; a recording, or playback: play or pause."""
        if self.timeline.recording or self.timeline.playing:
            self.toggle_play()
        elif self.live:
            self.pause()
        else:
            self.go_live()

    def toggle_play(self) -> None:
        """Play from the cursor, or pause playback (live: from a paused cursor, until it catches up)."""
        timeline = self.timeline
        if timeline.playing:
            timeline.pause()
        elif timeline.recording or not timeline.live:
            timeline.play()
        else:
            self.say("pause or click on the timeline first: playback starts from the cursor")

    def set_speed(self, speed: float) -> None:
        """Set the playback speed (`Timeline.SPEEDS`)."""
        self.timeline.set_speed(speed)
        self.say(f"playback speed {speed:g}\u00d7")

    def toggle_loop(self) -> None:
        """Switch looping (a recording plays again from its start at the end) on or off."""
        self.timeline.loop = not self.timeline.loop
        self.say("loop on: playback starts again at the end" if self.timeline.loop else "loop off")

    def shift_time(self, seconds: float) -> None:
        """Move the cursor `seconds` later (negative: earlier), pausing first when live."""
        if self.timeline.cursor is None:
            self.pause()
        assert self.timeline.cursor is not None
        self.seek(self.timeline.cursor + seconds)

    def step_time(self, direction: int) -> bool:
        """Move the cursor to the previous (-1) or next (+1) message of the step series; False if none."""
        bindings = self.scope.step_series()
        if self.timeline.cursor is None:
            self.pause()
        if not bindings or not self.timeline.step(bindings, direction):
            whose = self.scope.step_owner() or "any widget"
            self.say(f"no {'earlier' if direction < 0 else 'later'} message of {whose}")
            return False
        return True

    def newest(self) -> None:
        """End: back to live (a recording: to its end); plots follow the newest data again."""
        self.go_live()
        self.time_range.go_live()

    def oldest(self) -> None:
        """Home: to the oldest moment held (a recording's start), paused."""
        span = self.time_span()
        if span is not None:
            self.timeline.pause()
            self.seek(span[0])

    def use_source(self, source: DataSource, *, recording: bool, bound: Sequence[Binding]) -> None:
        """Show `source` in place of the current data source: a recording opened, or live again.

        Every binding in `bound` moves to it (widgets keep their bindings, fields, regex and transforms); a
        recording opens paused at its end, a live source live.
        """
        old = self.source
        for binding in bound:
            old.unbind(binding)
        timeline = self.timeline
        timeline.source = source
        timeline.recording = recording
        timeline.loop = False
        timeline.stale_after = float(getattr(source, "stale_after", timeline.stale_after))
        timeline.resume()
        for binding in bound:
            source.bind(binding)
        if recording:
            timeline.pause()
        self._fallback_span, self._span_checked = None, -1.0
        self.source_changes += 1

    # -- the commands as actions ----------------------------------------------------------------------

    def register(self, actions: Actions) -> None:
        """Register the time commands and their keys (the keys act on the canvas: not while typing)."""
        add = actions.register
        add(
            "time.toggle_live",
            "Pause",
            "Pause at the newest sample, or back to live; a recording: play or pause",
            self.toggle_live,
            keys=("Space",),
            scope="canvas",
            repeat=False,
        )
        add(
            "time.previous",
            "Previous message",
            "The previous message of the selected widget (or any)",
            lambda: self.step_time(-1),
            keys=("Left",),
            scope="canvas",
        )
        add(
            "time.next",
            "Next message",
            "The next message of the selected widget (or any)",
            lambda: self.step_time(1),
            keys=("Right",),
            scope="canvas",
        )
        for name, label, seconds, key in (
            ("time.back", "Back 1 s", -1.0, "Left"),
            ("time.ahead", "Ahead 1 s", 1.0, "Right"),
        ):
            add(
                name,
                label,
                f"One second {'earlier' if seconds < 0 else 'later'}",
                functools.partial(self.shift_time, seconds),
                keys=(f"Shift+{key}",),
                scope="canvas",
            )
        add(
            "time.newest",
            "Live",
            "Back to live (a recording: its end); plots follow the newest data again",
            self.newest,
            keys=("End",),
            scope="canvas",
        )
        add(
            "time.oldest",
            "Oldest",
            "To the oldest moment held (a recording's start), paused",
            self.oldest,
            keys=("Home",),
            scope="canvas",
        )
        add("time.play", "Play", "Play from the cursor, or pause playback", self.toggle_play)
        add(
            "time.loop",
            "Loop",
            "Play a recording again from its start at the end",
            self.toggle_loop,
            checked=lambda: self.timeline.loop,
        )
