"""dbglog.api package."""
