"""Haptic device backends (Sigma.7 through the Force Dimension SDK, virtual, scenario) and click emulation."""
