"""Allow ``python -m dbglog``."""

import sys

from dbglog._cli import main

sys.exit(main())
