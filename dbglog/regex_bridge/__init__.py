"""dbglog.regex_bridge package."""
