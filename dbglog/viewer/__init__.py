"""dbglog.viewer package."""
