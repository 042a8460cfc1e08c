"""The one compiled part of dbglog: the hot path of logfloat/logint/logbool/logstring and the publisher
thread's per-sample work (docs/api.md).

Everything else is in pyproject.toml. The extension is optional: without a C compiler the install still
succeeds and the same functions run in Python (``dbglog.api._public.hot_path`` says which).
"""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "dbglog.api._hot",
            sources=["dbglog/api/_hot.c", "dbglog/api/_flush.c", "dbglog/api/_writer.c"],
            depends=["dbglog/api/_parts.h"],
            optional=True,
        )
    ]
)
