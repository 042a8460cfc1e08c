"""An rclpy node for the watch tests: a 100 Hz timer, dbglog imported (DBGLOG_WATCH=1 makes it watchable).

Usage: talker.py STOP [NODE_AFTER]. It spins until the file STOP exists; NODE_AFTER: seconds to wait before
making its node, or a file it waits for first (it is watchable, by its program's name, meanwhile).
"""

import os
import sys
import time

import rclpy

import dbglog


class Talker:
    def __init__(self) -> None:
        self.node = rclpy.create_node("watch_talker")
        self.count = 0
        self.node.create_timer(0.01, self.tick)

    def tick(self) -> None:
        self.count += 1
        dbglog.logint("talker/count", self.count)  # L:tick


def main() -> None:
    if len(sys.argv) > 2:
        try:
            time.sleep(float(sys.argv[2]))
        except ValueError:  # a file: made by the test once it saw the program without a node
            while not os.path.exists(sys.argv[2]):
                time.sleep(0.02)
    rclpy.init()
    talker = Talker()
    while not os.path.exists(sys.argv[1]):
        rclpy.spin_once(talker.node, timeout_sec=0.05)
    talker.node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
