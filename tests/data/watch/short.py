"""A short-lived script for the watch tests: counts until the file STOP exists (at most SECONDS), then exits.

Usage: short.py SECONDS STOP (run as plain.py too: a copy that nothing makes watchable).
"""

import os
import sys
import time

end = time.monotonic() + float(sys.argv[1])
n = 0
while time.monotonic() < end and not os.path.exists(sys.argv[2]):
    n += 1
    time.sleep(0.01)  # L:short
print("counted", n > 0)
