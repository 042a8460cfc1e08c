"""A plain script for the watch tests (run by ``dbglog run``): it never imports dbglog.

Usage: loop.py OUT STOP. Each step's values go to OUT as a JSON line; it stops once the file STOP exists
and then writes how often the property with a side effect was read, and how it was started.
"""

import json
import os
import sys
import threading
import time
from typing import TextIO


class Robot:
    def __init__(self) -> None:
        self.speed = 0.0
        self.reads = 0

    @property
    def costly(self) -> int:
        self.reads += 1  # a side effect that a watch must never cause
        return 42


def step(robot: Robot, i: int, out: TextIO) -> None:
    speed = i * 0.5
    robot.speed = speed
    config = {"gain": i, "mode": "run"}
    ranges = [float(i), i + 0.25]
    out.write(json.dumps({"i": i, "speed": speed, "ranges": ranges, "config": config}) + "\n")  # L:step
    out.flush()


def hot(n: int) -> int:
    acc = 0
    for k in range(n):
        acc += k  # L:hot
    return acc


def ticker(stop: threading.Event) -> None:
    ticks = 0
    while not stop.is_set():
        ticks += 1
        time.sleep(0.01)  # L:ticker


def main() -> None:
    out_path, stop_path = sys.argv[1], sys.argv[2]
    robot = Robot()
    stop = threading.Event()
    thread = threading.Thread(target=ticker, args=(stop,), name="ticker")
    thread.start()
    with open(out_path, "w") as out:
        i = 0
        while not os.path.exists(stop_path):
            i += 1
            step(robot, i, out)
            hot(200)
            time.sleep(0.01)
        stop.set()
        thread.join()
        end = {"reads": robot.reads, "argv": sys.argv, "path0": sys.path[0], "name": __name__}
        out.write(json.dumps(end) + "\n")


if __name__ == "__main__":
    main()
