"""ROS conventions shared below ``api/`` and ``viewer/``: imports no feature package."""
