"""The demo robot: a turtle in a walled arena and a sound-source localizer, for ``dbglog demo``."""
