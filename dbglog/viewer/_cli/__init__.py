"""The viewer's command-line entry points: dbglog view, tags, echo and logs."""
