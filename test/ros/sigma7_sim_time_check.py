#!/usr/bin/env python3
"""rostest check: under use_sim_time the sigma7 scenario follows /clock, not the wall clock.

This node is the simulator: it publishes /clock from 1000 s at twice real time, then checks that the node's
scenario start and its pose stamps are simulated times and that the poses follow the scenario in simulated time.
"""

import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import yaml
from geometry_msgs.msg import PoseStamped
from rosgraph_msgs.msg import Clock

SIM_START = 1000.0  # [s]
SPEEDUP = 2.0
TICK = 0.005  # [s] of wall time between /clock messages


class Sigma7SimTime(unittest.TestCase):
    def test_scenario_follows_the_simulated_clock(self):
        rospy.init_node("sigma7_sim_time_check")
        with open(rospy.get_param("~scenario")) as stream:
            keyframes = yaml.safe_load(stream)["keyframes"]
        poses, lock, stop = [], threading.Lock(), threading.Event()

        def store(msg):
            with lock:
                poses.append(
                    (
                        msg.header.stamp.to_sec(),
                        np.array([msg.pose.position.x, msg.pose.position.y, msg.pose.position.z]),
                    )
                )

        rospy.Subscriber("/sigma7/pose", PoseStamped, store)
        clock = rospy.Publisher("/clock", Clock, queue_size=10)
        sim_now = [SIM_START]

        def run_clock():
            while not stop.is_set():
                clock.publish(Clock(rospy.Time.from_sec(sim_now[0])))
                time.sleep(TICK)
                sim_now[0] += TICK * SPEEDUP

        clocker = threading.Thread(target=run_clock, daemon=True)
        clocker.start()
        try:
            start_param = rospy.get_param("~start_param")
            end = keyframes[2]["t"] + 0.2  # past the first moving segment
            deadline = time.monotonic() + 60.0
            while time.monotonic() < deadline:
                if rospy.has_param(start_param):
                    start = rospy.get_param(start_param)
                    with lock:
                        if poses and poses[-1][0] - start > end:
                            break
                time.sleep(0.05)
            else:
                self.fail("the node did not play the scenario on simulated time")
        finally:
            stop.set()
            clocker.join()
        self.assertGreaterEqual(start, SIM_START)
        self.assertLess(start, SIM_START + 30.0, "scenario start is not a simulated time")
        with lock:
            received = list(poses)
        self.assertTrue(all(SIM_START <= stamp <= sim_now[0] for stamp, _ in received))
        first, second = keyframes[1], keyframes[2]
        segment = [
            (stamp - start, position) for stamp, position in received if first["t"] <= stamp - start <= second["t"]
        ]
        self.assertGreater(len(segment), 50)
        for scenario_time, position in segment:
            fraction = (scenario_time - first["t"]) / (second["t"] - first["t"])
            expected = np.array(first["position"]) + fraction * (
                np.array(second["position"]) - np.array(first["position"])
            )
            np.testing.assert_allclose(position, expected, atol=1e-6, err_msg=f"at scenario time {scenario_time}")


if __name__ == "__main__":
    rostest.rosrun("teleteach", "sigma7_sim_time_check", Sigma7SimTime)
