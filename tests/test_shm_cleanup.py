"""The suite's clean-up of Fast DDS segments left by the processes it killed (tests/_shm.py)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

from tests._ros import wait_until
from tests._shm import SHM, dead_segments, remove_dead_segments

_HOLD = (
    "import fcntl, os, sys; fd = os.open(sys.argv[1], os.O_RDONLY); fcntl.flock(fd, fcntl.LOCK_EX); "
    "print('held', flush=True); sys.stdin.read()"
)
_NODE = (
    "import rclpy, sys; rclpy.init(); node = rclpy.create_node('shm_victim'); "
    "print('up', flush=True); sys.stdin.read()"
)


def _segment(folder: Path, name: str, age: float) -> Path:
    """A segment and its lock file, both made `age` seconds ago."""
    segment, lock = folder / name, folder / f"{name}_el"
    segment.write_bytes(b"\0" * 64)
    lock.touch()
    made = time.time() - age
    for path in (segment, lock):
        os.utime(path, (made, made))
    return segment


def test_only_the_unlocked_segments_made_during_the_run_are_removed(tmp_path: Path) -> None:
    """A segment whose lock nobody holds goes with its lock file; one held, one just made, one older than
    the run and a port's segment stay."""
    since = time.time() - 100
    dead = _segment(tmp_path, "fastrtps_00000000000000aa", 30)
    held = _segment(tmp_path, "fastrtps_00000000000000bb", 30)
    young = _segment(tmp_path, "fastrtps_00000000000000cc", 1)
    before = _segment(tmp_path, "fastrtps_00000000000000dd", 1000)
    port = _segment(tmp_path, "fastrtps_port7000", 30)
    with subprocess.Popen(
        [sys.executable, "-c", _HOLD, f"{held}_el"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    ) as holder:
        assert holder.stdout is not None
        assert holder.stdin is not None
        assert holder.stdout.readline() == "held\n"
        assert dead_segments(since, tmp_path) == [dead]
        assert remove_dead_segments(since, tmp_path) == 1
        holder.stdin.close()
    left = {p.name for p in tmp_path.iterdir()}
    assert not {dead.name, f"{dead.name}_el"} & left
    for kept in (held, young, before, port):
        assert {kept.name, f"{kept.name}_el"} <= left
    assert dead_segments(since, tmp_path) == [held], "its holder gone, the held one is dead too"


def test_a_killed_nodes_segment_is_dead_and_a_living_ones_is_not() -> None:
    """A real rclpy process's segment is not listed while it runs, and is once it was SIGKILLed."""
    since = time.time() - 1
    with subprocess.Popen(
        [sys.executable, "-c", _NODE], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    ) as node:
        assert node.stdout is not None
        assert node.stdin is not None
        try:
            assert node.stdout.readline() == "up\n"
            up_at = time.time()  # its segment was made and locked before
            maps = Path(f"/proc/{node.pid}/maps").read_text()
            mine = {SHM / m for m in re.findall(r"/dev/shm/(fastrtps_[0-9a-f]{16})\s*$", maps, re.M)}
            assert mine, "the node maps a segment of its own"
            assert not mine & set(dead_segments(since, settled_s=0.0))
        finally:
            node.send_signal(signal.SIGKILL)
    assert wait_until(lambda: mine <= set(dead_segments(since, settled_s=0.0)), timeout=10)
    # only segments made before it was up (another suite's participant may be making one now)
    assert remove_dead_segments(since, settled_s=time.time() - up_at) >= len(mine)
    assert not [p for p in mine if p.exists() or p.with_name(f"{p.name}_el").exists()]
