"""Deliberately broken widget plugins for dbglog's fault-isolation tests (see tests/test_plugins.py)."""
