"""``dbglog tags`` and ``dbglog echo`` as real subprocesses against publishers in their own processes."""

from __future__ import annotations

import contextlib
import itertools
import os
import random
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import IO

import pytest
from std_msgs.msg import Float64

from dbglog.viewer._data._suggest import DISCOVERY_HORIZON_S
from tests._children import run_dbglog
from tests._ros import RosPeer, first_line, wait_until

TIMEOUT = 90
_ANNOUNCE_PERIOD_S = 3.0
"""How often a Fast DDS participant announces itself (a newcomer that missed its handshake finds it then)."""

# A robot process: the dbglog SDK publishing `count` tags under `prefix` at `hz`; `once` tags once.
_PUBLISHER = """
import sys, time
import dbglog
prefix, count, hz = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
for name in sys.argv[4:]:
    dbglog.logfloat(f"{prefix}/{name}", 3.5)
i = 0
try:
    while True:
        for k in range(count):
            dbglog.logfloat(f"{prefix}/t{k}", i + k / 100)
        if i == 0:
            print("publishing", flush=True)
        i += 1
        time.sleep(1 / hz)
except KeyboardInterrupt:  # `Robot.stop`: a clean exit
    pass
"""


class Robot:
    """A publisher process (real dbglog SDK) that is killed at the end."""

    def __init__(self, prefix: str, count: int, hz: float, *once: str) -> None:
        self.prefix = prefix
        self.tags = [f"{prefix}/t{k}" for k in range(count)]
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _PUBLISHER, prefix, str(count), str(hz), *once],
            stdout=subprocess.PIPE,
            text=True,
        )
        assert self.proc.stdout is not None
        assert first_line(self.proc.stdout) == "publishing", "the publisher process did not start"
        self.started = time.monotonic()

    def kill(self) -> None:
        """Kill the process at once (SIGKILL: no clean shutdown, as when a node crashes)."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(10)
        if self.proc.stdout is not None:
            self.proc.stdout.close()

    def stop(self) -> None:
        """End the process cleanly (SIGINT: its participant says goodbye), else kill it.

        A process that takes the id (the ports) of a participant killed outright moments before is found
        only at its next announcement, 3 s later (docs/engine.md, *Discovery*); after a clean exit it was
        found at once or 2 s later (4 runs): the next test's `dbglog tags` waits less."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.proc.wait(10)
        self.kill()


@pytest.fixture
def robots() -> Iterator[Callable[..., Robot]]:
    """Start publisher processes on demand; kill them all afterwards."""
    started: list[Robot] = []

    def start(prefix: str, count: int, hz: float, *once: str) -> Robot:
        robot = Robot(prefix, count, hz, *once)
        started.append(robot)
        return robot

    yield start
    for robot in started:
        robot.stop()


def _dbglog(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return run_dbglog(*args, timeout=TIMEOUT, env=env)


def _table(stdout: str) -> dict[str, list[str]]:
    """Parse a `dbglog tags` table into {tag: [type, rate, last value, status]} (rates keep their unit)."""
    lines = stdout.splitlines()
    assert lines[0].split() == ["tag", "type", "rate", "last", "value", "status"], stdout
    rows = {}
    for line in lines[2:]:
        cells = line.split()
        if cells[2] != "-":  # "19.8 Hz": join the unit back
            cells[2:4] = [f"{cells[2]} {cells[3]}"]
        rows[cells[0]] = cells[1:]
    return rows


def _said_of(stderr: str, *robots: Robot) -> str:
    """`dbglog tags`' stderr less its line on participants it never found when it names none of `robots`
    (a process another test of this worker left on the domain, stopped or going away, is named there)."""
    pids = [f"pid {robot.proc.pid} " for robot in robots]
    return "\n".join(
        line
        for line in stderr.splitlines()
        if not ("DDS participant" in line and "not found" in line and not any(p in line for p in pids))
    )


def _hz(cell: str) -> float:
    assert cell.endswith(" Hz"), cell
    return float(cell.removesuffix(" Hz"))


def _until_published(*tags: str, timeout: float = 30.0) -> None:
    """Wait until a plain ROS subscriber has a value from each tag (the publishers are up and discovered)."""
    from dbglog._ros._qos import tag_qos

    with RosPeer("cli_live_probe") as peer:
        collectors = [peer.subscribe(f"/rosdashboard/{tag}", Float64, tag_qos()) for tag in tags]
        assert wait_until(lambda: all(c.messages for c in collectors), timeout), "publishers not up"


def test_tags_lists_every_tag_of_two_processes_every_run(robots: Callable[..., Robot]) -> None:
    """Two publisher processes with six tags each: every `dbglog tags` run lists all twelve with values."""
    fast, slow = robots("lv_fast", 6, 20.0), robots("lv_slow", 6, 2.0)
    _until_published(fast.tags[0], slow.tags[0])
    # Each run is a newcomer that must find both publishers within its 4 s discovery horizon; they miss
    # the handshake only sometimes, so several runs are checked. They overlap (one after another they took
    # 4 x 5 s), each started a quarter of Fast DDS's 3 s announcement period after the one before: their
    # starts fall at phases spread over that period, as sequential runs' starts did.
    runs = 4
    with ThreadPoolExecutor(runs) as pool:
        started = []
        for run in range(runs):
            if run:
                time.sleep(_ANNOUNCE_PERIOD_S / runs)
            started.append(pool.submit(_dbglog, "tags"))
        outs = [future.result() for future in started]
    for run, out in enumerate(outs):
        assert out.returncode == 0, out.stderr
        rows = _table(out.stdout)
        missing = set(fast.tags + slow.tags) - set(rows)
        assert not missing, f"run {run}: {sorted(missing)} missing from\n{out.stdout}\n{out.stderr}"
        for tag in fast.tags + slow.tags:
            _, rate, value, status = rows[tag]
            assert status == "live", f"run {run}: {tag}: {rows[tag]}"
            assert value != "-", f"run {run}: {tag}: {rows[tag]}"
            assert rate != "-", f"run {run}: {tag}: {rows[tag]}"
        assert _said_of(out.stderr, fast, slow) == "", out.stderr


def test_tags_lists_in_natural_order_and_settle_sets_the_least_wait(robots: Callable[..., Robot]) -> None:
    """Rows in natural order (t2 before t10), whether the table prints once every participant is found
    (the default: no least wait, `test_tags_waits_for_discovery_only_as_long_as_the_census_needs`) or after
    --settle's least wait; a negative one is refused. How soon the default prints is a benchmark's figure
    (docs/performance.md): a participant that takes the id of one killed moments before is found 3 s late
    (Fast DDS), and it took 4.6 s in a loaded CI run."""
    robot = robots("lv_nat", 12, 20.0)
    _until_published(robot.tags[0])
    default = _dbglog("tags")
    begun = time.monotonic()
    settled = _dbglog("tags", "--settle", "4")
    took_settled = time.monotonic() - begun
    for out in (default, settled):
        assert out.returncode == 0, out.stderr
        listed = [tag for tag in _table(out.stdout) if tag.startswith("lv_nat/")]
        assert listed == [f"lv_nat/t{k}" for k in range(12)], out.stdout
        assert _said_of(out.stderr, robot) == "", out.stderr
    assert took_settled >= 4.0
    refused = _dbglog("tags", "--settle", "-1")
    assert refused.returncode == 2
    assert "--settle must be >= 0" in refused.stderr


def test_tags_waits_for_every_participant_of_this_host_and_says_which_it_never_found(
    robots: Callable[..., Robot],
) -> None:
    """A participant of this host that is never found (a socket on a discovery port that never answers)
    holds the table back until the discovery horizon; then the table prints and stderr says it is missing."""
    from dbglog._ros._census import metatraffic_ports

    robot = robots("lv_silent", 3, 20.0)
    _until_published(robot.tags[0])
    port = metatraffic_ports(int(os.environ["ROS_DOMAIN_ID"]))[-1]
    holder = (  # a participant's two ports: discovery, and user data above it
        "import socket, time; s = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in '12']; "
        f"s[0].bind(('127.0.0.1', {port})); s[1].bind(('127.0.0.1', {port + 1})); "
        "print('bound', flush=True); time.sleep(60)"
    )
    with subprocess.Popen([sys.executable, "-c", holder], stdout=subprocess.PIPE, text=True) as silent:
        try:
            assert silent.stdout is not None
            assert silent.stdout.readline() == "bound\n"
            begun = time.monotonic()
            out = _dbglog("tags")
            took = time.monotonic() - begun
        finally:
            silent.kill()
    assert out.returncode == 0, out.stderr
    assert [tag for tag in _table(out.stdout) if tag.startswith("lv_silent/")] == robot.tags
    assert took >= 4.0
    # other tests' participants may come and go meanwhile: the count is at least this one, and it is named
    assert re.search(r"\d+ DDS participants? on this host .* not found in", out.stderr), out.stderr
    assert f"pid {silent.pid} ({(sys.executable + ' -c import socket')[:24]}" in out.stderr, out.stderr
    assert "missing from the table" in out.stderr, out.stderr


def test_tags_rates_are_true_and_stale_tags_have_none(robots: Callable[..., Robot]) -> None:
    """Rates match 2 Hz and 20 Hz publishers; a tag set once long ago and a killed process show no rate."""
    fast = robots("lv_rate20", 3, 20.0, "latched")
    slow = robots("lv_rate2", 3, 2.0)
    _until_published(fast.tags[0], slow.tags[0])
    time.sleep(max(0.0, 3.0 - (time.monotonic() - fast.started)))  # the latched value is > 2 s old
    rows = _table(_dbglog("tags").stdout)
    for tag in fast.tags:
        assert 14.0 <= _hz(rows[tag][1]) <= 26.0, rows[tag]
    for tag in slow.tags:
        assert 1.4 <= _hz(rows[tag][1]) <= 2.6, rows[tag]
    assert rows["lv_rate20/latched"][1:] == ["-", "3.5", "stale"]

    slow.kill()
    out = _dbglog("tags")
    rows = _table(out.stdout)
    for tag in fast.tags:
        assert rows[tag][3] == "live", (rows[tag], out.stderr)
        assert 14.0 <= _hz(rows[tag][1]) <= 26.0, rows[tag]
    for tag in slow.tags:
        # Gone from the graph (same host: the participant is dropped at once); listed only while a
        # remote participant's lease runs, and then never with a rate.
        assert tag not in rows or (rows[tag][1] == "-" and rows[tag][3] in ("stale", "waiting")), rows


def test_tags_names_a_published_tag_that_sends_nothing() -> None:
    """A tag whose (volatile) publisher never publishes is listed `waiting` and named on stderr."""
    with RosPeer("cli_live_silent") as peer:
        peer.publisher("/rosdashboard/lv_silent", Float64)
        out = _dbglog("tags")
    assert out.returncode == 0, out.stderr
    rows = _table(out.stdout)
    assert rows["lv_silent"][1:] == ["-", "-", "waiting"]
    assert "waiting for a first value from lv_silent" in out.stderr


def _unused_domain() -> int:
    """A domain of 215-232 on which no participant of this host listens now (the census's sockets)."""
    from dbglog._ros._census import _read_tables, participant_sockets, udp_sockets

    sockets = udp_sockets(_read_tables() or [])
    free = [d for d in range(215, 233) if not participant_sockets(sockets, d)]
    assert free, "every domain of 215-232 has a participant on this host"
    return random.SystemRandom().choice(free)


def _waited(stdout: str) -> float:
    """The seconds an empty table says it waited ("... waited 0.5 s) ...")."""
    match = re.search(r"waited ([0-9.]+) s\)", stdout)
    assert match is not None, stdout
    return float(match.group(1))


def test_tags_on_an_empty_graph_hints_at_the_domain_without_waiting_for_wait() -> None:
    """With nothing on the graph, the table says so and hints at ROS_DOMAIN_ID and the discovery range;
    as no other participant of the domain is on this host, it says so once the graph settled, neither
    at --wait nor at the discovery horizon."""
    env = {**os.environ, "ROS_DOMAIN_ID": str(_unused_domain())}
    out = _dbglog("tags", "--wait", "60", env=env)
    assert out.returncode == 0, out.stderr
    assert "no dbglog tags" in out.stdout
    assert "ROS_DOMAIN_ID" in out.stdout
    assert "ROS_AUTOMATIC_DISCOVERY_RANGE" in out.stdout
    assert _waited(out.stdout) < DISCOVERY_HORIZON_S, out.stdout


def test_tags_beside_a_node_without_tags_waits_the_horizon_then_says_none() -> None:
    """A node on the graph may still be listing its topics: with no tag, the table waits the discovery
    horizon (not --wait) before it says there is none."""
    with RosPeer("cli_live_no_tags") as peer:
        peer.publisher("/lv_plain", Float64)
        out = _dbglog("tags", "--wait", "60")
    assert out.returncode == 0, out.stderr
    assert "no dbglog tags" in out.stdout
    assert "ROS_AUTOMATIC_DISCOVERY_RANGE" not in out.stdout, "the graph has topics: no domain hint"
    assert DISCOVERY_HORIZON_S <= _waited(out.stdout) < 60, out.stdout


def _stamped_lines(*args: str, count: int) -> list[tuple[float, float, str]]:
    """Run `dbglog echo ... --stamp` and return (wall time read, source stamp, value) per line."""
    with subprocess.Popen(
        [sys.executable, "-m", "dbglog", "echo", *args, "--stamp", "--timeout", "30"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    ) as proc:
        assert proc.stdout is not None
        lines = []
        for line in proc.stdout:
            stamp, value = line.split()
            lines.append((time.time(), float(stamp), value))
            if len(lines) == count:
                break
        assert proc.wait(TIMEOUT) == 0, proc.stderr.read() if proc.stderr else ""
    return lines


def test_echo_n1_prints_the_current_value(robots: Callable[..., Robot]) -> None:
    """`echo TAG -n 1` prints the newest value (not the oldest kept one), then -n 3 the next ones."""
    robot = robots("lv_echo", 1, 20.0)
    _until_published(robot.tags[0])
    time.sleep(max(0.0, 6.0 - (time.monotonic() - robot.started)))  # over 5 s of kept history
    for _ in range(3):
        [(read_at, stamp, _value)] = _stamped_lines(robot.tags[0], "-n", "1", count=1)
        assert read_at - stamp < 0.5, f"printed a value {read_at - stamp:.2f} s old"
    lines = _stamped_lines(robot.tags[0], "-n", "3", count=3)
    stamps = [stamp for _, stamp, _ in lines]
    assert lines[0][0] - stamps[0] < 0.5
    assert len(set(stamps)) == 3
    assert all(0.02 < b - a < 0.5 for a, b in itertools.pairwise(stamps)), stamps


def test_echo_history_prints_the_kept_values_first(robots: Callable[..., Robot]) -> None:
    """`echo TAG --history` starts with the kept history, oldest first, then goes on live."""
    robot = robots("lv_hist", 1, 20.0)
    _until_published(robot.tags[0])
    time.sleep(max(0.0, 6.0 - (time.monotonic() - robot.started)))
    lines = _stamped_lines(robot.tags[0], "--history", "-n", "60", count=60)
    stamps = [stamp for _, stamp, _ in lines]
    values = [float(value) for _, _, value in lines]
    assert stamps == sorted(stamps)
    assert values == sorted(values)
    assert lines[-1][0] - stamps[0] > 2.5, "the first line is not from the kept history"


def test_echo_help_states_the_count_rule() -> None:
    """`dbglog echo --help` says that -n starts from the newest value and offers --history."""
    out = _dbglog("echo", "--help")
    text = " ".join(out.stdout.split())
    assert "first the current value (the newest one a latched tag kept), then the next N-1" in text
    assert "--history" in text


def _stderr_line(proc: subprocess.Popen[str], timeout: float) -> str:
    """Read one stderr line of `proc` within `timeout` seconds ('' if none came)."""
    got: list[str] = []
    stream: IO[str] | None = proc.stderr
    assert stream is not None
    reader = threading.Thread(target=lambda: got.append(stream.readline()), daemon=True)
    reader.start()
    reader.join(timeout)
    return got[0] if got else ""


@pytest.mark.parametrize(
    ("target", "expected"),
    [
        ("lv_motor", "nothing publishes /rosdashboard/lv_motor itself; it has sub-topics: "),
        ("lv_motr/t0", "nothing publishes /rosdashboard/lv_motr/t0; did you mean /rosdashboard/lv_motor/t0"),
    ],
)
def test_echo_unpublished_target_says_why_and_keeps_waiting(
    robots: Callable[..., Robot], target: str, expected: str
) -> None:
    """Without --timeout, a dict parent or a typo is explained on stderr after a few seconds; echo goes on."""
    robot = robots("lv_motor", 2, 5.0)
    _until_published(*robot.tags)
    with subprocess.Popen(
        [sys.executable, "-m", "dbglog", "echo", target],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    ) as proc:
        started = time.monotonic()
        try:
            line = _stderr_line(proc, 30)
            said_at = time.monotonic() - started
            assert expected in line, line
            if "sub-topics" in expected:
                assert "/rosdashboard/lv_motor/t0, /rosdashboard/lv_motor/t1" in line
            assert "still waiting" in line
            assert said_at > 2.0, f"said after {said_at:.1f} s: too early to judge"
            time.sleep(0.5)
            assert proc.poll() is None, "echo must keep waiting"
        finally:
            proc.terminate()
            proc.wait(10)


def test_echo_on_an_empty_graph_hints_at_the_domain() -> None:
    """With nothing on the graph, echo's note hints at ROS_DOMAIN_ID and the discovery range."""
    env = {**os.environ, "ROS_DOMAIN_ID": str(random.SystemRandom().randint(215, 232))}
    with subprocess.Popen(
        [sys.executable, "-m", "dbglog", "echo", "lv_nothing"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    ) as proc:
        try:
            line = _stderr_line(proc, 30)
            assert "ROS_DOMAIN_ID" in line, line
            assert "ROS_AUTOMATIC_DISCOVERY_RANGE" in line, line
        finally:
            proc.terminate()
            proc.wait(10)
