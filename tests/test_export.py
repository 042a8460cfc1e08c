"""Exports (issues 16.5 and 17.3): series as CSV with source times, the live history saved as a recording
that an independent reader (mcap + mcap_ros2) decodes value by value and dbglog replays."""

from __future__ import annotations

import csv
import time
import uuid
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rclpy.serialization import serialize_message
from std_msgs.msg import Float64, String

from dbglog._ros._tags import topic_for_tag
from dbglog.record import McapWriter
from dbglog.viewer._data._engine import Engine
from dbglog.viewer._data._export import ExportError, export_csv, save_recording
from dbglog.viewer._data._model import Binding
from dbglog.viewer._data._replay import load_replay
from dbglog.viewer._values._transforms import Scale
from tests._children import run_sdk
from tests._ros import RosPeer, wait_until

T0 = 1_700_000_000_000_000_000


def _file(path: Path) -> None:
    w = McapWriter(path)
    a = w.add_channel("/a", "std_msgs/msg/Float64")
    s = w.add_channel("/s", "std_msgs/msg/String")
    for i in range(10):
        t = T0 + i * 100_000_000  # 10 Hz
        w.write(a, t, serialize_message(Float64(data=i * 1.5)), t)
        if i % 2:
            w.write(s, t + 50_000_000, serialize_message(String(data=f"odd, {i}")), t + 50_000_000)
    w.close()


def test_csv_has_source_times_one_column_per_series_and_blank_cells(tmp_path: Path) -> None:
    """Rows are the union of the series' times in range; a series without a sample there is blank."""
    rec = tmp_path / "r.mcap"
    _file(rec)
    source = load_replay(rec)
    a, scaled, s = Binding("/a"), Binding("/a", transforms=(Scale(2.0),)), Binding("/s")
    for b in (a, scaled, s):
        source.bind(b)
    out = tmp_path / "out.csv"
    t0, t1 = (T0 + 200_000_000) / 1e9, (T0 + 400_000_000) / 1e9
    rows = export_csv(source, [a, scaled, s], t0, t1, out)
    with out.open(encoding="utf-8", newline="") as f:
        table = list(csv.reader(f))
    assert table[0] == ["time", "/a", "/a [×2 + 0]", "/s"]
    assert rows == len(table) - 1 == 4  # 0.2, 0.3, 0.35, 0.4
    assert [r[0] for r in table[1:]] == [f"{(T0 + d) / 1e9:.6f}" for d in (2e8, 3e8, 3.5e8, 4e8)]
    assert table[1][1:] == ["3.0", "6.0", ""]
    assert table[3][1:] == ["", "", "odd, 3"]  # a comma inside a text is quoted, not a new column
    with pytest.raises(ExportError, match="already exists"):
        export_csv(source, [a], t0, t1, out)
    assert out.read_text(encoding="utf-8").startswith("time,")  # untouched
    assert export_csv(source, [a], t0, t1, out, force=True) == 3
    with pytest.raises(ExportError, match="does not exist"):
        export_csv(source, [a], t0, t1, tmp_path / "no" / "x.csv")
    with pytest.raises(ExportError, match="no series chosen"):
        export_csv(source, [], t0, t1, tmp_path / "y.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv", "r.mcap"]  # no temporary file left


def test_the_live_history_saved_as_a_recording_reads_back_everywhere(tmp_path: Path) -> None:
    """A real engine's history (a dbglog tag from batches, a plain String topic) saved to MCAP:
    mcap_ros2 decodes every value at its source time, and dbglog replays it."""
    tag = f"export_{uuid.uuid4().hex[:6]}/ramp"
    words = f"/export_{uuid.uuid4().hex[:6]}/words"
    with Engine(node_name="export_engine") as engine, RosPeer("export_peer") as peer:
        pub = peer.publisher(words, String)
        engine.bind(Binding(words))
        assert peer.wait_for_subscribers(pub, timeout=30)
        code = f"""
            import time, dbglog
            dbglog.init()
            time.sleep(2.0)
            for i in range(300):
                dbglog.logint({tag!r}, i)
                time.sleep(0.001)
            assert dbglog.flush(5.0)
        """
        topic = topic_for_tag(tag)
        done = run_sdk(code, stay_until=lambda: engine.store.count(topic) >= 300)
        assert done.returncode == 0, done.stderr
        for i in range(20):
            pub.publish(String(data=f"w{i}"))
            time.sleep(0.005)
        assert wait_until(lambda: engine.store.count(topic) >= 300 and engine.store.count(words) >= 20, 30), (
            engine.store.count(topic),
            engine.store.count(words),
        )
        types = engine.held_types()
        assert types[topic] == "std_msgs/msg/Int64"
        assert types[words] == "std_msgs/msg/String"
        held_times, _ = engine.store.range(topic, float("-inf"), float("inf"))
        out = tmp_path / "history.mcap"
        written = save_recording(engine.store, types, out)
    assert written >= 320
    decoded: dict[str, list[tuple[int, object]]] = {}
    with out.open("rb") as f:
        for _, channel, message, ros in make_reader(
            f, decoder_factories=[DecoderFactory()]
        ).iter_decoded_messages():
            decoded.setdefault(channel.topic, []).append((message.publish_time, ros.data))
    assert [v for _, v in decoded[topic]] == list(range(300))
    assert [t for t, _ in decoded[topic]] == [round(t * 1e9) for t in held_times.tolist()]
    assert [v for _, v in decoded[words]] == [f"w{i}" for i in range(20)]
    replay = load_replay(out)
    b = Binding(topic)
    replay.bind(b)
    assert replay.snapshot(b).values.tolist() == [float(i) for i in range(300)]
    with pytest.raises(ExportError, match="already exists"):
        save_recording(replay.store, replay.held_types(), out)
    with pytest.raises(ExportError, match="holds no message in that time range"):
        save_recording(replay.store, replay.held_types(), tmp_path / "empty.mcap", t0=0, t1=1)
    assert not (tmp_path / "empty.mcap").exists()
