"""The START tab: its widgets (``view``)."""
