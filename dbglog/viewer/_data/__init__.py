"""The viewer's headless data side: ROS in, series, history; no Dear PyGui."""
