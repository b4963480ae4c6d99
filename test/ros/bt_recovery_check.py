#!/usr/bin/env python3
"""rostest check: behaviour_tree (~resume true) over a data directory whose saved tree is corrupt and whose library
names a taught skill with a missing file and one with NaN stiffness. Expect the node to start from the previous tree,
say so in one log line without a traceback, keep the corrupt file aside, publish the library with the two skills
unavailable (and why), refuse them on /change_tree naming their files, and accept the rest."""

import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import unittest

import numpy as np
import rospkg
import rospy
import rostest
from bt_ros_support import TreeView

from teleteach.core import skill_file

CORRUPT_TREE = "execution: BehaviorExecution\nroot: {type: selector, name: Root, children: [\n"
PREVIOUS_TREE = """execution: BehaviorExecution
root:
  type: selector
  name: Root
  children:
    - {type: pause, name: PauseCondition}
    - type: sequence
      name: BehaviorExecution
      children: [LookToShelf, Wipe, Idle]
"""


def write_data_dir(root):
    count = 5
    pose = np.tile([0.5, 0.0, 0.4, 0.0, 0.0, 0.0, 1.0], (count, 1))
    stiffness = np.tile(np.eye(3) * 500.0, (count, 1, 1))
    skill_file.save(
        skill_file.Skill("Wipe", "stiffness", np.arange(count) * 0.1, stiffness, pose, pose), root / "w.npz"
    )
    stiffness[3, 1, 1] = np.nan
    meta = np.array('{"name": "Smear", "kind": "stiffness"}')
    np.savez(
        root / "s.npz",
        time=np.arange(count) * 0.1,
        stiffness=stiffness,
        equilibrium_pose=pose,
        cartesian_pose=pose,
        meta=meta,
    )
    trees = root / "trees"
    trees.mkdir()
    (trees / "current_tree.yaml").write_text(CORRUPT_TREE)
    (trees / "current_tree.previous.yaml").write_text(PREVIOUS_TREE)
    (trees / "skill_library.yaml").write_text(
        "skills:\n"
        f"  - {{name: Wipe, kind: stiffness, data_file: {root / 'w.npz'}}}\n"
        f"  - {{name: Gone, kind: stiffness, data_file: {root / 'gone.npz'}}}\n"
        f"  - {{name: Smear, kind: stiffness, data_file: {root / 's.npz'}}}\n"
    )


class ResumesFromCorruptState(unittest.TestCase):
    def test_corrupt_tree_and_bad_skill_files(self):
        data_dir = pathlib.Path(tempfile.mkdtemp(prefix="teleteach_bt_recovery_"))
        write_data_dir(data_dir)
        node = pathlib.Path(rospkg.RosPack().get_path("teleteach")) / "nodes" / "behaviour_tree"
        log_path = data_dir / "behaviour_tree.log"
        with open(log_path, "w") as log:
            process = subprocess.Popen(
                [sys.executable, str(node), "_resume:=true", f"_data_dir:={data_dir}", "_startup_timeout:=0"],
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )
        try:
            view = TreeView()
            view.wait_for(lambda: view.tree is not None and view.library is not None, 20, "log/tree and the library")
            # Expect the previous tree, and the corrupt file kept aside, untouched
            self.assertEqual(view.children("BehaviorExecution"), ["LookToShelf", "Wipe", "Idle"])
            trees = data_dir / "trees"
            aside = [path for path in trees.iterdir() if path.name.startswith("current_tree.corrupt-")]
            self.assertEqual(len(aside), 1, sorted(p.name for p in trees.iterdir()))
            self.assertEqual(aside[0].read_text(), CORRUPT_TREE)
            # Expect the library with Gone and Smear unavailable, their files named, the rest available
            library = view.library
            problems = dict(zip(library.names, library.problems))
            self.assertEqual(len(library.problems), len(library.names))
            self.assertIn(str(data_dir / "gone.npz"), problems["Gone"])
            self.assertIn("not finite", problems["Smear"])
            self.assertEqual(problems["Wipe"], "")
            self.assertEqual(problems["PickItem"], "")
            # Expect /change_tree to refuse the unavailable skills naming the file, and to accept the others
            response = view.change("Gone", "insert", 1)
            self.assertFalse(response.success)
            self.assertIn(str(data_dir / "gone.npz"), response.message)
            response = view.change("Smear", "add")
            self.assertFalse(response.success)
            self.assertIn(str(data_dir / "s.npz"), response.message)
            self.assertEqual(view.children("BehaviorExecution"), ["LookToShelf", "Wipe", "Idle"])
            for name in ("Wipe", "PickItem"):
                response = view.change(name, "add")
                self.assertTrue(response.success, response.message)
        finally:
            os.killpg(process.pid, signal.SIGINT)
            process.wait(timeout=20)
        output = log_path.read_text()
        # Expect one line saying what could not be resumed (naming the file set aside), and no traceback
        lines = [line for line in output.splitlines() if "could not resume" in line]
        self.assertEqual(len(lines), 1, output)
        self.assertIn(aside[0].name, lines[0])
        self.assertIn("current_tree.previous.yaml", lines[0])
        self.assertNotIn("Traceback", output)


if __name__ == "__main__":
    rospy.init_node("bt_recovery_check")
    rostest.rosrun("teleteach", "bt_recovery_check", ResumesFromCorruptState)
