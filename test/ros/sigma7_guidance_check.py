#!/usr/bin/env python3
"""rostest check: the sigma7 node renders /sigma7/guidance (seen on /sigma7/force), caps it, drops it when it is no
longer refreshed, and refuses a NaN one, a negative stiffness and an unknown mode, each with its reason."""

import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import WrenchStamped
from rosgraph_msgs.msg import Log

from teleteach.msg import HapticGuidance


def hold_x(stiffness, centre=0.0):
    """A hold spring on device x, everything else free."""
    message = HapticGuidance()
    message.header.stamp = rospy.Time.now()
    message.modes = ["hold", "free", "free", "free", "free", "free"]
    message.centres = [centre, 0.0, 0.0, 0.0, 0.0, 0.0]
    message.stiffness = [stiffness, 0.0, 0.0, 0.0, 0.0, 0.0]
    message.max_force, message.max_torque = 10.0, 0.1
    return message


class GuidanceOverRos(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.forces, self.logs = [], []
        rospy.Subscriber("/sigma7/force", WrenchStamped, self._on_force, queue_size=100)
        rospy.Subscriber("/rosout", Log, self._on_log, queue_size=100)
        self.publisher = rospy.Publisher("/sigma7/guidance", HapticGuidance, queue_size=10, latch=True)

    def _on_force(self, message):
        with self.lock:
            self.forces.append((time.monotonic(), np.array([message.wrench.force.x, message.wrench.force.y])))

    def _on_log(self, message):
        with self.lock:
            self.logs.append(message.msg)

    def latest_force(self):
        with self.lock:
            return self.forces[-1][1] if self.forces else None

    def wait_for(self, condition, timeout, what):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not rospy.is_shutdown():
            if condition():
                return
            time.sleep(0.01)
        self.fail(f"timed out after {timeout} s waiting for {what}; last force {self.latest_force()}")

    def refresh(self, message, seconds):
        """Publish ``message`` every 0.1 s for ``seconds`` (as the GUI refreshes its guidance)."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            message.header.stamp = rospy.Time.now()
            self.publisher.publish(message)
            time.sleep(0.1)

    def test_rendered_capped_dropped_when_stale_and_refused_when_bad(self):
        self.wait_for(lambda: self.latest_force() is not None, 30, "/sigma7/force")
        self.assertTrue(np.all(self.latest_force() == 0.0), "no guidance: no force")
        self.refresh(hold_x(100.0), 1.0)
        # Expect the spring's -k x = -2 N at x = 0.02 m
        np.testing.assert_allclose(self.latest_force(), [-2.0, 0.0], atol=1e-6)
        self.refresh(hold_x(1000.0), 1.0)
        # Expect 20 N asked, the node's 4 N cap rendered
        np.testing.assert_allclose(self.latest_force(), [-4.0, 0.0], atol=1e-6)
        stopped = time.monotonic()
        self.wait_for(lambda: self.latest_force()[0] == 0.0, 2.0, "zero force once the guidance is stale")
        with self.lock:
            first_zero = next(stamp for stamp, force in self.forces if stamp > stopped and force[0] == 0.0)
        # Expect zero within 0.5 s of the last refresh (+ one /sigma7/force period and delivery)
        self.assertLess(first_zero - stopped, 0.5 + 0.1)
        negative = hold_x(-100.0)
        unknown = hold_x(100.0)
        unknown.modes[0] = "sticky"
        for bad, reason in (
            (hold_x(float("nan")), "axis x stiffness must be a finite number >= 0, got nan"),
            (negative, "axis x stiffness must be a finite number >= 0, got -100.0"),
            (unknown, "axis x: unknown mode 'sticky'"),
        ):
            self.refresh(hold_x(100.0), 0.5)
            self.assertLess(self.latest_force()[0], -1.0)
            self.publisher.publish(bad)
            # Expect zero at once (well before the 0.5 s after which the last good one would be stale)
            self.wait_for(lambda: self.latest_force()[0] == 0.0, 0.2, f"zero force after a guidance with {reason}")
            self.wait_for(
                lambda reason=reason: any(f"guidance refused, rendering none: {reason}" in log for log in self.logs),
                5.0,
                f"the refusal's reason on /rosout ({reason})",
            )


if __name__ == "__main__":
    rospy.init_node("sigma7_guidance_check")
    rostest.rosrun("teleteach", "sigma7_guidance_check", GuidanceOverRos)
