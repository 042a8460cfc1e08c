"""Run the dbglog demo robot's two ROS 2 nodes: a turtle in a walled arena and a sound-source localizer.

    python examples/demo_robot.py                 # until Ctrl-C
    python examples/demo_robot.py --duration 30   # for 30 s

They publish typed values with ``dbglog.logfloat`` / ``logbool`` / ``logstring`` / ``log`` and write
ordinary log lines; see them with ``dbglog view`` (automatic dashboard), or with the case-study
dashboard ``dbglog view examples/dashboards/sound_source.json``, and turn the log lines into numbers
with ``dbglog bridge examples/rules/demo_rules.yaml``. ``dbglog demo`` does all of it in one command.
The nodes' code is in ``dbglog/_demo/_robot.py``.
"""

from __future__ import annotations

from dbglog._demo._robot import main
from dbglog._rosenv import localhost_discovery

if __name__ == "__main__":
    localhost_discovery()
    raise SystemExit(main())
