"""Every layout the ``mcap`` library's writer offers reads whole: `read_recording`, ``dbglog tags`` and
``echo`` (in-process and as the real command), and the viewer's replay; files cut at any byte give what
is whole and say that the end was cut; a file with no message says 0.

The files are plain ROS 2 profile MCAP files written by ``mcap.writer.Writer`` (chunked or not, each
compression, each index set, with or without the summary's schemas, channels, statistics and offsets);
their CDR comes from ``rclpy.serialization``. The record layout of the intact file, read with the
library's own `StreamReader`, says which messages lie wholly before a cut.
"""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.records import Chunk, Message
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import CompressionType, IndexType

from dbglog.record import read_recording
from dbglog.record._inspect import echo_lines, tags_table
from dbglog.record._reader import recording_span
from dbglog.viewer._data._replay import load_replay
from tests._mcap_layouts import LAYOUTS, T0, TOPICS, Layout, N, write


def _check_whole(path: Path, n: int = N) -> None:
    """`read_recording`, tags, echo and the replay all give every message of `path`, in order."""
    rec = read_recording(path)
    assert {t: len(d) for t, d in rec.topics.items()} == dict.fromkeys(TOPICS, n), rec.problems
    speed = rec.topics["/rosdashboard/speed"]
    assert speed.values is not None
    assert speed.values.tolist() == [i * 0.5 for i in range(n)]
    assert speed.times_ns.tolist() == [T0 + i * 10_000_000 for i in range(n)]
    # A file read without its summary and index says so once, with what the scan found and its time.
    if not rec.indexed:
        assert len(rec.problems) == 1, rec.problems
        assert f"read by scanning the whole file: {3 * n} messages in " in rec.problems[0]
    else:
        assert rec.problems == []
    notes: list[str] = []
    rows = {line.split()[0]: line.split() for line in tags_table(path, warn=notes.append).splitlines()[2:]}
    assert {tag: row[2] for tag, row in rows.items()} == {"count": str(n), "speed": str(n)}
    assert len(notes) == (0 if rec.indexed else 1)
    assert list(echo_lines(path, "count", warn=notes.append)) == [str(i - 20) for i in range(n)]
    assert list(echo_lines(path, "/cmd_vel.linear.x", warn=notes.append))[-1] == repr((n - 1) * 0.25)
    replay = load_replay(path)
    for topic in TOPICS:
        times, _values = (
            replay.store.range(topic, -1e300, 1e300)
            if replay.store.kind(topic) == "numbers"
            else replay.store.payloads(topic, -1e300, 1e300)
        )
        assert len(times) == n, topic
    # A long file opens its last seconds first only when an index can find them without a scan.
    assert recording_span(path) is None or rec.indexed
    untimed = [p.rsplit(" in ", 1)[0] for p in rec.problems]
    assert [p.rsplit(" in ", 1)[0] for p in replay.problems] == untimed


@pytest.mark.parametrize("layout", LAYOUTS, ids=str)
def test_every_mcap_writer_layout_reads_every_message(tmp_path: Path, layout: Layout) -> None:
    """Each layout of the `mcap` writer gives all 50 messages a topic to the reader, tags, echo and replay."""
    _check_whole(write(tmp_path / "run.mcap", layout), N)


def test_the_layouts_cover_every_option_of_the_writer() -> None:
    """The matrix holds every compression, index set and summary part, chunked and not (256 layouts)."""
    assert len(LAYOUTS) == 3 * 4 * 16 + 4 * 16
    assert {(la.chunked, la.compression) for la in LAYOUTS} == {(True, c) for c in CompressionType} | {
        (False, CompressionType.NONE)
    }
    assert {la.crcs for la in LAYOUTS} == {True, False}


@pytest.mark.parametrize(
    "layout",
    [
        Layout(True, CompressionType.ZSTD, IndexType.ALL, True, True, True, True, True),
        Layout(False, CompressionType.NONE, IndexType.NONE, False, False, False, False, False),
        Layout(True, CompressionType.LZ4, IndexType.NONE, True, True, True, True, True),
    ],
    ids=str,
)
def test_a_file_without_messages_still_says_0(tmp_path: Path, layout: Layout) -> None:
    """A file that holds no message reads as none: no topic with messages, tags with count 0 or none."""
    path = write(tmp_path / "empty.mcap", layout, 0)
    rec = read_recording(path)
    assert all(len(t) == 0 for t in rec.topics.values())
    table = tags_table(path, warn=lambda _m: None)
    if "no dbglog tags" not in table:
        assert {line.split()[2] for line in table.splitlines()[2:]} == {"0"}
    if not rec.indexed:
        assert "read by scanning the whole file: no message in" in rec.problems[0]
    if "/cmd_vel" in rec.topics:
        assert list(echo_lines(path, "/cmd_vel.linear.x", warn=lambda _m: None)) == []


def _whole_before(data: bytes) -> list[tuple[int, int]]:
    """(end byte, messages of our topics) of each top-level record of an intact file, by `StreamReader`."""
    stream = io.BytesIO(data)
    reader = StreamReader(stream, emit_chunks=True)
    out = []
    for record in reader.records:
        if isinstance(record, Chunk):
            out.append((stream.tell(), sum(isinstance(r, Message) for r in breakup_chunk(record))))
        else:
            out.append((stream.tell(), int(isinstance(record, Message))))
    return out


@pytest.mark.parametrize(
    "layout",
    [
        Layout(True, CompressionType.ZSTD, IndexType.ALL, True, True, True, True, True),
        Layout(True, CompressionType.NONE, IndexType.NONE, False, False, False, False, False),
        Layout(False, CompressionType.NONE, IndexType.ALL, True, True, True, True, False),
    ],
    ids=str,
)
def test_a_file_cut_at_any_byte_reads_what_is_whole_and_says_the_end_was_cut(
    tmp_path: Path, layout: Layout
) -> None:
    """Cut anywhere (a crashed writer): every message in a whole record is read, in order; the cut is said."""
    whole = write(tmp_path / "whole.mcap", layout, 200, chunk_size=2048)
    data = whole.read_bytes()
    records = _whole_before(data)
    path = tmp_path / "cut.mcap"
    for cut in sorted({*range(60, len(data), max(1, len(data) // 37)), len(data) - 1, len(data) - 9}):
        path.write_bytes(data[:cut])
        rec = read_recording(path)
        whole_messages = sum(count for end, count in records if end <= cut)
        speed = rec.topics.get("/rosdashboard/speed")
        got = [] if speed is None or speed.values is None else speed.values.tolist()
        # The messages go speed, count, cmd_vel, speed, ...: the first of every round begun is a speed.
        assert got == [i * 0.5 for i in range((whole_messages + 2) // 3)], (cut, rec.problems)
        assert not rec.indexed
        said = " ".join(rec.problems)
        assert str(path) in said
        assert "truncated at byte" in said or "cut short" in said, (cut, said)


def _dbglog(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "dbglog", *argv], capture_output=True, text=True, timeout=60, check=False
    )


def test_cli_tags_and_echo_of_an_index_less_file_count_every_message(tmp_path: Path) -> None:
    """`dbglog tags FILE` counts 50 (not 0) in a file with no index, and says once how it was read."""
    for layout in (
        Layout(True, CompressionType.ZSTD, IndexType.NONE, True, True, True, True, True),  # summary, no index
        Layout(False, CompressionType.NONE, IndexType.NONE, False, False, False, False, True),  # nothing
    ):
        path = write(tmp_path / "plain.mcap", layout)
        tags = _dbglog("tags", str(path))
        assert tags.returncode == 0, tags.stderr
        rows = {line.split()[0]: line.split() for line in tags.stdout.splitlines()[2:]}
        assert rows["speed"][2] == str(N), tags.stdout
        assert tags.stderr.count("warning") == 1, tags.stderr
        assert "read by scanning the whole file: 150 messages in" in tags.stderr
        echo = _dbglog("echo", "speed", "--file", str(path))
        assert echo.returncode == 0, echo.stderr
        assert echo.stdout.splitlines() == [repr(i * 0.5) for i in range(N)]
        path.unlink()
