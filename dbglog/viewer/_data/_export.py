"""What the viewer holds, written out: a time range of series as CSV, the history as an MCAP recording.

`export_csv` writes chosen bindings between two source times as one table: a ``time`` column (source
time in epoch seconds to the microsecond: the history holds float64 seconds, ~0.24 µs apart today, so
no finer digit would be true) and a column per binding, a cell empty where that series has no sample
(the layout PlotJuggler's CSV export and pandas' ``read_csv`` expect). A row is one microsecond, as its
time is written: the samples of different series whose times round to it share the row, and a series
with several samples in that microsecond fills as many rows (the time repeated), so no sample is lost.
`save_recording` writes every topic the history holds in a time range as an MCAP file in the ROS 2
profile (``dbglog record``'s writer): a dbglog tag as its std_msgs type with every sample, other topics
as their received CDR bytes, so ``dbglog view --replay`` and other tools open it. Both files get mode
0666 less the umask and are written under a temporary name beside the target, then renamed into place
(`dbglog._files`): a failure never leaves a half-written file or harms an existing one. No ROS, no
Dear PyGui.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Protocol

import numpy as np
import numpy.typing as npt

from dbglog._files import write_new_file
from dbglog._ros._cdr import SCALAR_FORMATS, scalar_encoder
from dbglog.record._writer import McapWriter, RecordingError
from dbglog.viewer._data._fields import Scalar
from dbglog.viewer._data._history import History
from dbglog.viewer._data._model import Binding

__all__ = ["ExportError", "column_label", "csv_rows", "export_csv", "save_recording"]


class ExportError(Exception):
    """An export could not be written; the message names the file and why."""


class _Ranges(Protocol):
    def between(self, binding: Binding, t0: float, t1: float) -> tuple[npt.NDArray[np.float64], list[Scalar]]:
        """Return the binding's samples with ``t0 <= time <= t1``."""


def column_label(binding: Binding) -> str:
    """Name a binding's CSV column: ``topic``, ``topic.field`` and ``~regex`` when it has one."""
    label = binding.topic
    if binding.field.strip():
        label += "." + binding.field.strip()
    if binding.regex.strip():
        label += f" ~{binding.regex.strip()}"
    if binding.transforms:
        label += " [" + ", ".join(t.describe() for t in binding.transforms) + "]"
    return label


def _cell(value: Scalar) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(value)
    if isinstance(value, tuple):
        return " ".join(repr(float(v)) for v in value)
    return str(value)


def _check_target(path: Path, *, force: bool) -> None:
    """Refuse a target that exists (without `force`), is a folder or lies in a folder that does not exist."""
    if path.exists() and not force:
        raise ExportError(f"{path} already exists (choose another name, or allow replacing it)")
    if path.is_dir():
        raise ExportError(f"{path} is a folder")
    folder = path.parent
    if not folder.is_dir():
        raise ExportError(f"cannot write {path}: the folder {folder} does not exist")


def _atomic(path: Path, write: Callable[[Path], None], *, force: bool) -> None:
    """Write through a temporary file in the target's folder (0666 less the umask), then rename it."""
    _check_target(path, force=force)
    try:
        write_new_file(path, write, replace=force)
    except FileExistsError:
        raise ExportError(f"{path} already exists (choose another name, or allow replacing it)") from None
    except OSError as exc:
        raise ExportError(f"cannot write {path}: {exc.strerror or exc}") from None


def _micros(times: npt.NDArray[np.float64]) -> npt.NDArray[np.int64]:
    """Source times (epoch seconds) as the whole microseconds a CSV row shows, each float rounded exactly.

    The whole seconds and the fraction are scaled apart: ``t * 1e6`` itself would be rounded to a quarter
    of a microsecond first at today's epoch.
    """
    t = np.asarray(times, dtype=np.float64)
    whole = np.floor(t)
    return whole.astype(np.int64) * 1_000_000 + np.rint((t - whole) * 1e6).astype(np.int64)


def _time_text(us: int) -> str:
    """Whole microseconds as epoch seconds with six decimals, exactly."""
    sign = "-" if us < 0 else ""
    whole, frac = divmod(abs(us), 1_000_000)
    return f"{sign}{whole}.{frac:06d}"


def csv_rows(
    times: Sequence[npt.NDArray[np.float64]],
) -> tuple[npt.NDArray[np.int64], list[npt.NDArray[np.int64]]]:
    """Lay series out as CSV rows: each row's time, and for each series the row of each of its samples.

    Samples whose times round to the same microsecond share a row; the k-th sample of a series within a
    microsecond goes to that microsecond's k-th row. Rows are in time order.

    Args:
        times: each series' sample times (epoch seconds).

    Returns:
        The rows' times (whole microseconds, ascending; repeated where a series has several samples in
        one microsecond) and, per series, the row index of each of its samples.
    """
    keys: list[npt.NDArray[np.int64]] = []
    ranks: list[npt.NDArray[np.int64]] = []
    for t in times:
        us = _micros(t)
        order = np.argsort(us, kind="stable")
        ordered = us[order]
        rank = np.empty(len(us), dtype=np.int64)
        rank[order] = np.arange(len(us)) - np.searchsorted(ordered, ordered, side="left")
        keys.append(us)
        ranks.append(rank)
    all_keys = np.concatenate(keys) if keys else np.empty(0, np.int64)
    all_ranks = np.concatenate(ranks) if ranks else np.empty(0, np.int64)
    order = np.lexsort((all_ranks, all_keys))  # by microsecond, then by rank within it
    k, r = all_keys[order], all_ranks[order]
    starts = np.ones(len(k), dtype=bool)
    starts[1:] = (k[1:] != k[:-1]) | (r[1:] != r[:-1])
    row = np.empty(len(k), dtype=np.int64)
    row[order] = np.cumsum(starts) - 1
    bounds = np.cumsum([0, *(len(x) for x in keys)])
    return k[starts], [row[bounds[i] : bounds[i + 1]] for i in range(len(keys))]


def export_csv(
    source: _Ranges,
    bindings: Sequence[Binding],
    t0: float,
    t1: float,
    path: str | os.PathLike[str],
    *,
    force: bool = False,
) -> int:
    """Write the bindings' samples with ``t0 <= time <= t1`` to a CSV file; return the rows written.

    Raises:
        ExportError: nothing to export, or the file exists (without `force`) or cannot be written.
    """
    if not bindings:
        raise ExportError("nothing to export: no series chosen")
    if not t0 <= t1:
        raise ExportError(f"the export range is empty: it starts at {t0} after it ends at {t1}")
    columns = [source.between(b, t0, t1) for b in bindings]
    row_us, rows_of = csv_rows([c[0] for c in columns])
    target = Path(path)

    def write(tmp: Path) -> None:
        table = [[_time_text(us), *([""] * len(columns))] for us in row_us.tolist()]
        for col, ((_times, values), rows) in enumerate(zip(columns, rows_of, strict=True), start=1):
            for row, value in zip(rows.tolist(), values, strict=True):
                table[row][col] = _cell(value)
        with tmp.open("w", newline="", encoding="utf-8") as f:
            out = csv.writer(f)
            out.writerow(["time", *(column_label(b) for b in bindings)])
            out.writerows(table)

    _atomic(target, write, force=force)
    return len(row_us)


def _numbers_encoder(msg_type: str) -> Callable[[float], bytes] | None:
    """value -> CDR bytes of a one-field std_msgs type, with the value cast to the field's type."""
    short = msg_type.rsplit("/", 1)[-1]
    fmt = SCALAR_FORMATS.get(short)
    if fmt is None or not msg_type.startswith("std_msgs/msg/"):
        return None
    encode = scalar_encoder(fmt)
    if short == "Bool":
        return lambda v: encode(bool(v))
    if short.startswith(("Int", "UInt")):
        return lambda v: encode(int(v))
    return lambda v: encode(float(v))


def save_recording(
    store: History,
    types: dict[str, str],
    path: str | os.PathLike[str],
    *,
    t0: float = -math.inf,
    t1: float = math.inf,
    force: bool = False,
    extra: Sequence[tuple[str, str, npt.NDArray[np.float64], Sequence[bytes]]] = (),
) -> int:
    """Write every topic `store` holds between `t0` and `t1` to an MCAP file; return the messages written.

    Args:
        store: the history (topics by name; series' own keys are skipped).
        types: each topic's ROS type (a topic without one is skipped).
        path: the ``.mcap`` file to write.
        t0: the first source time written (epoch seconds).
        t1: the last source time written.
        force: replace an existing file.
        extra: messages the history lacks, written with its own in time order: (topic, ROS type, source
            times, CDR payloads) each (the markers added to a replay).

    Raises:
        ExportError: nothing held in the range, or the file exists (without `force`) or cannot be written.
    """
    added = {topic: (msg_type, times, list(payloads)) for topic, msg_type, times, payloads in extra}
    topics = [n for n in store.topics() if n.startswith("/") and n in types]
    topics += [n for n in added if n not in topics]
    types = {**{n: t for n, (t, _, _) in added.items()}, **types}
    target = Path(path)
    _check_target(target, force=force)
    written = 0
    try:
        writer = McapWriter(target, force=force, atomic=True)
    except RecordingError as exc:
        raise ExportError(f"cannot write {target}: {exc}") from None
    try:
        for name in topics:
            msg_type = types[name]
            if store.kind(name) == "numbers":
                encode = _numbers_encoder(msg_type)
                if encode is None:
                    continue
                times, values = store.range(name, t0, t1)
                payloads = [encode(v) for v in values.tolist()]
            else:
                times, payloads = store.payloads(name, t0, t1)
            if name in added:
                _, more_times, more = added[name]
                keep = (more_times >= t0) & (more_times <= t1)
                times = np.concatenate([times, more_times[keep]])
                payloads = [*payloads, *(p for p, k in zip(more, keep.tolist(), strict=True) if k)]
                order = np.argsort(times, kind="stable")
                times, payloads = times[order], [payloads[i] for i in order.tolist()]
            if not len(times):
                continue
            channel = writer.add_channel(name, msg_type)
            for t, data in zip(times.tolist(), payloads, strict=True):
                ns = round(t * 1e9)
                writer.write(channel, ns, data, ns)
            written += len(times)
        if not written:
            raise ExportError("nothing to save: the history holds no message in that time range")
        writer.close()
    except RecordingError as exc:
        writer.abandon()
        raise ExportError(f"cannot write {target}: {exc}") from None
    except OSError as exc:
        writer.abandon()
        raise ExportError(f"cannot write {target}: {exc.strerror or exc}") from None
    except BaseException:
        writer.abandon()
        raise
    return written
