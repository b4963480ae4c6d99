#!/usr/bin/env python3
"""rostest check of a wipe under shared control through the real nodes, judged from the world (issue 49).

The base drives to the counter (move_base), the check sends the taught stiffness (3000 N/m along the board, 300 N/m
along its normal, axes those of the board as perceived) and enables shared control, which locates the board through
perception and TF; then a scripted operator wipes with a wave from right to left and on into the boundary, and early
on holds the clutch for a while, stiffening the normal as the GUI's wipe teaching would, while the controller keeps
the wave. Every check is on what the world did: the force the board puts on the tool along its true normal, the TCP in
the true board's frame, and what the controller recognised. A second wipe goes stiffer along the normal than the arm
takes: the wipe must end off the board, with one line saying why.
"""

import math
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import Vector3Stamped

from teleteach.core.scene import load_scene
from teleteach.msg import SharedControlTask
from teleteach.shared_control.ros import task_of
from teleteach.shared_control.surface import wiping_box
from teleteach.wiping.ros import BOARD, CONTACT, TAUGHT, ScriptedWipe, WorldRecord, board_in_base, drive_to

BOUNDARY_TOLERANCE = 0.005  # [m] the tool's centre beyond the boundary (the arm tracks within a few mm)
REFERENCE_TOLERANCE = 0.001  # [m] the controller's equilibrium beyond the boundary: its constraint's own slack
SETTLING = 0.5  # [s] into the wipe before the tool is held to BOUNDARY_TOLERANCE (it starts where the approach left it)
STIFFENED = (3000.0, 3000.0, 1000.0)  # [N/m] what the operator shapes while clutched: a stiffer normal
TOO_STIFF = (3000.0, 3000.0, 5000.0)  # [N/m] a normal stiffer than the arm's max_stiffness (3000 N/m)


class WipeUnderSharedControl(unittest.TestCase):
    def wait_for(self, condition, what, timeout=60.0):
        deadline = rospy.Time.now().to_sec() + timeout
        while rospy.Time.now().to_sec() < deadline and not rospy.is_shutdown():
            value = condition()
            if value:
                return value
            rospy.sleep(0.05)
        self.fail(f"timed out waiting for {what}")

    def start_wipe(self):
        """At the counter, the taught stiffness sent and shared control enabled: the record, the operator and the
        board in base_link as perceived and as it is, once the approach has reached the board."""
        record = WorldRecord()
        self.assertTrue(drive_to(), "the base did not arrive at the counter")
        seen_in_base, true_in_base = board_in_base()
        operator = ScriptedWipe()
        operator.press_with(seen_in_base)
        rospy.sleep(0.5)
        operator.enable()
        self.wait_for(lambda: record.states, "the approach to the board (then /shared_control/state)", 90.0)
        return record, operator, seen_in_base, true_in_base

    def test_the_taught_stiffness_keeps_the_tool_on_the_board_along_a_wave_inside_the_marked_area(self):
        scene = load_scene()
        record, operator, seen_in_base, true_in_base = self.start_wipe()
        _, (_, located) = task_of(rospy.wait_for_message("/shared_control/task", SharedControlTask, timeout=30.0))

        bad = rospy.Publisher("/eigenvalues", Vector3Stamped, queue_size=1)  # a bad message mid-wipe changes nothing
        half = int(2.0 * 50.0) // 2

        def nan_midway(k, stamp):
            if k == half:
                nan = Vector3Stamped()
                nan.header.stamp = rospy.Time.from_sec(stamp)
                nan.vector.x = nan.vector.y = nan.vector.z = float("nan")
                bad.publish(nan)

        start, _ = operator.pattern("wave", 2.5, math.pi, np.random.default_rng(49), nan_midway)
        # The clutch, once the wave is recognised: the hand leaves the pattern for the ellipsoid, the controller keeps
        # the wave (on into the boundary, if the tool gets there)
        clutch_start, clutch_end = operator.teach(2.0, seen_in_base, TAUGHT, STIFFENED)
        _, end = operator.pattern("wave", 4.5, math.pi, np.random.default_rng(50))
        # The operator's input is lost (nothing more is sent): the tool must leave the board and the node stop.
        rospy.sleep(4.0)
        after = rospy.Time.now().to_sec()

        normal = true_in_base.rotation.apply([0.0, 0.0, 1.0])
        pressing = record.between("forces", start + 1.0, end) @ normal
        self.assertGreater(len(pressing), 100, "too few force samples")
        in_contact = float(np.mean(pressing >= CONTACT))
        self.assertGreaterEqual(in_contact, 0.9, f"in contact {in_contact:.0%} of the wipe")
        self.assertTrue(4.0 <= float(np.median(pressing)) <= 16.0, f"median force {np.median(pressing):.1f} N for 10 N")

        reach = scene.wiping_tool.reach
        tcp = record.between("poses", start, end)
        face = np.array([true_in_base.inverse().apply_point(point) for point in tcp])
        box = wiping_box(scene.surface(BOARD), scene.wiping_tool.size[:2])

        def beyond(points):
            return np.maximum.reduce(
                [box.x_min - points[:, 0], points[:, 0] - box.x_max, box.y_min - points[:, 1], points[:, 1] - box.y_max]
            )

        # The controller keeps the boundary where it located the board (/shared_control/task); the world's marked
        # area differs by perception's in-plane bias (a few mm), which the controller cannot see. Its promise is its
        # reference: every equilibrium it sent lies inside.
        to_located = located.inverse()
        reference = record.between("equilibria", start, end)
        reference_outside = beyond(np.array([to_located.apply_point(point) for point in reference]))
        self.assertGreater(len(reference), 100, "too few equilibria")
        self.assertLessEqual(float(reference_outside.max()), REFERENCE_TOLERANCE, "the reference left the boundary")
        # The tool follows within BOUNDARY_TOLERANCE once the wipe is under way: it starts where the approach's
        # touchdown left it, which on a fresh machine was once 5.8 mm past the edge the approach ends beside
        outside = beyond(np.array([to_located.apply_point(point) for point in tcp]))
        outside_true = beyond(face)
        stamps = np.array([stamp for stamp, *_ in record.stamped_between("poses", start, end)])
        under_way = stamps >= start + SETTLING
        worst = int(np.argmax(np.where(under_way, outside, -np.inf)))
        seen_worst = to_located.apply_point(tcp[worst])
        self.assertLessEqual(
            float(outside[under_way].max()),
            BOUNDARY_TOLERANCE,
            f"the tool left the boundary at {seen_worst[:2].round(4).tolist()} (board as located), "
            f"{stamps[worst] - start:.2f} s into the wipe "
            f"(clutched {clutch_start - start:.2f}-{clutch_end - start:.2f} s)",
        )
        self.assertLess(float(face[:, 0].min()), box.x_min + 0.03, "the wipe did not reach the area's left edge")
        self.assertGreater(float(np.ptp(face[:, 1])), 0.03, "no wave across the board")
        self.assertTrue(np.all(np.abs(face[:, 2] - reach) < 0.03), "the TCP was not at the tool's reach over the board")

        lifted = record.between("forces", after - 0.5, after) @ normal
        last_face = true_in_base.inverse().apply_point(record.between("poses", after - 0.5, after)[-1])[2] - reach
        with record.lock:
            shared = [state.skill for stamp, state, _ in record.states if stamp >= start + 2.0 and state.skill]
            stopped = all(stamp < end + 2.5 for stamp, _, _ in record.states)
            cycles, late = record.states[-1][1].cycle, record.states[-1][1].late_cycles
        print(
            f"input lost: force {np.max(lifted):.2f} N at most, the eraser's face {1000 * last_face:.0f} mm off the "
            f"board, shared control {'stopped' if stopped else 'still running'}",
            flush=True,
        )
        print(
            f"wipe: in contact {in_contact:.0%}, median force {np.median(pressing):.1f} N, tool outside the boundary "
            f"by at most {1000 * max(float(outside.max()), 0.0):.1f} mm as perceived, "
            f"{1000 * max(float(outside_true.max()), 0.0):.1f} mm in the world, "
            f"u from {face[:, 0].min():.3f} to {face[:, 0].max():.3f} m, "
            f"v spans {np.ptp(face[:, 1]):.3f} m, recognised wave in {shared.count('wave')} of {len(shared)} cycles, "
            f"{late} of {cycles} cycles late",
            flush=True,
        )
        self.assertGreater(len(shared), 50)
        self.assertGreaterEqual(shared.count("wave") / len(shared), 0.9, f"recognised {set(shared)}")
        self.assertLess(float(np.max(lifted)), CONTACT, "the tool still pressed after the input was lost")
        self.assertGreater(last_face, 0.015, "the tool did not retract off the board")
        self.assertTrue(stopped, "shared control went on without input")
        self.check_the_clutch_kept_the_wave(record, true_in_base, clutch_start, clutch_end)

    def test_the_wipe_ends_off_the_board_when_the_stiffness_goes_beyond_what_the_arm_takes(self):
        from rosgraph_msgs.msg import Log

        lines = []
        rospy.Subscriber("/rosout", Log, lambda message: lines.append(message.msg), queue_size=100)
        record, operator, seen_in_base, true_in_base = self.start_wipe()
        sent = []

        def too_stiff_midway(k, stamp):
            if k == 100:  # 2 s into the wave the normal goes stiffer than the arm's controller takes (it would clamp)
                operator.press_with(seen_in_base, TOO_STIFF)
                sent.append(stamp)

        start, end = operator.pattern("wave", 5.0, math.pi, np.random.default_rng(51), too_stiff_midway)
        rospy.sleep(1.0)
        reach, normal = load_scene().wiping_tool.reach, true_in_base.rotation.apply([0.0, 0.0, 1.0])
        before = record.between("forces", start + 1.0, sent[0]) @ normal  # settled, as in the first test
        lifted = record.between("forces", end - 0.5, end) @ normal
        last_face = true_in_base.inverse().apply_point(record.between("poses", end - 0.5, end)[-1])[2] - reach
        with record.lock:
            stopped = all(stamp < sent[0] + 2.0 for stamp, _, _ in record.states)
        said = [line for line in lines if "outside the arm's range" in line and "the wipe ends" in line]
        print(
            f"stiffness {TOO_STIFF} N/m mid-wipe: before, median force {np.median(before):.1f} N; after, force "
            f"{np.max(lifted):.2f} N at most, the eraser's face {1000 * last_face:.0f} mm off the board, shared "
            f"control {'stopped' if stopped else 'still running'}; the log: {said}",
            flush=True,
        )
        in_contact = float(np.mean(before >= CONTACT))
        self.assertGreaterEqual(in_contact, 0.9, f"the wipe was in contact {in_contact:.0%} of {len(before)} before")
        self.assertLess(float(np.max(lifted)), CONTACT, "the tool still pressed with a stiffness the arm clamps")
        self.assertGreater(last_face, 0.015, "the tool did not retract off the board")
        self.assertTrue(stopped, "shared control went on with a stiffness the arm clamps")
        self.assertEqual(len(said), 1, f"not one line saying why: {lines[-5:]}")

    def check_the_clutch_kept_the_wave(self, record, true_in_base, start, end):
        """While clutched: the wave kept by the controller (right to left at 5 cm/s, swaying), the tool on the board
        and moving, the force held while the normal stiffened."""
        normal = true_in_base.rotation.apply([0.0, 0.0, 1.0])
        pressing = record.between("forces", start + 0.2, end) @ normal
        in_contact = float(np.mean(pressing >= CONTACT))
        face = np.array([true_in_base.inverse().apply_point(point) for point in record.between("poses", start, end)])
        moved = float(np.sum(np.linalg.norm(np.diff(face[:, :2], axis=0), axis=1)))
        with record.lock:
            clutched = [state for stamp, state, _ in record.states if start + 0.2 <= stamp <= end]
        kept = sum(state.message.startswith("clutch: keeping the wave") for state in clutched)
        commands = np.array([(state.command.x, state.command.y) for state in clutched])
        print(
            f"clutch: {kept} of {len(clutched)} cycles keeping the wave, its commands {commands[:, 0].mean():.3f} m/s "
            f"along u, {np.ptp(commands[:, 1]):.2f} m/s sway; in contact {in_contact:.0%}, median force "
            f"{np.median(pressing):.1f} N, the eraser moved {moved:.3f} m on the board",
            flush=True,
        )
        self.assertGreater(len(clutched), 50, "no controller state while clutched")
        self.assertGreaterEqual(kept / len(clutched), 0.9, f"the clutch did not keep the wave: {clutched[-1].message}")
        self.assertTrue(-0.07 <= commands[:, 0].mean() <= -0.03, "the kept wave does not go right to left at 5 cm/s")
        self.assertGreater(np.ptp(commands[:, 1]), 0.2, "the kept wave does not sway")  # the operator's: +-0.19 m/s
        self.assertGreaterEqual(in_contact, 0.9, f"in contact {in_contact:.0%} while the stiffness was shaped")
        self.assertTrue(4.0 <= float(np.median(pressing)) <= 16.0, f"median force {np.median(pressing):.1f} N")
        self.assertGreater(moved, 0.04, "the tool did not move on the board while clutched")


if __name__ == "__main__":
    rospy.init_node("shared_control_wipe_check")
    rostest.rosrun("teleteach", "shared_control_wipe_check", WipeUnderSharedControl)
