"""What the viewer's watches cost its UI thread, and how soon a widget's watch is armed (docs/watch.md).

Run: ``.venv/bin/python benchmarks/bench_watch_viewer.py [--arms 10]``; prints Markdown tables.

* **per look**: `WatchKeeper.poll` (a frame hook: it runs at every turn of the frame loop, ~10 a second
  idle, once a frame while drawing) with 0 to 1000 widgets showing watches, the service's reports
  unchanged (the steady state); µs a call, the best of 5 x 200.
* **to armed**: a `WatchService` against a real program (tests/data/watch/loop.py under ``dbglog run``):
  seconds from `keep` (a widget added, a dashboard opened) to the watch's report saying ``armed`` with its
  topic, then to ``keep({})`` leaving nothing armed in the program (a widget deleted); medians and
  maxima over `--arms` rounds.
* **killed -> gone**: seconds from SIGKILL of a program whose watch is armed to the report saying
  ``gone`` (its node stays on the graph for the middleware's lease; the client asks the pid), over
  `--kills` programs.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
import timeit
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks._common import local_ros_env, print_table  # noqa: E402

LOOP = ROOT / "tests" / "data" / "watch" / "loop.py"
STEP = 31
"""loop.py's ``# L:step`` line."""


class _Item:
    """A widget as the keeper reads it (its saved entry, its note), without a window."""

    def __init__(self, config: object) -> None:
        self.config, self.note, self.widget_cls, self.bindings = config, None, None, ()


class _Doc:
    def __init__(self, items: list[_Item]) -> None:
        self.items = items


class _NoDialogs:
    current = None


class _NoCanvas:
    """Never asked: no widget is added."""


def per_look(counts: tuple[int, ...]) -> list[list[object]]:
    """µs per `WatchKeeper.poll` with `counts` watched widgets (reports unchanged)."""
    from dbglog.viewer._document._dashboard import WatchConfig, WidgetConfig
    from dbglog.viewer._publishing._watches import WatchService
    from dbglog.viewer._ui._watches import WatchKeeper

    def no_client() -> object:
        raise RuntimeError("not needed: the reports stay as they are")

    rows: list[list[object]] = []
    for n in counts:
        items = [
            _Item(
                WidgetConfig("plot", f"w{i}", 0, 0, 100, 100, watch=WatchConfig(str(LOOP), STEP, (f"x{i}",)))
            )
            for i in range(n)
        ]
        service: WatchService[WatchConfig] = WatchService(no_client)  # type: ignore[arg-type]
        keeper = WatchKeeper(
            _Doc(items),  # type: ignore[arg-type]
            _NoDialogs(),  # type: ignore[arg-type]
            _NoCanvas(),  # type: ignore[arg-type]
            say=lambda _t: None,
            wake=lambda: None,
            service=service,
        )
        keeper.poll()
        time.sleep(0.3)  # the service has said its (failed) reports
        keeper.poll()
        best = min(timeit.repeat(keeper.poll, number=200, repeat=5)) / 200
        rows.append([n, f"{best * 1e6:.1f}"])
        service.close()
    return rows


def _until(check: Callable[[], bool], timeout: float = 60.0) -> float:
    start = time.monotonic()
    while not check():
        if time.monotonic() - start > timeout:
            raise TimeoutError("no answer in time")
        time.sleep(0.005)
    return time.monotonic() - start


def to_armed(arms: int) -> list[list[object]]:
    """Seconds from `keep` to armed, and from `keep({})` to nothing armed, against a real program."""
    from dbglog.viewer._publishing._watches import WatchService
    from dbglog.watch.client import WatchClient, WatchSpec

    tmp = Path(tempfile.mkdtemp(prefix="bench_watch_viewer_"))
    env = {k: v for k, v in os.environ.items() if not k.startswith("DBGLOG_WATCH") and k != "DBGLOG"}
    program = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "run", str(LOOP), str(tmp / "out"), str(tmp / "stop")],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    service: WatchService[str] = WatchService()  # reads its watches every POLL_S, as the viewer's
    observer = WatchClient()  # sees the program's announcements as they come
    armed, gone = [], []
    try:
        service.start()
        _until(lambda: any(p.pid == program.pid for p in service.processes()))

        def watches() -> int:
            return sum(len(p.watches) for p in observer.processes() if p.pid == program.pid)

        for i in range(arms):
            key = f"speed{i}"
            service.keep({key: WatchSpec(str(LOOP), STEP, ("speed",), label=f"bench/speed{i}")})
            armed.append(_until(lambda k=key: service.report(k).state == "armed"))  # type: ignore[misc]
            service.keep({})
            gone.append(_until(lambda: watches() == 0))
    finally:
        service.close()
        observer.close()
        (tmp / "stop").touch()
        program.wait(30)
    return [
        ["keep -> armed (report)", f"{statistics.median(armed):.3f}", f"{max(armed):.3f}"],
        ["keep({}) -> nothing armed in the program", f"{statistics.median(gone):.3f}", f"{max(gone):.3f}"],
    ]


def _program(tmp: Path, name: str) -> subprocess.Popen[bytes]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("DBGLOG_WATCH") and k != "DBGLOG"}
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "dbglog",
            "run",
            str(LOOP),
            str(tmp / f"{name}.out"),
            str(tmp / f"{name}.stop"),
        ],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


def to_gone(kills: int) -> list[list[object]]:
    """Seconds from killing a program whose watch is armed to the watch's report saying ``gone``."""
    from dbglog.viewer._publishing._watches import WatchService
    from dbglog.watch.client import WatchSpec

    tmp = Path(tempfile.mkdtemp(prefix="bench_watch_gone_"))
    service: WatchService[str] = WatchService()
    service.keep({"speed": WatchSpec(str(LOOP), STEP, ("speed",))})
    seconds = []
    try:
        for i in range(kills):
            program = _program(tmp, f"run{i}")
            try:
                _until(lambda p=program: f"pid {p.pid}" in service.report("speed").message)  # type: ignore[misc]
                _until(lambda: service.report("speed").state == "armed")
            finally:
                program.kill()
                program.wait(30)
            seconds.append(_until(lambda: service.report("speed").state == "gone"))
    finally:
        service.close()
    return [["SIGKILL -> gone (report)", f"{statistics.median(seconds):.2f}", f"{max(seconds):.2f}"]]


def main() -> int:
    """Run the measurements and print their tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", type=int, default=10, help="rounds of arming and disarming (default 10)")
    parser.add_argument("--kills", type=int, default=3, help="programs killed while watched (default 3)")
    args = parser.parse_args()
    local_ros_env()
    print(f"Python {sys.version.split()[0]}, load {os.getloadavg()[0]:.1f}")
    print_table("WatchKeeper.poll per look", ["watched widgets", "µs a call"], per_look((0, 10, 100, 1000)))
    print_table(
        f"A watch in a real program ({args.arms} rounds)", ["", "median s", "max s"], to_armed(args.arms)
    )
    print_table(
        f"A watched program killed ({args.kills} programs)", ["", "median s", "max s"], to_gone(args.kills)
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
