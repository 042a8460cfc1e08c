"""A robot of a fleet: many tags in subsystems, logged through the dbglog SDK at a steady rate.

``python -m benchmarks._fleet --subsystems 15 --tags 20 --rate 10`` runs one robot (its namespace from
``DBGLOG_NAMESPACE``, as a lab starts identical robots); `bench_ui` and the automatic dashboard's tests start
two. Subsystem ``s<k>`` logs ``v0``... (numbers whose magnitudes cycle through 0.1, 1, 10 and 100), then
three bools (``ok``, ``fault``, ``ready``) and three strings (``state``, ``mode``, ``error``): 14 numbers
and 6 states of 20 tags. With ``--late S``, subsystem ``s0`` also logs ``v_late`` (a number near 1) and
``late_flag`` (a bool) from S seconds on (``--tags 0``: those two alone). It prints ``publishing`` once
every tag has been logged once.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

STATES = ("ok", "fault", "ready", "state", "mode", "error")
"""The non-numeric tags of a subsystem (three in ten of its tags, up to six): bools, then strings."""
BOOLS = frozenset({"ok", "fault", "ready"})


def tag_names(subsystems: int, tags: int) -> list[tuple[str, str]]:
    """Every (tag, kind) a robot logs: kind ``number``, ``bool`` or ``string``."""
    out = []
    states = min(len(STATES), tags * 3 // 10)
    for k in range(subsystems):
        for j in range(tags - states):
            out.append((f"s{k}/v{j}", "number"))
        for name in STATES[:states]:
            out.append((f"s{k}/{name}", "bool" if name in BOOLS else "string"))
    return out


def value(tag: str, t: float) -> float:
    """The number a tag ``s<k>/v<j>`` logs at time `t`: a sine of amplitude 10^(j mod 4 - 1)."""
    k, j = (int(part[1:]) for part in tag.split("/"))
    return 10.0 ** (j % 4 - 1) * math.sin(0.4 * t + 0.3 * j + k)


def main(argv: list[str] | None = None) -> int:
    """Log every tag at the rate until killed."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--subsystems", type=int, default=15)
    parser.add_argument("--tags", type=int, default=20, help="tags per subsystem")
    parser.add_argument("--rate", type=float, default=10.0, help="times a second each tag is logged")
    parser.add_argument("--late", type=float, default=0.0, help="log two more tags after this many seconds")
    args = parser.parse_args(argv)
    import dbglog

    names = tag_names(args.subsystems, args.tags)
    period = 1.0 / args.rate
    start = time.monotonic()
    tick = 0
    while True:
        t = time.time()
        for tag, kind in names:
            if kind == "number":
                dbglog.logfloat(tag, value(tag, t))
            elif kind == "bool":
                dbglog.logbool(tag, (int(t) + len(tag)) % 4 != 0)
            else:
                dbglog.logstring(tag, ("idle", "running", "paused")[(int(t / 3) + len(tag)) % 3])
        if args.late and time.monotonic() - start >= args.late:
            dbglog.logfloat("s0/v_late", 1.0 + 0.5 * math.sin(t))
            dbglog.logbool("s0/late_flag", int(t) % 2 == 0)
        if tick == 0:
            print("publishing", flush=True)
        tick += 1
        delay = start + tick * period - time.monotonic()
        if delay > 0:
            time.sleep(delay)


if __name__ == "__main__":
    sys.exit(main())
