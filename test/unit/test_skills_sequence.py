"""The skills on the real in-process simulation (pybullet physics, controller manager, command validation), no ROS."""

import math
import re

import numpy as np
import pybullet
import pytest
from scipy.spatial.transform import Rotation

from teleteach.core import skill_file
from teleteach.learning.synthetic import placement_on_trajectory
from teleteach.run.sim_robot import SimRobot
from teleteach.sim.robot_sim import IMPEDANCE, TRAJECTORY
from teleteach.skills.config import load_motion_config
from teleteach.skills.predefined import PREDEFINED_SKILLS
from teleteach.skills.robot import Execution, SkillError
from teleteach.skills.runner import SkillRunner


def product_position(sim, name):
    return sim.world.product_poses()[name][0]


def gap_offset(sim, name):
    offset = product_position(sim, name) - np.array(sim.scene.gap("gap_1").position)
    return math.hypot(offset[0], offset[1]), abs(offset[2])


@pytest.mark.slow
def test_the_predefined_sequence_puts_the_product_in_the_gap(sim, runner):
    for name in PREDEFINED_SKILLS:
        feedback = []
        outcome = runner.execute(
            name, "", Execution(feedback=lambda progress, phase, into=feedback: into.append(progress))
        )
        assert outcome.success, f"{name}: {outcome.message}"
        assert feedback[-1] == pytest.approx(1.0)
        assert np.all(np.diff(feedback) >= -1e-9), f"{name}: progress went backwards"
        if name == "PickItem":
            # Expect: the simulation's own grasp holds product_pick_1
            assert sim.world.grasped == "product_pick_1"
        if name == "DropItem":
            horizontal, vertical = gap_offset(sim, "product_pick_1")
            assert horizontal <= sim.scene.gap("gap_1").tolerance
            assert vertical < 0.02
            assert sim.world.grasped is None
    # Expect: the first product still stands in the gap; the second one is in the hand in front of gap_2
    horizontal, vertical = gap_offset(sim, "product_pick_1")
    assert horizontal <= sim.scene.gap("gap_1").tolerance and vertical < 0.02
    assert sim.world.grasped == "product_pick_2"
    # Expect: nothing else was knocked over or pushed on the way
    for product in sim.scene.products:
        if product.name not in ("product_pick_1", "product_pick_2"):
            assert np.linalg.norm(product_position(sim, product.name) - product.position) < 0.005, product.name
    target = sim.scene.base_poses["place_perpendicular_2"]
    np.testing.assert_allclose(sim.world.base_pose, [target.x, target.y, target.yaw], atol=0.01)


def test_pick_fails_saying_the_product_is_not_on_the_table(sim, runner):
    body = sim.world.products["product_pick_1"]
    pybullet.resetBasePositionAndOrientation(body, [0.0, 1.5, 0.07], [0, 0, 0, 1], physicsClientId=sim.world.client)
    before = np.array(sim.world.joint_states()[0][:7])
    outcome = runner.execute("PickItem")
    assert not outcome.success and not outcome.preempted
    assert outcome.message == "product_pick_1 is not on the table"
    np.testing.assert_allclose(sim.world.joint_states()[0][:7], before, atol=1e-3)


@pytest.mark.slow
def test_conditions_read_the_world_and_move_nothing(sim, runner):
    assert sim.switch_controllers([IMPEDANCE], [TRAJECTORY], 2)[0]
    before = np.array(sim.world.joint_states()[0][:7])
    empty = runner.execute("ProductInHand")
    # Expect an empty hand reported with what the hand saw, nothing moved, no controller switched
    assert not empty.success
    assert re.fullmatch(
        r"no product is in the hand \(product_\w+ is [\d.]+ cm from the hand's hold, the gripper \d+ mm open\)",
        empty.message,
    ), empty.message
    gap = runner.execute("ProductInGap")
    assert not gap.success and gap.message.startswith("no product in gap_1 (nearest: product_"), gap.message
    np.testing.assert_allclose(sim.world.joint_states()[0][:7], before, atol=1e-3)
    assert sim.manager.running == IMPEDANCE
    for name in ("LookToShelf", "PickItem"):
        assert runner.execute(name).success
    held = runner.execute("ProductInHand")
    assert held.success and held.message.startswith("product_pick_1 is in the hand"), held.message
    assert runner.execute("ProductInHand", "{product: product_pick_2}").message.startswith("product_pick_2 is not in")
    for name in ("MoveBase", "PlaceItem", "DropItem"):
        assert runner.execute(name).success
    # Expect the placed product seen in gap_1 (the configured gap), and not in gap_2 (a leaf's parameter)
    placed = runner.execute("ProductInGap")
    assert placed.success and placed.message == "product_pick_1 stands in gap_1"
    elsewhere = runner.execute("ProductInGap", "{gap: gap_2}")
    assert not elsewhere.success and elsewhere.message.startswith("no product in gap_2"), elsewhere.message
    assert runner.execute("ProductInGap", "{gap: gap_9}").message.startswith("ProductInGap: ")


def test_place_and_drop_without_a_product_fail(runner):
    assert runner.execute("PlaceItem").message == "no product in the gripper to place"
    assert runner.execute("DropItem").message == "no product in the gripper to drop"


def test_goal_parameters_choose_the_product(sim, runner):
    outcome = runner.execute("PickItem", "{product: product_pick_2}")
    assert outcome.success, outcome.message
    assert sim.world.grasped == "product_pick_2"
    assert runner.execute("PickItem", "{product: 3}").message.startswith("parameters must be a yaml mapping")


def test_a_preempted_skill_stops_and_holds_the_arm(sim, runner):
    look = np.array(runner.config.postures["look"])
    stop_at = sim.time + 0.6
    outcome = runner.execute("LookToShelf", "", Execution(preempt_requested=lambda: sim.time > stop_at))
    assert outcome.preempted and not outcome.success
    stopped = np.array(sim.world.joint_states()[0][:7])
    sim.run(1.0)
    after = np.array(sim.world.joint_states()[0][:7])
    assert np.abs(after - stopped).max() < 0.02  # [rad] it holds (the fingers may still open)
    assert np.abs(after - look).max() > 0.1  # and did not go on to the goal
    assert sim.manager.running == TRAJECTORY


def test_a_preempted_skill_cancels_its_gripper_goal(sim, runner):
    closing = runner.robot.move_gripper(0.0, 0.1)
    while not closing.done():
        sim.run(0.02)
    start = sim.time
    # LookToShelf opens the gripper first: preempt it 0.1 s into that move
    outcome = runner.execute("LookToShelf", "", Execution(preempt_requested=lambda: sim.time > start + 0.1))
    assert outcome.preempted and not outcome.success
    stopped = runner.robot.gripper_width()
    sim.run(1.0)
    # Expect the fingers stopped part way (a move left running would open them to 0.08 m)
    assert 0.002 < stopped < 0.05
    assert runner.robot.gripper_width() == pytest.approx(stopped, abs=0.001)


def test_a_preempted_skill_cancels_its_base_goal(sim, runner):
    start = np.array(sim.world.base_pose)
    driven = Execution(preempt_requested=lambda: np.linalg.norm(np.array(sim.world.base_pose)[:2] - start[:2]) > 0.1)
    outcome = runner.execute("MoveBase", "", driven)
    assert outcome.preempted and not outcome.success
    stopped = np.array(sim.world.base_pose)
    sim.run(2.0)
    # Expect the base stopped where the skill was preempted (move_base left running drives on at 0.5 m/s)
    assert not sim.world.base_moving
    np.testing.assert_allclose(sim.world.base_pose, stopped, atol=0.001)
    assert np.linalg.norm(stopped[:2] - start[:2]) < 0.2


def test_pick_fails_at_once_when_the_grasp_does(sim, runner):
    body = sim.world.products["product_pick_1"]
    phases = []

    def feedback(progress, phase):
        if phase == "grasp" and "grasp" not in phases:  # the product taken away as the fingers start to close
            pybullet.resetBasePositionAndOrientation(
                body, [0.0, 1.5, 0.07], [0, 0, 0, 1], physicsClientId=sim.world.client
            )
        phases.append(phase)

    assert runner.execute("LookToShelf").success
    outcome = runner.execute("PickItem", "", Execution(feedback=feedback))
    # Expect the grasp's own failure, with nothing moved after it: no lift, no carry posture
    assert not outcome.success and not outcome.preempted
    assert re.fullmatch(r"the grasp of product_pick_1 \(\d+ mm wide\) failed: .+", outcome.message), outcome.message
    assert phases[-1] == "grasp" and "lift" not in phases
    assert sim.world.grasped is None


def test_a_skill_first_switches_back_to_the_position_controller(sim, runner):
    ok, message = sim.switch_controllers([IMPEDANCE], [TRAJECTORY], 2)
    assert ok, message
    outcome = runner.execute("LookToShelf")
    assert outcome.success, outcome.message
    assert sim.manager.running == TRAJECTORY
    np.testing.assert_allclose(sim.world.joint_states()[0][:7], runner.config.postures["look"], atol=0.01)


def test_unknown_skill_is_refused(runner):
    outcome = runner.execute("Dance")
    assert not outcome.success and outcome.message.startswith("unknown skill 'Dance'")


def write_skill(sim, path, duration=1.0, step=(0.05, 0.0, 0.0)):
    """A short skill from where the hand is now: 5 cm along base X while the ellipsoid turns 45 deg."""
    position, quaternion = sim.world.read_state().position, sim.world.read_state().quaternion
    count = 21
    fractions = np.linspace(0.0, 1.0, count)[:, None]
    positions = position + fractions * np.array(step)
    poses = np.hstack([positions, np.tile(quaternion, (count, 1))])
    rotated = Rotation.from_euler("z", math.pi / 4).as_matrix()
    final = rotated @ np.diag([300.0, 1500.0, 1000.0]) @ rotated.T
    stiffness = np.array([(1 - f) * np.diag([800.0, 800.0, 800.0]) + f * final for f in fractions[:, 0]])
    skill = skill_file.Skill("place_45", "stiffness", np.linspace(0.0, duration, count), stiffness, poses, poses)
    return skill_file.save(skill, path), final, positions[-1]


def placing_skill(path, until=None):
    """III-C's demonstration on the perpendicular trajectory, or its first ``until`` seconds, saved at path."""
    return skill_file.save(placement_on_trajectory("perpendicular", until), path)


def pick_and_face_the_shelf(runner):
    """Run the tree's first skills: product_pick_1 in the hand, the base in front of gap_1."""
    for name in ("LookToShelf", "PickItem", "MoveBase"):
        outcome = runner.execute(name)
        assert outcome.success, f"{name}: {outcome.message}"


class StampRecordingRobot(SimRobot):
    """The in-process robot, also noting when each stiffness command was stamped."""

    def __init__(self, sim):
        super().__init__(sim)
        self.stamps = []

    def command_stiffness(self, eigenvalues, eigenvectors, stamp):
        self.stamps.append(stamp)
        super().command_stiffness(eigenvalues, eigenvectors, stamp)


class LateSceneRobot(SimRobot):
    """The in-process robot whose next scene readings lag: products reported 3.3 cm off, as a late /teleteach/scene
    after a motion makes a carried product look on a loaded machine (bt_reuse once failed so)."""

    def __init__(self, sim):
        super().__init__(sim)
        self.late_readings = 0

    def product_poses(self):
        poses = super().product_poses()
        if self.late_readings:
            self.late_readings -= 1
            return {
                name: (position + np.array([0.033, 0.0, 0.0]), quaternion)
                for name, (position, quaternion) in poses.items()
            }
        return poses


@pytest.mark.slow
def test_a_late_scene_does_not_make_a_carried_product_look_gone(sim, kinematics):
    robot = LateSceneRobot(sim)
    runner = SkillRunner(robot, load_motion_config(), sim.scene, kinematics)
    pick_and_face_the_shelf(runner)
    robot.late_readings = 1
    # Expect the placing skill to look again when the first reading shows an empty hand, and place the product
    outcome = runner.execute("PlaceItem")
    assert outcome.success, outcome.message
    assert robot.late_readings == 0
    robot.late_readings = 10
    assert runner.execute("DropItem").message == "no product in the gripper to drop"


@pytest.mark.slow
def test_replay_places_the_product_in_the_gap_and_releases_it(sim, kinematics, tmp_path):
    robot = StampRecordingRobot(sim)
    runner = SkillRunner(robot, load_motion_config(), sim.scene, kinematics)
    pick_and_face_the_shelf(runner)
    path = placing_skill(tmp_path / "place")
    robot.stamps.clear()
    feedback = []
    outcome = runner.execute(
        "ReplaySkill",
        f"{{data_file: {path}, kind: stiffness}}",
        Execution(feedback=lambda progress, phase: feedback.append(phase)),
    )
    assert outcome.success, outcome.message
    assert "product_pick_1 released upright in gap_1" in outcome.message
    assert feedback.index("switch to impedance control") < feedback.index("replay") < feedback.index("release")
    # Expect: at least 100 Hz over the recording, stamps following the recording's timing
    played = np.diff(np.unique(robot.stamps[1:]))
    assert played.max() <= 0.01 + 1e-9 and played.min() > 0.0
    assert robot.stamps[-1] - robot.stamps[1] == pytest.approx(11.0, abs=1e-6)
    # Expect: the world agrees: released, in gap_1, upright, nothing pushed; the arm back on position control
    assert sim.world.grasped is None
    horizontal, vertical = gap_offset(sim, "product_pick_1")
    assert horizontal <= sim.scene.gap("gap_1").tolerance and vertical < 0.02
    for product in sim.scene.products:
        if product.name.startswith("product_shelf"):
            assert np.linalg.norm(product_position(sim, product.name) - product.position) < 0.01, product.name
    assert sim.manager.running == TRAJECTORY


@pytest.mark.slow
def test_replay_that_leaves_the_product_outside_the_gap_fails_naming_product_gap_and_distance(sim, runner, tmp_path):
    pick_and_face_the_shelf(runner)
    path = placing_skill(tmp_path / "short", until=5.0)  # stops 15 cm in front of the shelf
    outcome = runner.execute("ReplaySkill", f"{{data_file: {path}}}")
    assert not outcome.success
    assert re.fullmatch(r"product_pick_1 ended 1\d\.\d cm from gap_1 \(.*\); it is still in the hand", outcome.message)
    # Expect: the product was not dropped in front of the shelf; the whole skill then places it from there
    assert sim.world.grasped == "product_pick_1"
    outcome = runner.execute("ReplaySkill", f"{{data_file: {placing_skill(tmp_path / 'whole')}}}")
    assert outcome.success, outcome.message
    horizontal, vertical = gap_offset(sim, "product_pick_1")
    assert horizontal <= sim.scene.gap("gap_1").tolerance and vertical < 0.02


def test_replay_with_nothing_in_the_hand_fails_before_moving(sim, kinematics, tmp_path):
    robot = StampRecordingRobot(sim)
    runner = SkillRunner(robot, load_motion_config(), sim.scene, kinematics)
    path, _, _ = write_skill(sim, tmp_path / "place_45")
    before = np.array(sim.world.joint_states()[0][:7])
    outcome = runner.execute("ReplaySkill", f"{{data_file: {path}, kind: stiffness}}")
    assert not outcome.success
    # Expect the refusal to say what it saw: no product in the hold, the gripper open
    assert outcome.message.startswith("place_45 places a product, but there is none in the hand: pick one first (")
    assert "cm from the hand's hold" in outcome.message and "mm open)" in outcome.message
    assert robot.stamps == []
    np.testing.assert_allclose(sim.world.joint_states()[0][:7], before, atol=1e-3)
    assert sim.manager.running == TRAJECTORY


def test_replay_of_a_skill_file_with_nan_is_refused_naming_the_file(sim, runner, tmp_path):
    path = placing_skill(tmp_path / "nan")
    with np.load(path) as archive:
        arrays = dict(archive)
    arrays["stiffness"][5, 0, 0] = np.nan
    np.savez(path, **arrays)
    outcome = runner.execute("ReplaySkill", f"{{data_file: {path}}}")
    assert outcome.message == f"skill file {path}: stiffness is not finite (NaN or inf) at sample 5"


def test_replay_of_a_bad_skill_file_fails_with_its_error(sim, runner, tmp_path):
    broken = tmp_path / "broken.npz"
    broken.write_bytes(b"not a skill")
    outcome = runner.execute("ReplaySkill", f"{{data_file: {broken}, kind: stiffness}}")
    assert not outcome.success
    assert outcome.message.startswith(f"skill file {broken} cannot be read")
    missing = runner.execute("ReplaySkill", f"{{data_file: {tmp_path / 'none.npz'}}}")
    assert missing.message == f"skill file {tmp_path / 'none.npz'} does not exist"
    path, _, _ = write_skill(sim, tmp_path / "place")
    assert "holds a 'stiffness' skill" in runner.execute("ReplaySkill", f"{{data_file: {path}, kind: dmp}}").message
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    cut = runner.execute("ReplaySkill", f"{{data_file: {truncated}}}")
    assert not cut.success and cut.message.startswith(f"skill file {truncated} cannot be read")
    assert sim.manager.running == TRAJECTORY


@pytest.mark.slow
def test_a_preempted_replay_switches_back_to_position_control(sim, runner, tmp_path):
    pick_and_face_the_shelf(runner)
    path = placing_skill(tmp_path / "long")
    stop_at = sim.time + 3.0
    outcome = runner.execute(
        "ReplaySkill", f"{{data_file: {path}}}", Execution(preempt_requested=lambda: sim.time > stop_at)
    )
    assert outcome.preempted
    assert sim.manager.running == TRAJECTORY
    held = sim.world.read_state().position
    sim.run(0.5)
    assert np.linalg.norm(sim.world.read_state().position - held) < 0.005
    assert IMPEDANCE != sim.manager.running


class GuiSwitchesFirst(SimRobot):
    """The in-process robot where the teaching GUI's switch back to position control lands just before the skill's."""

    def switch_controllers(self, start, stop):
        if self.sim.manager.running == IMPEDANCE:
            super().switch_controllers([TRAJECTORY], [IMPEDANCE])
        super().switch_controllers(start, stop)


def test_a_skill_starting_while_the_gui_switches_back_to_position_control_runs(sim, kinematics):
    robot = GuiSwitchesFirst(sim)
    runner = SkillRunner(robot, load_motion_config(), sim.scene, kinematics)
    SimRobot(sim).switch_controllers([IMPEDANCE], [TRAJECTORY])
    # Expect: the skill's STRICT switch is refused (the impedance controller already stopped), yet the skill runs
    with pytest.raises(SkillError, match="refused"):
        robot.switch_controllers([TRAJECTORY], [IMPEDANCE])
    SimRobot(sim).switch_controllers([IMPEDANCE], [TRAJECTORY])
    outcome = runner.execute("LookToShelf")
    assert outcome.success, outcome.message
    assert sim.manager.running == TRAJECTORY
