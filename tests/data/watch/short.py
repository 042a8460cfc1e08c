"""A short-lived script for the watch tests: counts for SECONDS seconds, then exits.

Usage: short.py SECONDS (run it as plain.py too, a copy that nothing makes watchable).
"""

import sys
import time

end = time.monotonic() + float(sys.argv[1])
n = 0
while time.monotonic() < end:
    n += 1
    time.sleep(0.01)  # L:short
print("counted", n > 0)
