"""The SHARED CONTROL tab: its widgets (``view``) and its ROS side (``ros``, the MPC's topics in the task plane)."""
