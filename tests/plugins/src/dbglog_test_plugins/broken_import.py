"""A plugin module that fails to import: it needs a package that is not installed."""

from __future__ import annotations

import dbglog_test_dependency_that_is_not_installed  # type: ignore[import-not-found]  # noqa: F401

from dbglog.viewer.widget_api import Widget


class BrokenImportWidget(Widget):
    """Never defined: the import above fails first."""
