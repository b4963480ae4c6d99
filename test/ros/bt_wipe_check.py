#!/usr/bin/env python3
"""rostest check: a wiping skill, taught on the service counter's board and learned with DMPs (`learn_skill --add`),
joins the tree and wipes the board through /skills/ReplaySkill, and the world says whether it did: the board's push on
the eraser along the board's true normal (/force_torque_ext, the board from /teleteach/true_scene, TF) and where the
TCP went on the board (/cartesian_pose)."""

import pathlib
import subprocess
import sys
import threading
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from bt_ros_support import TreeView
from geometry_msgs.msg import PoseStamped, WrenchStamped
from scipy.spatial.transform import Rotation
from visualization_msgs.msg import MarkerArray

from teleteach.control.kinematics import PandaKinematics
from teleteach.core import skill_file
from teleteach.core.frames import Transform
from teleteach.core.observed import observed_from_markers
from teleteach.core.scene import load_scene
from teleteach.core.wiping import load_wiping_config
from teleteach.sim.robot_sim import RobotSim
from teleteach.sim.uncertainty import UncertaintySettings
from teleteach.wiping.ablation import TAUGHT
from teleteach.wiping.trial import SurfaceWiper, wiping_scene

HELP_TIMEOUT = 240.0  # [s] wall: sim, skill servers and tree starting on a loaded machine, then the drive
RUN_TIMEOUT = 300.0  # [s] wall: the wipe on the simulated robot
BOARD = "counter_board"
WAVE_SECONDS = 3.0
CONTACT = 1.0  # [N] a push below this is no contact


class WorldRecord:
    """The force on the hand and the TCP (base_link, by sim time), and the board as it truly is (world)."""

    def __init__(self):
        self.lock = threading.Lock()
        self.forces, self.poses, self.board = [], [], None
        rospy.Subscriber("/force_torque_ext", WrenchStamped, self._on_force, queue_size=1000)
        rospy.Subscriber("/cartesian_pose", PoseStamped, self._on_pose, queue_size=1000)
        rospy.Subscriber("/teleteach/true_scene", MarkerArray, self._on_scene, queue_size=1)

    def _on_force(self, message):
        f = message.wrench.force
        with self.lock:
            self.forces.append((message.header.stamp.to_sec(), f.x, f.y, f.z))

    def _on_pose(self, message):
        p = message.pose.position
        with self.lock:
            self.poses.append((message.header.stamp.to_sec(), p.x, p.y, p.z))

    def _on_scene(self, message):
        board = observed_from_markers(message.markers)[0].surfaces.get(BOARD)
        if board is not None:
            with self.lock:
                self.board = Transform(board.position, Rotation.from_quat(board.quaternion))

    def arrays(self):
        with self.lock:
            return np.array(self.forces), np.array(self.poses), self.board


def taught_wave(path: pathlib.Path) -> pathlib.Path:
    """A wave taught on the board from the wiping pose (the operator's demonstration), saved in the board's frame."""
    scene, config = load_scene(), load_wiping_config()
    board = scene.surface(BOARD)
    sim = RobotSim(wiping_scene(scene, board), uncertainty=UncertaintySettings.none())
    kinematics = PandaKinematics(scene.robot.mount_height)
    try:
        sim.place_base(scene.base_poses["wipe_counter"])
        phase = np.linspace(0.0, 1.0, int(round(WAVE_SECONDS / config.dt)))
        wave = np.column_stack([0.1 - 0.2 * phase, 0.04 * np.sin(2 * np.pi * 2 * phase)])
        skill = SurfaceWiper(sim, kinematics, board, config).pattern_skill(wave, TAUGHT, "DemonstratedWipe_1")
    finally:
        kinematics.close()
        sim.close()
    return skill_file.save(skill, path)


class LearnedWipeInTheTree(unittest.TestCase):
    def test_the_tree_wipes_the_board_with_the_learned_skill(self):
        view = TreeView()
        world = WorldRecord()
        buffer = tf2_ros.Buffer()
        tf2_ros.TransformListener(buffer)
        data = pathlib.Path(rospy.get_param("~data_dir")) / "demonstrations"
        data.mkdir(parents=True, exist_ok=True)
        demonstration = taught_wave(data / "DemonstratedWipe_1.npz")
        view.wait_for(lambda: view.help is not None and view.help.node_name == "DropItem", HELP_TIMEOUT, "help")
        view.wait_for(lambda: view.status("PauseCondition") == "SUCCESS", 10, "the tree paused")

        command = [sys.executable, str(pathlib.Path(__file__).parents[2] / "nodes" / "learn_skill"), str(demonstration)]
        command += ["--name", "LearnedWipe", "--data-dir", str(data.parent), "--add", "--timeout", "30"]
        learned = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
        self.assertEqual(learned.returncode, 0, learned.stdout + learned.stderr)
        view.wait_for(lambda: "LearnedWipe" in (view.library.names if view.library else []), 10, "LearnedWipe")
        for arguments in (("LearnedWipe", "insert", 2), ("DropItem", "remove")):
            response = view.change(*arguments)
            self.assertTrue(response.success, f"{arguments}: {response.message}")
        started = rospy.get_time()
        view.pause(False)
        view.wait_completed(timeout=RUN_TIMEOUT)
        message = view.nodes()["LearnedWipe"].message
        self.assertEqual(view.status("LearnedWipe"), "SUCCESS", message)
        self.assertIn(f"wiped {BOARD} with LearnedWipe (dmp, taught on {BOARD})", message)

        # Expect, from the world: the eraser pressed on the true board for the wave's length, with about the 10 N
        # asked for, while the TCP swept the board's middle right to left.
        transform = buffer.lookup_transform("base_link", "world", rospy.Time(0), rospy.Duration(5.0)).transform
        t, q = transform.translation, transform.rotation
        world_in_base = Transform(np.array([t.x, t.y, t.z]), Rotation.from_quat([q.x, q.y, q.z, q.w]))
        forces, poses, board = world.arrays()
        self.assertIsNotNone(board, "no counter_board on /teleteach/true_scene")
        board_in_base = world_in_base * board
        normal = board_in_base.rotation.apply([0.0, 0.0, 1.0])
        forces = forces[forces[:, 0] >= started]
        push = forces[:, 1:] @ normal
        touching = forces[push >= CONTACT, 0]
        self.assertGreater(len(touching), 10, f"the eraser never pressed on the board (peak {push.max():.1f} N)")
        self.assertGreaterEqual(touching[-1] - touching[0], 0.95 * WAVE_SECONDS, "in contact too briefly")
        gaps = np.diff(touching)
        self.assertLess(float(gaps.max()), 0.2, f"contact broken for {gaps.max():.2f} s mid-wipe")
        median = float(np.median(push[push >= CONTACT]))
        self.assertTrue(4.0 <= median <= 16.0, f"median push {median:.1f} N for the 10 N asked")
        during = poses[(poses[:, 0] >= touching[0]) & (poses[:, 0] <= touching[-1])]
        on_board = board_in_base.inverse().apply_point(during[:, 1:]) if len(during) else np.zeros((1, 3))
        self.assertLess(on_board[:, 0].min(), -0.07, "the wipe did not reach the board's left")
        self.assertGreater(on_board[:, 0].max(), 0.07, "the wipe did not start on the board's right")
        rospy.loginfo(
            f"bt_wipe: in contact {touching[-1] - touching[0]:.2f} s, median push {median:.1f} N, TCP u "
            f"{on_board[:, 0].min():.3f}..{on_board[:, 0].max():.3f} m; {message}"
        )


if __name__ == "__main__":
    rospy.init_node("bt_wipe_check")
    rostest.rosrun("teleteach", "bt_wipe_check", LearnedWipeInTheTree)
