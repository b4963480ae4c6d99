"""The HIGH-LEVEL tab: its widgets (``view``)."""
