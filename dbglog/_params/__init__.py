"""``dbglog params``: list and set ROS 2 node parameters from a terminal (no viewer engine, no display)."""
