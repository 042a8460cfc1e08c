"""Transforms on bindings: applied by the engine against real publishers, saved in dashboards, and no code
from a dashboard — the whole escape corpus through the real loader, the engine and the real viewer process.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from geometry_msgs.msg import Twist
from std_msgs.msg import Bool, Float64, String

from dbglog.viewer._data._engine import Engine
from dbglog.viewer._data._model import Binding, Status, ValueKind
from dbglog.viewer._document._dashboard import WidgetConfig, dumps, load_dashboard, parse_dashboard
from dbglog.viewer._values._transforms import (
    Abs,
    Clamp,
    DegToRad,
    Derivative,
    FormulaTransform,
    Invalid,
    MovingAverage,
    RadToDeg,
    Scale,
    TransformError,
    Unwrap,
    transforms_from_json,
    transforms_or_invalid,
)
from dbglog.viewer._widgets import WidgetRegistry
from tests._ros import RosPeer, wait_until

CORPUS = Path(__file__).parent / "data" / "escape_corpus.json"


def _corpus_texts(sentinel: Path) -> list[tuple[str, str]]:
    """(formula, why) for every corpus entry, the sentinel path filled in and repetitions expanded."""
    out = []
    for entry in json.loads(CORPUS.read_text(encoding="utf-8")):
        if "expand" in entry:
            spec = entry["expand"]
            text = spec["prefix"] * spec["count"] + spec["middle"] + spec["suffix"] * spec["count"]
        else:
            text = str(entry["formula"]).replace("SENTINEL", str(sentinel))
        out.append((text, entry["why"]))
    return out


def _bind(topic: str, fld: str, transforms: list[dict[str, Any]], regex: str = "") -> Binding:
    return Binding(topic, fld, regex, transforms_or_invalid(transforms))


@pytest.fixture(scope="module")
def ros() -> Iterator[tuple[RosPeer, Engine]]:
    """One real publisher peer and one engine for the module."""
    with RosPeer("xf_publisher") as peer, Engine(stale_after=5.0, graph_period=0.1) as engine:
        yield peer, engine


def _publish_all(
    peer: RosPeer, engine: Engine, topic: str, cls: Any, msgs: list[Any], bindings: list[Binding]
) -> None:
    pub = peer.publisher(topic, cls)
    for b in bindings:
        engine.bind(b)
    assert wait_until(
        lambda: (
            all(engine.snapshot(b).status is Status.WAITING and engine.snapshot(b).kind for b in bindings)
            or all(engine.snapshot(b).kind for b in bindings)
        ),
        20,
    ), [engine.snapshot(b) for b in bindings]
    assert peer.wait_for_subscribers(pub, 1, 20)
    for msg in msgs:
        pub.publish(msg)
    assert wait_until(lambda: all(engine.snapshot(b).count >= len(msgs) for b in bindings), 20), [
        (engine.snapshot(b).count, engine.snapshot(b).reason) for b in bindings
    ]


def _floats(values: list[float]) -> list[Any]:
    out = []
    for v in values:
        m = Float64()
        m.data = v
        out.append(m)
    return out


def test_every_transform_through_the_engine(ros: tuple[RosPeer, Engine]) -> None:
    """Each transform kind, on a real Float64 topic, gives the known values (fast raw-CDR path)."""
    peer, engine = ros
    raw = [0.0, 0.5, -1.0, 3.0, -3.0, 2.9, -2.9, 1.5]
    x = np.array(raw)
    cases: dict[str, tuple[list[dict[str, Any]], Any]] = {
        "scale": ([{"kind": "scale", "scale": 2.0, "offset": 1.0}], x * 2 + 1),
        "rad2deg": ([{"kind": "rad2deg"}], np.degrees(x)),
        "deg2rad": ([{"kind": "deg2rad"}], np.radians(x)),
        "abs": ([{"kind": "abs"}], np.abs(x)),
        "clamp": ([{"kind": "clamp", "min": -1.0, "max": 2.0}], np.clip(x, -1.0, 2.0)),
        "average": (
            [{"kind": "moving_average", "window": 3}],
            np.array([np.mean(x[max(0, i - 2) : i + 1]) for i in range(len(x))]),
        ),
        "unwrap": ([{"kind": "unwrap"}], np.unwrap(x)),
        "formula": ([{"kind": "formula", "expr": "x * 57.2958"}], x * 57.2958),
        "chain": (
            [{"kind": "unwrap"}, {"kind": "rad2deg"}, {"kind": "clamp", "max": 300}],
            np.minimum(np.degrees(np.unwrap(x)), 300),
        ),
    }
    bindings = {name: _bind("/xf/value", "", t) for name, (t, _) in cases.items()}
    derivative = _bind("/xf/value", "data", [{"kind": "derivative"}])
    plain = Binding("/xf/value", "data")
    _publish_all(peer, engine, "/xf/value", Float64, _floats(raw), [*bindings.values(), derivative, plain])
    for name, (_, expected) in cases.items():
        snap = engine.snapshot(bindings[name])
        assert snap.status is Status.LIVE, (name, snap.reason)
        assert snap.kind is ValueKind.NUMBER
        np.testing.assert_allclose(snap.values, expected, rtol=1e-12, atol=1e-12, err_msg=name)
        assert snap.last == pytest.approx(expected[-1])
    base = engine.snapshot(plain)
    np.testing.assert_array_equal(base.values, x)
    d = engine.snapshot(derivative)
    assert math.isnan(d.values[0])
    np.testing.assert_allclose(d.values[1:], np.diff(x) / np.diff(d.times), rtol=1e-9)
    assert d.status is Status.LIVE, "a derivative's first NaN is not a failure"


def test_multi_field_formula_reads_fields_of_the_same_message(ros: tuple[RosPeer, Engine]) -> None:
    """sqrt(linear.x**2 + linear.y**2) on a Twist binding reads both fields from each message."""
    peer, engine = ros
    pairs = [(3.0, 4.0), (6.0, 8.0), (0.0, -2.0), (1.0, 1.0)]
    msgs = []
    for vx, vy in pairs:
        m = Twist()
        m.linear.x, m.linear.y, m.angular.z = vx, vy, vx - vy
        msgs.append(m)
    speed = _bind("/xf/cmd_vel", "linear.x", [{"kind": "formula", "expr": "sqrt(linear.x**2 + linear.y**2)"}])
    mixed = _bind("/xf/cmd_vel", "angular.z", [{"kind": "formula", "expr": "x * 10 + linear.y"}])
    heading = _bind(
        "/xf/cmd_vel",
        "linear.x",
        [{"kind": "formula", "expr": "atan2(linear.y, linear.x)"}, {"kind": "rad2deg"}],
    )
    _publish_all(peer, engine, "/xf/cmd_vel", Twist, msgs, [speed, mixed, heading])
    np.testing.assert_allclose(engine.snapshot(speed).values, [5.0, 10.0, 2.0, math.sqrt(2)])
    np.testing.assert_allclose(engine.snapshot(mixed).values, [(vx - vy) * 10 + vy for vx, vy in pairs])
    np.testing.assert_allclose(
        engine.snapshot(heading).values, [math.degrees(math.atan2(vy, vx)) for vx, vy in pairs]
    )


def test_bool_and_regex_bindings_take_transforms(ros: tuple[RosPeer, Engine]) -> None:
    """A transformed bool becomes a number; a regex-captured number is transformed too."""
    peer, engine = ros
    scaled = _bind("/xf/flag", "", [{"kind": "scale", "scale": 10.0}])
    bools = []
    for flag in (True, False, True):
        b = Bool()
        b.data = flag
        bools.append(b)
    _publish_all(peer, engine, "/xf/flag", Bool, bools, [scaled])
    snap = engine.snapshot(scaled)
    assert snap.kind is ValueKind.NUMBER
    np.testing.assert_array_equal(snap.values, [10.0, 0.0, 10.0])
    from_log = _bind("/xf/log", "", [{"kind": "scale", "scale": 2.0}], regex=r"speed=([0-9.]+)")
    texts = []
    for line in ("speed=1.25", "speed=4"):
        s = String()
        s.data = line
        texts.append(s)
    _publish_all(peer, engine, "/xf/log", String, texts, [from_log])
    np.testing.assert_array_equal(engine.snapshot(from_log).values, [2.5, 8.0])


def test_persistent_runtime_failure_is_an_error_until_values_are_good(ros: tuple[RosPeer, Engine]) -> None:
    """A formula failing sample after sample (sqrt of negatives) is an ERROR with why; good values recover."""
    peer, engine = ros
    root = _bind("/xf/neg", "", [{"kind": "formula", "expr": "sqrt(x)"}])
    _publish_all(peer, engine, "/xf/neg", Float64, _floats([-1.0, -2.0, -3.0, -4.0, -5.0, -6.0]), [root])
    snap = engine.snapshot(root)
    assert snap.status is Status.ERROR
    assert snap.reason.startswith("transform failed: ")
    assert "sqrt" in snap.reason or "domain" in snap.reason, snap.reason
    pub = peer.publisher("/xf/neg", Float64)
    assert peer.wait_for_subscribers(pub, 1, 20)
    pub.publish(_floats([16.0])[0])
    assert wait_until(lambda: engine.snapshot(root).status is Status.LIVE, 20), engine.snapshot(root).reason
    assert engine.snapshot(root).last == 4.0


def test_a_stateful_transform_takes_samples_in_source_time_order() -> None:
    """Samples in order pass at once; one older than a sample already taken is left out and from then on
    samples wait for older ones (1.5 times the lateness seen), so an interleaved batch is differentiated in
    source time order; what waited goes out when its wait is over, nothing newer coming (`release`)."""
    from dbglog.viewer._data._series import Series
    from dbglog.viewer._data._sinks import feed_numbers, make_sink, prepare, release

    binding = Binding("/t", transforms=(Derivative(),))
    series = Series(binding, 100)
    prepared = prepare(binding)
    assert not isinstance(prepared, str)
    sink = make_sink(binding, series, Float64, "std_msgs/msg/Float64", *prepared)
    assert sink.reorder is not None

    def feed(times: list[float], now: float) -> None:
        t = np.array(times)
        feed_numbers(sink, t, 10.0 * t, now)  # the slope is 10 everywhere

    feed([1.000, 1.002, 1.004], now=0.0)
    assert series.snapshot(1e9).times.tolist() == [1.000, 1.002, 1.004]  # in order: at once
    feed([1.001, 1.003], now=0.001)  # too late: left out, and samples now wait 1.5 x 3 ms
    assert sink.reorder.dropped == 2
    assert sink.reorder.hold == pytest.approx(0.0045)
    feed([1.006, 1.010], now=0.002)
    feed([1.005, 1.007], now=0.003)  # older than the newest arrival, within the wait: in order
    assert series.snapshot(1e9).times.tolist() == [1.000, 1.002, 1.004, 1.005]  # 1.005 <= 1.010 - 0.0045
    release(sink, now=0.003 + 0.0045)  # nothing newer came: what waited that long goes out
    snap = series.snapshot(1e9)
    assert snap.times.tolist() == [1.000, 1.002, 1.004, 1.005, 1.006, 1.007, 1.010]
    assert math.isnan(snap.values[0])
    assert snap.values[1:] == pytest.approx([10.0] * 6)


def test_samples_waiting_for_older_ones_go_out_when_their_sink_is_let_go() -> None:
    """A stateful binding's samples held back for older ones are pushed at once when its sink is let go
    (`flush`): the topic read from batches after its own subscription, or the other way round. Before,
    they went with the sink, missing from the derivative without a word (17 of 2058 in a CI run)."""
    from std_msgs.msg import UInt8MultiArray

    from dbglog._ros._batch import TagSamples
    from dbglog.viewer._data._batchsub import BatchIngest
    from dbglog.viewer._data._history import History
    from dbglog.viewer._data._series import Series
    from dbglog.viewer._data._sinks import feed_numbers, flush, make_sink, prepare

    binding = Binding("/rosdashboard/f", transforms=(Derivative(),))
    prepared = prepare(binding)
    assert not isinstance(prepared, str)

    def sink_for(b: Binding, series: Series, cls: Any, msg_type: str) -> Any:
        return make_sink(b, series, cls, msg_type, *prepared)

    def times(series: Series) -> list[float]:
        return [float(t) for t in series.snapshot(1e9).times]

    series = Series(binding, 100)
    sink = sink_for(binding, series, Float64, "std_msgs/msg/Float64")
    for batch in ([1.0, 1.2], [1.1], [1.3, 1.4]):  # 1.1 late: from then on samples wait 0.15 s
        t = np.array(batch)
        feed_numbers(sink, t, 10.0 * t, 0.0)
    assert times(series) == [1.0, 1.2]
    flush(sink, 0.0)  # its topic is read another way now: nothing older can come to this sink
    assert times(series) == [1.0, 1.2, 1.3, 1.4]
    assert sink.reorder is not None
    assert sink.reorder.dropped == 1  # 1.1 came too late: counted

    series = Series(binding, 100)
    ingest = BatchIngest(
        make_sink=sink_for,
        feed=lambda *_a: None,
        feed_numbers=feed_numbers,
        record_latency=lambda _t: None,
        message_class=lambda _n: UInt8MultiArray if _n.endswith("UInt8MultiArray") else Float64,
        history=History(),
    )
    ingest.attach(binding.topic, "std_msgs/msg/Float64", {binding: series})
    for batch in ([1.0, 1.2], [1.1], [1.3, 1.4]):
        ns = (np.array(batch) * 1e9).astype(np.int64)
        ingest._ingest(TagSamples("f", "Float64", ns, np.array(batch) * 10.0))
    assert times(series) == pytest.approx([1.0, 1.2])  # 1.3 and 1.4 wait for older samples
    ingest.detach(binding.topic)  # its publisher is not a batch writer (yet): the topic is read on its own
    assert times(series) == pytest.approx([1.0, 1.2, 1.3, 1.4])


def test_engine_rejects_bad_transforms_without_evaluating(
    ros: tuple[RosPeer, Engine], tmp_path: Path
) -> None:
    """Transforms given to the engine directly (not via a file) are checked too; corpus entries never run."""
    _, engine = ros
    sentinel = tmp_path / "sentinel"
    bad = [
        _bind("/xf/value", "", [{"kind": "nope"}]),
        Binding("/xf/value", transforms=transforms_or_invalid("[{")),
    ]
    bad += [
        _bind("/xf/value", "", [{"kind": "formula", "expr": text}]) for text, _ in _corpus_texts(sentinel)
    ]
    for b in bad:
        engine.bind(b)
        snap = engine.snapshot(b)
        assert snap.status is Status.ERROR
        assert snap.reason.startswith("bad transforms: ")
        engine.unbind(b)
    text_field = _bind("/xf/log", "", [{"kind": "abs"}])
    engine.bind(text_field)
    assert wait_until(lambda: "transforms apply to numbers" in engine.snapshot(text_field).reason, 20)
    assert not sentinel.exists()


def test_dashboard_round_trip_keeps_transforms() -> None:
    """A binding's transforms load, compare equal after a save and reload, and stay in canonical form."""
    data = {
        "format": "dbglog-dashboard",
        "version": 1,
        "widgets": [
            {
                "type": "plot",
                "name": "Heading",
                "x": 0,
                "y": 0,
                "width": 200,
                "height": 200,
                "bindings": [
                    {"topic": "/a", "transforms": [{"kind": "rad2deg"}, {"max": 5, "kind": "clamp"}]},
                    {"topic": "/b", "transforms": []},
                ],
            }
        ],
    }
    registry = WidgetRegistry.builtin()
    first = parse_dashboard(data, registry.get)
    assert first.messages == []
    config = first.dashboard.widgets[0]
    again = parse_dashboard(json.loads(json.dumps(first.dashboard.to_dict())), registry.get)
    assert again.dashboard.widgets[0] == config
    binding, empty = config.bindings
    assert binding.transforms == (RadToDeg(), Clamp(high=5.0))
    assert empty.transforms == ()
    assert hash(binding) == hash(Binding("/a", "", "", (RadToDeg(), Clamp(high=5.0))))


SAVED = Path(__file__).parent / "data" / "transforms_saved.json"
"""Saved by the viewer when bindings still held their transforms as JSON text (before they were values)."""


def test_transforms_are_values_and_files_stay_byte_identical() -> None:
    """Bindings hold typed transform values (a rejected list is one `Invalid`, kept as written with its
    reason); the file written before transforms were values loads and saves back byte for byte."""
    registry = WidgetRegistry.builtin()
    text = SAVED.read_text(encoding="utf-8")
    result = parse_dashboard(json.loads(text), registry.get)
    assert dumps(result.dashboard) == text
    every, empty, dunder, not_a_list = result.dashboard.widgets[0].bindings
    assert every.transforms == (
        Scale(2.0, -1.5),
        DegToRad(),
        RadToDeg(),
        Abs(),
        Clamp(-5.0, 5.0),
        Clamp(high=1e300),
        Derivative(),
        MovingAverage(7),
        Unwrap(360.0),
        FormulaTransform("x * 57.2958 + linear.y"),
    )
    assert len({every, replace(every, transforms=tuple(every.transforms))}) == 1, "hashable values"
    assert empty.transforms == ()
    (rejected,) = dunder.transforms
    assert isinstance(rejected, Invalid)
    assert rejected.reason.startswith("transforms[0] (formula): 'expr'")
    assert json.loads(rejected.written)[0] == {"kind": "formula", "expr": "__import__('os')"}
    (shape,) = not_a_list.transforms
    assert isinstance(shape, Invalid)
    assert shape.reason == "transforms must be a list of objects, got dict"
    assert [m.split(": ", 1)[0] for m in result.messages] == ["widget #1 'Every kind'"] * 2


def test_transform_loaders_type_every_parameter() -> None:
    """Each kind's loader checks its parameters' types and names the bad one (no value reaches a class
    untyped); the constructors check the same ranges when called directly."""
    cases = [
        ({"kind": "scale", "scale": "2"}, "'scale' must be a number"),
        ({"kind": "clamp", "min": True}, "'min' must be a number"),
        ({"kind": "moving_average", "window": 2.5}, "'window' must be an integer"),
        ({"kind": "moving_average"}, "needs 'window'"),
        ({"kind": "unwrap", "period": None}, "'period' must be a number"),
        ({"kind": "formula", "expr": 3}, "'expr' must be a string"),
        ({"kind": "formula"}, "needs 'expr'"),
    ]
    for item, reason in cases:
        with pytest.raises(TransformError, match=reason):
            transforms_from_json([item])
        (kept,) = transforms_or_invalid([item])
        assert isinstance(kept, Invalid)
        assert reason in kept.reason
    with pytest.raises(TransformError, match="between 1 and"):
        MovingAverage(0)
    with pytest.raises(TransformError, match="is above 'max'"):
        Clamp(2.0, 1.0)


def _corpus_dashboard(path: Path, sentinel: Path) -> list[str]:
    """Write a dashboard with one dial per corpus formula plus one good dial; return the corpus names."""
    widgets = []
    names = []
    for i, (text, _why) in enumerate(_corpus_texts(sentinel)):
        name = f"Corpus {i:03d}"
        names.append(name)
        widgets.append(
            {
                "type": "dial",
                "name": name,
                "x": 10 * (i % 40),
                "y": 10 * (i // 40),
                "width": 200,
                "height": 200,
                "bindings": [
                    {
                        "topic": "/xf/escape",
                        "field": "data",
                        "transforms": [{"kind": "formula", "expr": text}],
                    }
                ],
            }
        )
    widgets.append(
        {
            "type": "dial",
            "name": "Good",
            "x": 500,
            "y": 500,
            "width": 200,
            "height": 200,
            "bindings": [{"topic": "/xf/escape", "transforms": [{"kind": "formula", "expr": "x * 57.2958"}]}],
        }
    )
    data = {"format": "dbglog-dashboard", "version": 1, "widgets": widgets}
    path.write_text(json.dumps(data), encoding="utf-8")
    return names


REJECTED = "; kept as written, the widget shows this error until it is fixed"


def test_escape_corpus_dashboard_through_the_loader_and_the_viewer(tmp_path: Path) -> None:
    """A dashboard holding every corpus entry loads with each formula rejected (kept as written, the widget
    in error), naming its widget; the real viewer process opens it, renders, and the sentinel file is never
    created."""
    sentinel = tmp_path / "sentinel"
    board = tmp_path / "corpus.json"
    names = _corpus_dashboard(board, sentinel)
    assert len(names) >= 160
    result = load_dashboard(board, WidgetRegistry.discover().get)
    by_name = {w.name: w for w in result.dashboard.widgets}
    for i, name in enumerate(names):
        (kept,) = by_name[name].bindings
        (rejected,) = kept.transforms
        assert isinstance(rejected, Invalid), name
        assert json.loads(rejected.written)[0]["kind"] == "formula", name
        assert any(
            m.startswith(f"widget #{i + 1} {name!r}: bindings[0]: transforms[0] (formula)")
            for m in result.messages
        ), name
    assert len([m for m in result.messages if m.endswith(REJECTED)]) == len(names)
    assert by_name["Good"].bindings[0].transforms
    report = tmp_path / "report.json"
    env = dict(os.environ)
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "dbglog._cli",
            "view",
            str(board),
            "--screenshot",
            str(tmp_path / "corpus.png"),
            "--after",
            "1",
            "--report-json",
            str(report),
            "--size",
            "900x600",
        ],
        capture_output=True,
        text=True,
        timeout=100,
        check=False,
        cwd=tmp_path,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    rejected_lines = [line for line in proc.stderr.splitlines() if line.endswith(REJECTED)]
    assert len(rejected_lines) == len(names)
    for name in names:
        assert any(f"{name!r}: bindings[0]: transforms[0] (formula)" in line for line in rejected_lines), name
    shown = {w["name"]: w for w in json.loads(report.read_text())["widgets"]}
    assert len(shown) == len(names) + 1
    assert all(shown[name]["status"] == "error" for name in names)
    assert all("bad transforms" in shown[name]["reason"] for name in names)
    assert shown["Good"]["bindings"] == [{"topic": "/xf/escape", "field": "", "regex": ""}]
    assert (tmp_path / "corpus.png").stat().st_size > 0
    assert not sentinel.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["corpus.json", "corpus.png", "report.json"]


def test_shipped_dashboards_show_the_azimuth_in_degrees_and_the_demo_has_teleop() -> None:
    """The sound-source example and the demo feed a degrees compass through rad→deg; the demo can steer."""
    root = Path(__file__).resolve().parent.parent
    registry = WidgetRegistry.discover()
    for path in (
        root / "examples" / "dashboards" / "sound_source.json",
        root / "dbglog" / "_demo" / "demo_dashboard.json",
    ):
        result = load_dashboard(path, registry.get)
        assert result.messages == [], path
        compass = next(w for w in result.dashboard.widgets if w.type == "compass" and "zimuth" in w.name)
        assert compass.properties["units"] == "degrees"  # type: ignore[union-attr]
        (binding,) = compass.bindings
        assert binding.topic == "/rosdashboard/sound/azimuth"
        assert binding.transforms == (RadToDeg(),)
    demo = load_dashboard(root / "dbglog" / "_demo" / "demo_dashboard.json", registry.get).dashboard
    teleop = {
        (w.type, w.bindings[0].topic, w.bindings[0].field)
        for w in demo.widgets
        if isinstance(w, WidgetConfig) and w.name.startswith("Teleop")
    }
    assert teleop == {
        ("toggle", "/turtle1/autopilot", ""),
        ("slider", "/turtle1/cmd_vel", "linear.x"),
        ("slider", "/turtle1/cmd_vel", "angular.z"),
    }
