"""The viewer's publishing service for control widgets: its own node, publishers and type checks."""
