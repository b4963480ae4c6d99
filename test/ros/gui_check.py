#!/usr/bin/env python3
"""rostest check: teaching_gui opened on LOW-LEVEL (no device) says so on /teleteach/active_tab and commands the
initial ellipsoid of config/gui.yaml: initial_stiffness on every axis, axes aligned with base_frame."""

import pathlib
import unittest

import rospkg
import rospy
import rostest
import yaml
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from std_msgs.msg import Int8

from teleteach.core.active_tab import Tab


class GuiPublishes(unittest.TestCase):
    def test_low_level_commands_the_initial_ellipsoid(self):
        config = pathlib.Path(rospkg.RosPack().get_path("teleteach")) / "config" / "gui.yaml"
        gui = yaml.safe_load(config.read_text())
        tab = rospy.wait_for_message("/teleteach/active_tab", Int8, timeout=60)
        values = rospy.wait_for_message("/eigenvalues", Vector3Stamped, timeout=60)
        vectors = rospy.wait_for_message("/eigenvectors", QuaternionStamped, timeout=60)
        # Expect the LOW-LEVEL tab, the configured stiffness on each axis, no rotation, in the base frame
        self.assertEqual(tab.data, Tab.LOW_LEVEL)
        stiffness = gui["initial_stiffness"]
        for axis in "xyz":
            self.assertAlmostEqual(getattr(values.vector, axis), stiffness, delta=1e-6 * stiffness)
        self.assertEqual(values.header.frame_id, gui["base_frame"])
        self.assertEqual(vectors.header.frame_id, gui["base_frame"])
        q = vectors.quaternion
        self.assertAlmostEqual(abs(q.w), 1.0, places=6)
        self.assertAlmostEqual(q.x**2 + q.y**2 + q.z**2, 0.0, places=9)


if __name__ == "__main__":
    rospy.init_node("gui_check")
    rostest.rosrun("teleteach", "gui_check", GuiPublishes)
