"""``dbglog record`` as a real subprocess against real publishers; the files read back independently."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from geometry_msgs.msg import Twist
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from dbglog.record import read_recording
from dbglog.record._inspect import echo_lines, tag_series, tags_table
from tests._ros import RosPeer, first_line

pytestmark = pytest.mark.timeout(120)

# A robot: the real dbglog SDK. Tag "early" is set before the recorder starts (kept, transient-local);
# after "go" on stdin it publishes `n` values of "speed" (floats), "count" (ints), "state" (strings),
# then a brand-new tag "late", and keeps running until stdin closes.
_ROBOT = """
import sys, time
import dbglog
n = int(sys.argv[1])
dbglog.logfloat("early", 42.5)
dbglog.flush()
print("ready", flush=True)
sys.stdin.readline()
for i in range(n):
    dbglog.logfloat("speed", i * 0.5)
    dbglog.logint("count", i)
    dbglog.logstring("state", f"step {i}")
    time.sleep(0.005)
dbglog.logbool("late", True)
dbglog.flush()
print("sent", flush=True)
sys.stdin.readline()
"""

# A steady publisher for the crash test: one Float64 tag at 200 Hz, its value its own index.
_STEADY = """
import time
import dbglog
i = 0
t = time.monotonic()
print("ready", flush=True)
while True:
    dbglog.logfloat("steady", float(i))
    i += 1
    t += 0.005
    time.sleep(max(0.0, t - time.monotonic()))
"""


class Proc:
    """A child process with text pipes, ended at teardown."""

    def __init__(self, *args: str, stdin: bool = False) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, *args],
            stdin=subprocess.PIPE if stdin else subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )

    def line(self) -> str:
        """The next stdout line."""
        assert self.proc.stdout is not None
        return first_line(self.proc.stdout)

    def send(self, text: str) -> None:
        """Write a line to stdin."""
        assert self.proc.stdin is not None
        self.proc.stdin.write(text + "\n")
        self.proc.stdin.flush()

    def end(self, sig: int = signal.SIGINT, timeout: float = 30) -> tuple[int, str]:
        """Send `sig`, wait, and return the exit code and stderr."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        _, err = self.proc.communicate(timeout=timeout)
        return self.proc.returncode, err


@pytest.fixture
def procs() -> Iterator[Callable[..., Proc]]:
    """Start child processes; kill the ones still running at the end."""
    started: list[Proc] = []

    def start(*args: str, stdin: bool = False) -> Proc:
        p = Proc(*args, stdin=stdin)
        started.append(p)
        return p

    yield start
    for p in started:
        if p.proc.poll() is None:
            p.proc.kill()
        p.proc.communicate(timeout=10)


def _record(out: Path, *args: str) -> list[str]:
    return ["-m", "dbglog", "record", "-o", str(out), *args]


def _stderr_until(proc: Proc, needle: str, timeout: float = 30) -> str:
    """Read the recorder's stderr lines until one contains `needle`."""
    assert proc.proc.stderr is not None
    deadline = time.monotonic() + timeout
    seen = []
    while time.monotonic() < deadline:
        line = proc.proc.stderr.readline()
        if not line:
            break
        seen.append(line)
        if needle in line:
            return line
    raise AssertionError(f"no {needle!r} on stderr within {timeout} s: {seen[-5:]}")


def _counts(proc: Proc, done: Callable[[list[int]], bool], timeout: float = 60) -> list[int]:
    """Read the recorder's once-a-second summary lines until `done(counts so far)`; return the counts."""
    assert proc.proc.stderr is not None
    counts: list[int] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.proc.stderr.readline()
        if not line:
            break
        words = line.replace(",", "").split()
        if "messages" in words:
            counts.append(int(words[words.index("messages") - 1]))
            if done(counts):
                return counts
    raise AssertionError(f"the recorder's summary never got there: {counts[-5:]}")


def _settled(counts: list[int], least: int) -> bool:
    """At least `least` messages and no new one during the last second."""
    return len(counts) >= 2 and counts[-1] >= least and counts[-1] == counts[-2]


def _decoded(path: Path) -> dict[str, list[tuple[int, Any]]]:
    """Every message of the file decoded by mcap + mcap_ros2 (the independent reader)."""
    out: dict[str, list[tuple[int, Any]]] = {}
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, message, decoded in reader.iter_decoded_messages():
            out.setdefault(channel.topic, []).append((message.publish_time, decoded))
    return out


def test_record_default_gets_kept_values_new_tags_and_every_sample(
    tmp_path: Path, procs: Callable[..., Proc]
) -> None:
    """Default targets: a kept value from before the start, every sample of 3 tags, a later tag; Ctrl-C."""
    n = 400
    robot = procs("-c", _ROBOT, str(n), stdin=True)
    assert robot.line() == "ready"
    out = tmp_path / "run.mcap"
    rec = procs(*_record(out))
    # Wait until the recorder has matched the robot's topics (its summary counts them, /parameter_events too).
    _stderr_until(rec, " 3 topics")
    robot.send("go")
    assert robot.line() == "sent"
    _counts(rec, lambda c: _settled(c, 3 * 100))
    code, err = rec.end(signal.SIGINT)
    assert code == 0, err
    assert f"to {out}" in err
    decoded = _decoded(out)
    assert [m.data for _, m in decoded["/rosdashboard/early"]] == [42.5]
    # A tag's own topic is found at the next graph poll; its publisher keeps its last 100 values for a
    # late subscriber, so it holds at least those (all of them here unless the machine is very slow) ...
    speeds = [m.data for _, m in decoded["/rosdashboard/speed"]]
    assert len(speeds) >= 100
    assert speeds == [i * 0.5 for i in range(n - len(speeds), n)]
    counts = [m.data for _, m in decoded["/rosdashboard/count"]]
    assert counts == list(range(n - len(counts), n))
    states = [m.data for _, m in decoded["/rosdashboard/state"]]
    assert states == [f"step {i}" for i in range(n - len(states), n)]
    assert [m.data for _, m in decoded["/rosdashboard/late"]] == [True]
    assert "/_dbglog/samples" in decoded
    # Source times are the publishers', in order.
    stamps = [t for t, _ in decoded["/rosdashboard/speed"]]
    assert stamps == sorted(stamps)
    assert abs(stamps[-1] / 1e9 - time.time()) < 60
    # The file is whole (summary, indexes) and the dbglog reader agrees with the batches.
    recording = read_recording(out)
    assert recording.indexed
    assert recording.problems == []
    # ... and the batch topic, subscribed from the start, has every sample of every tag.
    series = tag_series(recording)
    assert series["speed"].values is not None
    assert list(series["speed"].values) == [i * 0.5 for i in range(n)]
    assert list(series["count"].values) == list(range(n))
    assert series["state"].values[-1] == f"step {n - 1}"
    table = tags_table(out)
    assert table.splitlines()[0].split() == [
        "tag",
        "type",
        "count",
        "rate",
        "first",
        "value",
        "last",
        "value",
    ]
    rows = {line.split()[0]: line.split() for line in table.splitlines()[2:]}
    assert rows["speed"][1:3] == ["std_msgs/msg/Float64", str(n)]
    assert rows["speed"][-2:] == ["0", str((n - 1) * 0.5).rstrip("0").rstrip(".")]
    assert rows["late"][-1] == "true"
    lines = list(echo_lines(out, "count", stamp=True))
    assert [line.split()[1] for line in lines] == [str(i) for i in range(n)]
    assert list(echo_lines(out, "/rosdashboard/state"))[:2] == ["step 0", "step 1"]


def test_record_topics_and_tags_given_as_targets(tmp_path: Path, procs: Callable[..., Proc]) -> None:
    """A /topic target records that topic (any type, best-effort QoS matched), a tag target its tag only."""
    peer = RosPeer("record_peer")
    try:
        qos = QoSProfile(
            depth=10, reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE
        )
        pub = peer.node.create_publisher(Twist, "/cmd_vel_rec", qos)
        other = peer.node.create_publisher(Twist, "/not_wanted", qos)
        robot = procs("-c", _ROBOT, "50", stdin=True)
        assert robot.line() == "ready"
        out = tmp_path / "some.mcap"
        rec = procs(*_record(out, "/cmd_vel_rec", "speed"))
        _stderr_until(rec, " 3 topics")  # the batch topic, /cmd_vel_rec and /parameter_events
        robot.send("go")
        assert robot.line() == "sent"
        for i in range(20):
            msg = Twist()
            msg.linear.x = float(i)
            pub.publish(msg)
            other.publish(msg)
            time.sleep(0.02)
        _stderr_until(rec, " 4 topics")  # and now speed
        _counts(rec, lambda c: _settled(c, 20 + 50))
        code, err = rec.end(signal.SIGTERM)
        assert code == 0, err
    finally:
        peer.close()
    decoded = _decoded(out)
    assert sorted(decoded) == ["/_dbglog/samples", "/cmd_vel_rec", "/rosdashboard/speed"]
    xs = [m.linear.x for _, m in decoded["/cmd_vel_rec"]]
    assert xs == sorted(xs)
    assert len(xs) >= 15  # best effort over loopback: nearly all
    assert [m.data for _, m in decoded["/rosdashboard/speed"]] == [i * 0.5 for i in range(50)]
    assert list(echo_lines(out, "/cmd_vel_rec.linear.x"))[:1] == [repr(xs[0])]


def test_record_after_sigkill_opens_missing_at_most_the_last_second(
    tmp_path: Path, procs: Callable[..., Proc]
) -> None:
    """A SIGKILLed recorder leaves a file that opens (scanned, said so) with all but the last second."""
    steady = procs("-c", _STEADY)
    assert steady.line() == "ready"
    out = tmp_path / "killed.mcap"
    rec = procs(*_record(out, "steady"))
    _stderr_until(rec, " 3 topics")  # the batch topic, steady and /parameter_events
    _counts(rec, lambda c: c[-1] > 500)
    killed_at = time.time()
    rec.proc.send_signal(signal.SIGKILL)
    rec.proc.wait(10)
    recording = read_recording(out)
    assert not recording.indexed
    assert len(recording.problems) == 1
    assert str(out) in recording.problems[0]
    assert "not finished" in recording.problems[0]
    values = recording.topics["/rosdashboard/steady"].values
    assert values is not None
    assert len(values) > 100
    assert list(values) == [float(v) for v in range(int(values[0]), int(values[0]) + len(values))]
    newest = recording.topics["/rosdashboard/steady"].times_ns[-1] / 1e9
    assert killed_at - newest <= 1.0 + 0.3  # flushed every 0.5 s; slack for a loaded machine


def test_record_refuses_to_overwrite_unless_forced(tmp_path: Path, procs: Callable[..., Proc]) -> None:
    """An existing output file is kept and named (exit 1); --force replaces it with a recording, a new
    file that gets 0666 less the umask (not the old file's 0600)."""
    out = tmp_path / "exists.mcap"
    out.write_bytes(b"keep me")
    out.chmod(0o600)
    done = subprocess.run(
        [sys.executable, *_record(out)], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == 1
    assert f"{out} already exists (use --force" in done.stderr
    assert out.read_bytes() == b"keep me"
    forced = subprocess.run(
        [sys.executable, *_record(out, "--force", "--duration", "1")],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        umask=0o027,
    )
    assert forced.returncode == 0, forced.stderr
    assert read_recording(out).indexed
    assert out.stat().st_mode & 0o777 == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exists.mcap"]


def test_record_rejects_a_malformed_target(tmp_path: Path) -> None:
    """A target that is neither a tag nor a topic is named with exit 2, before anything starts (any text is
    a tag now: 'a.b' is the tag a.b, so a topic with a dot is the malformed one)."""
    done = subprocess.run(
        [sys.executable, *_record(tmp_path / "x.mcap", "/odom.x")],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert "'/odom.x' is not a tag or a topic" in done.stderr
    assert not (tmp_path / "x.mcap").exists()


def test_snapshot_writes_the_ram_window_on_sigusr1(tmp_path: Path, procs: Callable[..., Proc]) -> None:
    """--snapshot keeps the last seconds in RAM; SIGUSR1 writes them to a new timestamped file."""
    steady = procs("-c", _STEADY)
    assert steady.line() == "ready"
    base = tmp_path / "snap.mcap"
    rec = procs(*_record(base, "steady", "--snapshot", "1.5"))
    # Ten seconds of recording first: a subscription that matched late receives its writer's kept history
    # (up to ~5 s of batches) at once, and that burst must lie outside the 1.5 s window being checked.
    # The window holds the batches (~100/s; the SDK tag's own topic is not subscribed, its samples are
    # written from the batches when the snapshot is taken).
    _counts(rec, lambda c: len(c) >= 10 and c[-1] > 50)
    # The summary says what left the window (the first seconds, long gone from 1.5 s).
    words = _stderr_until(rec, "dropped as older").replace(",", "").split()
    assert int(words[words.index("dropped") - 1]) > 100
    assert not base.exists()
    sent_at = time.time()
    rec.proc.send_signal(signal.SIGUSR1)
    line = _stderr_until(rec, "snapshot of the last 1.5 s")
    path = Path(line.rsplit(" written to ", 1)[1].strip())
    assert path.parent == tmp_path
    assert path.name.startswith("snap-")
    assert path.suffix == ".mcap"
    code, err = rec.end(signal.SIGINT)
    assert code == 0, err
    recording = read_recording(path)
    assert recording.indexed
    # The tag as a reader gets it: from the batch topic (every sample, source times) where the window holds
    # batches, else from its own topic (under load the per-tag copy may not have matched yet in 1.5 s).
    steady_series = tag_series(recording)["steady"]
    times = steady_series.times_ns / 1e9
    span = times[-1] - times[0]
    # The window is 1.5 s of reception time; source times spread a little more when delivery lagged.
    assert 0.5 <= span <= 2.6, span
    assert sent_at - times[-1] < 3.0, sent_at - times[-1]  # the newest messages are in it
    values = steady_series.values
    assert not isinstance(values, list)
    assert list(values) == [float(v) for v in range(int(values[0]), int(values[0]) + len(values))]
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


def test_snapshot_summary_counts_what_the_snapshot_then_writes(
    tmp_path: Path, procs: Callable[..., Proc]
) -> None:
    """--snapshot's summary counts what the window holds as a snapshot writes it (the samples of the batches
    it holds included), so the snapshot then writes that many messages, to the message."""
    n = 200
    robot = procs("-c", _ROBOT, str(n), stdin=True)
    assert robot.line() == "ready"
    base = tmp_path / "win.mcap"
    rec = procs(*_record(base, "--snapshot", "600"))
    _counts(rec, lambda c: c[-1] >= 2)  # subscribed: the batch that carried 'early', and its sample
    robot.send("go")
    assert robot.line() == "sent"
    # Every sample of the 3 tags (n each), 'early' and 'late', plus the batches that carried them.
    counts = _counts(rec, lambda c: _settled(c, 3 * n + 2))
    rec.proc.send_signal(signal.SIGUSR1)
    # The snapshot is taken right after a summary line, in the same pass of the take loop: the last
    # summary before it says what the window held when it was written.
    assert rec.proc.stderr is not None
    seen: list[str] = []
    while not (line := rec.proc.stderr.readline()).startswith("dbglog record: snapshot of the last 600 s"):
        assert line, seen[-3:]
        seen.append(line)
    held = int(seen[-1].replace(",", "").split("messages")[0].split()[-1]) if seen else counts[-1]
    written = int(line.split(": ", 2)[2].split()[0].replace(",", ""))
    path = Path(line.rsplit(" written to ", 1)[1].strip())
    code, err = rec.end(signal.SIGINT)
    assert code == 0, err
    assert held >= 3 * n + 2
    assert written == held, (seen[-1:], counts[-3:], line)
    recording = read_recording(path)
    assert sum(len(t) for t in recording.topics.values()) == written
    assert list(tag_series(recording)["count"].values) == list(range(n))
    assert path.stat().st_mode & 0o777 == 0o666 & ~_umask()


def _umask() -> int:
    """This process's umask (read without changing it, from /proc)."""
    with open("/proc/self/status") as f:
        return int(next(line.split()[1] for line in f if line.startswith("Umask:")), 8)


def test_record_help_names_sigusr1() -> None:
    """--help says how a snapshot is requested (SIGUSR1) and what is recorded by default."""
    done = subprocess.run(
        [sys.executable, "-m", "dbglog", "record", "--help"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        env={**os.environ, "COLUMNS": "120"},
    )
    assert done.returncode == 0
    assert "SIGUSR1" in done.stdout
    assert "/_dbglog/samples" in done.stdout
    assert "/rosout" in done.stdout


def test_record_no_batch_leaves_out_the_batch_topic(tmp_path: Path, procs: Callable[..., Proc]) -> None:
    """--no-batch records the tags' own topics only; tags then read from those."""
    robot = procs("-c", _ROBOT, "30", stdin=True)
    assert robot.line() == "ready"
    out = tmp_path / "small.mcap"
    rec = procs(*_record(out, "--no-batch"))
    _stderr_until(rec, " 2 topics")  # /rosdashboard/early and /parameter_events
    robot.send("go")
    assert robot.line() == "sent"
    _stderr_until(rec, " 6 topics")
    _counts(rec, lambda c: _settled(c, 1 + 3 * 30 + 1))
    code, err = rec.end(signal.SIGINT)
    assert code == 0, err
    decoded = _decoded(out)
    assert "/_dbglog/samples" not in decoded
    assert sorted(decoded) == [f"/rosdashboard/{t}" for t in ("count", "early", "late", "speed", "state")]
    assert list(echo_lines(out, "speed")) == [repr(i * 0.5) for i in range(30)]


def test_record_writes_sdk_tags_from_the_batch_without_subscribing_to_them(
    tmp_path: Path, procs: Callable[..., Proc]
) -> None:
    """A tag topic only SDK nodes publish is written from the batch (all samples); a peer's is subscribed."""
    from std_msgs.msg import Float64

    from dbglog._ros._qos import tag_qos

    n = 200
    peer = RosPeer("record_tag_peer")
    try:
        pub = peer.publisher("/rosdashboard/from_peer", Float64, tag_qos())
        robot = procs("-c", _ROBOT, str(n), stdin=True)
        assert robot.line() == "ready"
        out = tmp_path / "b.mcap"
        rec = procs(*_record(out))
        # The batch topic, early (from the batch), from_peer (subscribed), /rosout (the peer's) and
        # /parameter_events.
        _stderr_until(rec, " 5 topics")
        assert peer.wait_for_subscribers(pub)
        robot.send("go")
        assert robot.line() == "sent"
        for i in range(20):
            pub.publish(Float64(data=float(i)))
        _stderr_until(rec, " 9 topics")  # and speed, count, state, late

        def recorders(topic: str) -> list[str]:
            infos = peer.node.get_subscriptions_info_by_topic(topic)
            return [i.node_name for i in infos if i.node_name.startswith("dbglog_record_")]

        assert recorders("/_dbglog/samples")
        assert recorders("/rosdashboard/from_peer")
        assert recorders("/rosdashboard/speed") == []  # the SDK then publishes no per-sample copy
        _counts(rec, lambda c: _settled(c, 3 * n + 20))
        code, err = rec.end(signal.SIGINT)
        assert code == 0, err
        assert "batches missing 0, reported lost by DDS 0" in err
    finally:
        peer.close()
    decoded = _decoded(out)
    assert [m.data for _, m in decoded["/rosdashboard/speed"]] == [i * 0.5 for i in range(n)]
    assert [m.data for _, m in decoded["/rosdashboard/count"]] == list(range(n))
    assert [m.data for _, m in decoded["/rosdashboard/state"]] == [f"step {i}" for i in range(n)]
    assert [m.data for _, m in decoded["/rosdashboard/early"]] == [42.5]
    assert [m.data for _, m in decoded["/rosdashboard/late"]] == [True]
    assert [m.data for _, m in decoded["/rosdashboard/from_peer"]] == [float(i) for i in range(20)]
    stamps = [t for t, _ in decoded["/rosdashboard/speed"]]
    assert stamps == sorted(stamps)
