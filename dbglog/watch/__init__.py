"""Watches: a line of a running Python program and a variable become a live dbglog tag (docs/watch.md).

``dbglog.watch.client`` is the watchers' API (``dbglog watch``, the viewer); the rest runs in the
watched process (``DBGLOG_WATCH=1`` or ``dbglog run``).
"""
