"""The teaching GUI (thesis II-B, II-C, III-A, Appendix A): START, HIGH-LEVEL and LOW-LEVEL tabs driven by the device.

Pure logic (device filtering, the three-step selection, the ellipsoid, recording) lives in modules that import
neither Qt nor rospy, so it is testable on its own; ``worker``, ``tabs``, ``gl_view`` and ``app`` add Qt and ROS.
"""
