"""What every node and experiment runs on, importing only teleteach.core.

A node's start, parameters and end, the actionlib helpers, and an experiment's child processes (Xvfb, a ROS master, a
launch) (docs/architecture.md).
"""
