"""Files dbglog creates (issue 32.9): 0666 less the umask everywhere, whole or not at all, an existing file
never harmed by a failure; the CSV export's rows as its time column shows them."""

from __future__ import annotations

import csv
import json
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from dbglog._files import TEMP_MARK, put_in_place, write_new_file
from dbglog.record import McapWriter, RecordingError
from dbglog.viewer._data._export import ExportError, csv_rows, export_csv, save_recording
from dbglog.viewer._data._fields import Scalar
from dbglog.viewer._data._history import History
from dbglog.viewer._data._model import Binding

ROOT = Path(__file__).resolve().parent.parent
T0_NS = 1_700_000_000_000_000_000

# Every kind of file dbglog writes, created by the real code in a process whose umask the test sets: a CSV
# export, a saved history (.mcap), a recording and a snapshot (`dbglog record`'s writer), a dashboard; each
# also replacing a 0600 file already there. Prints {name: mode}.
_CREATE_ALL = """
import json, os, sys
from pathlib import Path
import numpy as np
from dbglog.record import McapWriter
from dbglog.viewer._data._export import export_csv, save_recording
from dbglog.viewer._data._history import History
from dbglog.viewer._data._model import Binding
from dbglog.viewer._document._dashboard import Dashboard, save_dashboard

out = Path(sys.argv[1])

class Source:
    def between(self, binding, t0, t1):
        return np.array([1.0, 2.0]), [1.5, 2.5]

store = History(clock=None)
store.append_numbers("/a", [1.0, 2.0], [1.0, 2.0])

def make(name):
    path = out / name
    if name.startswith("old_"):
        path.write_text("an older file")
        path.chmod(0o600)
    force = name.startswith("old_")
    if name.endswith(".csv"):
        export_csv(Source(), [Binding("/a")], 0.0, 3.0, path, force=force)
    elif name.endswith("saved.mcap"):
        save_recording(store, {"/a": "std_msgs/msg/Float64"}, path, force=force)
    elif name.endswith(".mcap"):
        w = McapWriter(path, force=force, atomic="snapshot" in name)
        w.write(w.add_channel("/a", "std_msgs/msg/Float64"), 1, bytes(12), 1)
        w.close()
    else:
        save_dashboard(Dashboard([]), path)

names = ["x.csv", "saved.mcap", "record.mcap", "snapshot.mcap", "board.json"]
for name in names + ["old_" + n for n in names]:
    make(name)
print(json.dumps({p.name: os.stat(p).st_mode & 0o777 for p in out.iterdir()}))
"""


@pytest.mark.parametrize("umask", [0o027, 0o002])
def test_every_file_dbglog_creates_gets_0666_less_the_umask(tmp_path: Path, umask: int) -> None:
    """CSV, saved history, recording, snapshot and dashboard files, new or replacing a 0600 one, get
    0666 & ~umask in a process with that umask; nothing temporary is left beside them."""
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(_CREATE_ALL), str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        umask=umask,
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr
    modes = json.loads(done.stdout)
    names = ["x.csv", "saved.mcap", "record.mcap", "snapshot.mcap"]
    expected = dict.fromkeys([*names, *(f"old_{n}" for n in names)], 0o666 & ~umask)
    # A dashboard replacing a file keeps that file's bits (docs/viewer.md); a new one gets the umask's.
    expected |= {"board.json": 0o666 & ~umask, "old_board.json": 0o600, "old_board.json.bak": 0o600}
    assert {n: oct(m) for n, m in modes.items()} == {n: oct(m) for n, m in expected.items()}


def test_a_failed_write_leaves_the_existing_file_and_nothing_temporary(tmp_path: Path) -> None:
    """A write that fails half-way, an atomic recording abandoned or a history with nothing to save: the
    file already there keeps its bytes and mode, and no temporary file is left."""
    target = tmp_path / "keep.csv"
    target.write_text("precious")
    target.chmod(0o640)

    def half(tmp: Path) -> None:
        tmp.write_text("half of it")
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="No space left"):
        write_new_file(target, half, replace=True)
    snap = tmp_path / "snap.mcap"
    snap.write_bytes(b"an older snapshot")
    w = McapWriter(snap, force=True, atomic=True)
    w.write(w.add_channel("/a", "std_msgs/msg/Float64"), 1, bytes(12), 1)
    w.abandon()
    with pytest.raises(ExportError, match="holds no message"):
        save_recording(History(clock=None), {}, snap, force=True)
    assert target.read_text() == "precious"
    assert stat.S_IMODE(target.stat().st_mode) == 0o640
    assert snap.read_bytes() == b"an older snapshot"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.csv", "snap.mcap"]


def test_an_existing_file_is_never_replaced_unasked_even_when_it_appears_meanwhile(tmp_path: Path) -> None:
    """Without `replace`, a file that exists, or that another program creates while ours is written, is
    left as it was: FileExistsError, RecordingError or ExportError name it."""
    target = tmp_path / "run.mcap"

    def racing(tmp: Path) -> None:
        tmp.write_text("ours")
        target.write_text("theirs")  # another program took the name meanwhile

    with pytest.raises(FileExistsError):
        write_new_file(target, racing)
    assert target.read_text() == "theirs"
    with pytest.raises(RecordingError, match="already exists"):
        McapWriter(target)
    with pytest.raises(RecordingError, match="it is a folder"):
        McapWriter(tmp_path, force=True)
    w = McapWriter(tmp_path / "late.mcap", atomic=True)
    (tmp_path / "late.mcap").write_text("theirs too")
    with pytest.raises(RecordingError, match=r"late\.mcap already exists"):
        w.close()
    assert (tmp_path / "late.mcap").read_text() == "theirs too"
    assert not [p for p in tmp_path.iterdir() if TEMP_MARK in p.name]
    tmp = tmp_path / "t"
    tmp.write_text("x")
    with pytest.raises(FileExistsError):
        put_in_place(tmp, target, replace=False)
    put_in_place(tmp, target, replace=True)
    assert target.read_text() == "x"


def test_a_recording_is_at_its_name_from_its_header_on(tmp_path: Path) -> None:
    """A recording's file is in place once created (a killed recorder leaves it there); an atomic one
    (a snapshot) only when closed."""
    live = McapWriter(tmp_path / "live.mcap")
    snap = McapWriter(tmp_path / "snap.mcap", atomic=True)
    assert (tmp_path / "live.mcap").stat().st_size > 8
    assert not (tmp_path / "snap.mcap").exists()
    live.abandon()
    snap.close()
    assert (tmp_path / "live.mcap").exists()
    assert (tmp_path / "snap.mcap").read_bytes()[-8:] == b"\x89MCAP0\r\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["live.mcap", "snap.mcap"]


class _Columns:
    """A source whose bindings hold given sample times (float64 epoch seconds, as the history holds them)."""

    def __init__(self, columns: dict[Binding, npt.NDArray[np.float64]]) -> None:
        self.columns = columns

    def between(self, binding: Binding, t0: float, t1: float) -> tuple[npt.NDArray[np.float64], list[Scalar]]:
        """Return the binding's samples in [t0, t1]; each value is its index."""
        t = self.columns[binding]
        keep = (t >= t0) & (t <= t1)
        return t[keep], [float(i) for i in np.flatnonzero(keep).tolist()]


def _read(path: Path) -> list[list[str]]:
    with path.open(encoding="utf-8", newline="") as f:
        return list(csv.reader(f))[1:]


def test_samples_a_few_nanoseconds_apart_share_the_row_of_their_microsecond(tmp_path: Path) -> None:
    """Two series logged 3 ns apart (as float64 seconds: one ulp apart or equal): a row per microsecond
    shown, never two rows with the same time; the pair shares its row unless a microsecond boundary
    falls between them (then they are on neighbouring rows, 1 µs apart); every sample is there once."""
    n = 5000
    a_ns = T0_NS + np.arange(n, dtype=np.int64) * 10_000_037  # ~100 Hz, every phase of the microsecond
    b_ns = a_ns + 3
    a, b = Binding("/a"), Binding("/b")
    source = _Columns({a: a_ns.astype(np.float64) * 1e-9, b: b_ns.astype(np.float64) * 1e-9})  # as history_of
    assert np.count_nonzero(a_ns * 1e-9 != b_ns * 1e-9) > 10  # the case the issue met: different floats
    path = tmp_path / "pairs.csv"
    rows_written = export_csv(source, [a, b], -np.inf, np.inf, path)
    rows = _read(path)
    assert rows_written == len(rows)
    shown = np.array([int(r[0].replace(".", "")) for r in rows], dtype=np.int64) * 1000  # ns
    assert np.all(np.diff(shown) > 0)  # one row per time shown
    for col, true_ns in ((1, a_ns), (2, b_ns)):
        filled = [i for i, r in enumerate(rows) if r[col]]
        assert [rows[i][col] for i in filled] == [repr(float(i)) for i in range(n)]
        # Each sample's row shows its time to the microsecond, within what the float64 seconds made from
        # its ns hold (0.35 µs off at most here).
        assert np.max(np.abs(shown[filled] - true_ns)) <= 500 + 400
    split = [i for i, r in enumerate(rows) if not (r[1] and r[2])]
    assert len(split) < n * 0.01  # a boundary between two samples 3 ns apart: rare
    for i, j in zip(split[::2], split[1::2], strict=True):
        assert j == i + 1
        assert shown[j] - shown[i] == 1000


def test_samples_of_one_series_in_one_microsecond_keep_their_own_rows(tmp_path: Path) -> None:
    """A series with two samples in one microsecond fills two rows with that time (none lost); another
    series' sample of that microsecond is on the first; rows never repeat a time otherwise."""
    t = 1_700_000_000.0
    a, b = Binding("/a"), Binding("/b")
    us = 1e-6
    source = _Columns({a: np.array([t, t + 0.2 * us, t + 2 * us]), b: np.array([t + 0.1 * us, t + 2 * us])})
    path = tmp_path / "dup.csv"
    assert export_csv(source, [a, b], 0, 2e9, path) == 3
    assert _read(path) == [
        ["1700000000.000000", "0.0", "0.0"],
        ["1700000000.000000", "1.0", ""],
        ["1700000000.000002", "2.0", "1.0"],
    ]
    times, rows = csv_rows([np.array([t + 3 * us, t]), np.array([])])
    assert times.tolist() == [1_700_000_000_000_000, 1_700_000_000_000_003]
    assert [r.tolist() for r in rows] == [[1, 0], []]
