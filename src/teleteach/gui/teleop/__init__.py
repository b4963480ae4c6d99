"""The TELEOP tab: its widgets (``view``)."""
