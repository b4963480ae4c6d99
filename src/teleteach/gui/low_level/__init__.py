"""The LOW-LEVEL tab: its widgets (``view``)."""
