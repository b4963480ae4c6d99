"""The pybullet world: scene file, base_link frame (Jacobian), kinematics for the skills, URDF, base drive, grasp."""

import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest
from conftest import ROOT
from scipy.spatial.transform import Rotation
from sim_support import IMPEDANCE, TRAJECTORY, robot_sim_for_module

from teleteach.control import panda
from teleteach.control.kinematics import IKError, PandaKinematics
from teleteach.core.paths import share_dir
from teleteach.core.scene import SceneError, load_scene
from teleteach.sim.urdf import robot_description


@pytest.fixture
def robot_sim():
    yield from robot_sim_for_module()


DOWN = [1.0, 0.0, 0.0, 0.0]  # TCP z pointing down, fingers closing along base_link y


@pytest.fixture(scope="module")
def kinematics():
    model = PandaKinematics()
    yield model
    model.close()


def test_the_scene_has_tight_gaps_between_real_products_behind_a_lip_and_held_out_places():
    scene = load_scene()
    boards = {part.name: part for part in scene.shelf if "board" in part.name}
    assert {"board_low", "board_high", "endcap_board"} <= set(boards)
    assert list(scene.gaps) == [f"gap_{number}" for number in range(1, 8)]
    product = scene.product("product_pick_1")
    clearances = {}
    for gap in scene.gaps.values():
        # Expect: the gap stands on a board, a lip 2 cm high in front of it, a neighbour at each edge of its width
        board = min(boards.values(), key=lambda part: abs(part.center[2] + part.size[2] / 2 - gap.position[2] + 0.07))
        top = board.center[2] + board.size[2] / 2
        assert gap.position[2] - product.size[2] / 2 == pytest.approx(top, abs=1e-9)
        lip = next(part for part in scene.shelf if "lip" in part.name and abs(part.center[2] - top - 0.01) < 1e-9)
        assert lip.size[2] == pytest.approx(0.02)
        inward = Rotation.from_euler("z", gap.yaw)
        sides = []
        for other in scene.products:
            local = inward.inv().apply(np.array(other.position) - np.array(gap.position))
            if abs(local[0]) < 0.01 and abs(local[2]) < 0.01 and 0.0 < abs(local[1]) < 0.1:
                sides.append(abs(local[1]) - other.size[1] / 2)
        assert len(sides) == 2 and sides[0] == pytest.approx(gap.width / 2, abs=1e-3) == sides[1]
        clearances[gap.name] = (gap.width - product.size[1]) / 2
        assert gap.tolerance == pytest.approx(0.01)
        assert f"place_{gap.name}" in scene.base_poses or gap.name in ("gap_1", "gap_2")
    assert min(clearances.values()) == pytest.approx(0.002) and max(clearances.values()) == pytest.approx(0.010)
    assert clearances["gap_1"] == pytest.approx(0.005)
    masses = [item.mass for item in scene.products]
    assert 0.2 <= min(masses) and max(masses) <= 1.0 and len(set(masses)) > 4
    assert all(item.corner_radius > 0.0 for item in scene.products)
    assert len([p for p in scene.products if p.name.startswith("product_pick")]) >= 2
    assert {"pick", "place_perpendicular", "place_45deg", "place_perpendicular_2", "place_45deg_2"} <= set(
        scene.base_poses
    )


def test_an_unknown_gap_is_a_clear_error():
    with pytest.raises(SceneError, match="no gap 'gap_9' \\(it has gap_1, gap_2, gap_3, gap_4, gap_5, gap_6, gap_7\\)"):
        load_scene().gap("gap_9")


def test_jacobian_is_in_base_link_with_a_yawed_base(robot_sim):
    sim = robot_sim
    sim.world.teleport_base(sim.scene.base_poses["place_45deg"])
    state = sim.world.read_state()
    kinematics = PandaKinematics(sim.scene.robot.mount_height)
    dq = np.array([0.3, -0.2, 0.1, 0.2, -0.1, 0.2, 0.1]) * 1e-4
    # Expect J dq = the finite difference of the TCP in base_link, and the kinematics model to agree
    moved, _ = kinematics.forward(state.q + dq)
    here, quaternion = kinematics.forward(state.q)
    np.testing.assert_allclose(state.jacobian[:3] @ dq, moved - here, rtol=1e-3, atol=1e-8)
    np.testing.assert_allclose(here, state.position, atol=1e-6)
    assert abs(np.dot(quaternion, state.quaternion)) == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_allclose(kinematics.jacobian(state.q), state.jacobian, atol=1e-9)
    kinematics.close()
    sim.world.teleport_base(sim.scene.base_poses["start"])


def test_inverse_kinematics_round_trip(kinematics):
    target = np.array([0.55, 0.1, 0.6])
    joints = kinematics.inverse(target, DOWN)
    position, quaternion = kinematics.forward(joints)
    np.testing.assert_allclose(position, target, atol=1e-3)
    assert abs(np.dot(quaternion, DOWN)) == pytest.approx(1.0, abs=1e-5)
    assert np.all(joints >= panda.LOWER_LIMITS) and np.all(joints <= panda.UPPER_LIMITS)
    with pytest.raises(IKError):
        kinematics.inverse([2.0, 0.0, 0.6], DOWN)


def test_urdf_has_base_link_and_resolvable_meshes():
    robot = ElementTree.fromstring(robot_description())
    links = {link.get("name") for link in robot.findall("link")}
    joints = {joint.get("name") for joint in robot.findall("joint")}
    assert {"base_link", "panda_link0", "panda_hand", "panda_grasptarget"} <= links
    assert set(panda.ARM_JOINTS + panda.FINGER_JOINTS) <= joints
    children = {joint.find("child").get("link") for joint in robot.findall("joint")}
    assert links - children == {"base_link"}  # the root
    # Expect every mesh named through the package (RViz elsewhere resolves it), and in the package (ROS's own lookup of
    # an install space: test/ros/test_install_space.py)
    meshes = [mesh.get("filename") for mesh in robot.iter("mesh")]
    package = share_dir()
    assert meshes and all(m.startswith("package://teleteach/meshes/panda/") for m in meshes), meshes
    assert all((package / m[len("package://teleteach/") :]).is_file() for m in meshes)


def test_the_shipped_meshes_are_pybullet_datas_but_for_one_texture_path():
    # pybullet simulates panda.urdf from pybullet_data; RViz shows the copies in meshes/panda: they must not drift
    # apart. The one change (NOTICE): collision/link6.mtl named its texture by a Windows path of its author.
    shipped = ROOT / "meshes" / "panda"
    upstream = panda.PANDA_URDF.parent / "meshes"
    files = sorted(path.relative_to(upstream) for path in upstream.rglob("*") if path.is_file())
    assert len(files) > 20
    changed = [str(name) for name in files if (shipped / name).read_bytes() != (upstream / name).read_bytes()]
    assert changed == ["collision/link6.mtl"]
    assert "D:\\" not in (shipped / "collision" / "link6.mtl").read_text()
    assert (shipped / "collision" / "colors.png").read_bytes() == (upstream / "visual" / "colors.png").read_bytes()


def test_base_drives_at_capped_speed(robot_sim):
    sim = robot_sim
    start = sim.world.base_pose.copy()
    sim.command_base_goal("world", [start[0] - 0.5, start[1], 0.0], [0.0, 0.0, 0.0, 1.0])
    sim.run(0.5)
    assert np.linalg.norm(sim.world.base_pose[:2] - start[:2]) == pytest.approx(0.25, abs=1e-3)  # 0.5 m/s cap
    sim.run(1.0)
    np.testing.assert_allclose(sim.world.base_pose, [start[0] - 0.5, start[1], 0.0], atol=1e-9)
    sim.command_base_goal("world", [start[0], start[1], 0.0], [0.0, 0.0, 0.0, 1.0])
    sim.run(1.1)


def test_pick_lifts_the_product_and_it_rides_along_with_the_base(robot_sim, kinematics):
    sim = robot_sim
    product = sim.scene.product("product_pick_1")
    top = np.array(product.position) + np.array(
        [0.0, 0.0, product.size[2] / 2]
    )  # base at the origin: world = base_link
    names = list(panda.ARM_JOINTS)

    def move(position, seconds):
        joints = kinematics.inverse(position, DOWN, seed=sim.state.q)
        sim.command_trajectory(names, [(joints.tolist(), [0.0] * 7, seconds)])
        sim.run(seconds + 0.3)

    sim.gripper.move(0.08, 0.1, sim.time)
    move(top + np.array([0.0, 0.0, 0.10]), 1.5)
    move(top - np.array([0.0, 0.0, 0.025]), 1.0)
    grasp = sim.gripper.grasp(product.size[1], 0.005, 0.005, 0.1, 20.0, sim.time)
    sim.run(0.8)
    # Expect: the grasp judged from the fingers' width: they stopped on the product's 5 cm
    assert grasp.done and grasp.success, grasp
    assert grasp.final_width == pytest.approx(product.size[1], abs=0.002)
    assert sim.world.grasped == "product_pick_1"
    move(top + np.array([0.0, 0.0, 0.15]), 1.0)
    lifted = sim.world.product_poses()["product_pick_1"][0]
    assert lifted[2] - product.position[2] == pytest.approx(0.175, abs=0.01)
    # the product rides along when the base drives
    sim.command_base_goal("world", [-0.3, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0])
    sim.run(1.0)
    carried = sim.world.product_poses()["product_pick_1"][0]
    np.testing.assert_allclose(carried - lifted, [-0.3, 0.0, 0.0], atol=0.01)
    # opening releases it: it falls to the floor
    sim.gripper.move(0.08, 0.1, sim.time)
    sim.run(1.5)
    assert sim.world.grasped is None
    assert sim.world.product_poses()["product_pick_1"][0][2] < 0.1


def test_contact_wrench_balances_the_spring(robot_sim, kinematics):
    sim = robot_sim
    running = sim.manager.running
    if running != TRAJECTORY:
        assert sim.switch_controllers([TRAJECTORY], [running] if running else [], 2)[0]
    # the ready posture first: teleporting the base must not put the arm into the shelf
    sim.command_trajectory(panda.ARM_JOINTS, [(list(sim.scene.robot.ready_joint_positions), [0.0] * 7, 1.0)])
    sim.run(1.2)
    sim.world.teleport_base(sim.scene.base_poses["place_perpendicular"])
    spot, board_top = [0.62, -0.45], 0.65  # on board_high, clear of the products (base_link)
    above = kinematics.inverse([*spot, board_top + 0.05], DOWN, seed=sim.state.q)
    sim.command_trajectory(panda.ARM_JOINTS, [(above.tolist(), [0.0] * 7, 1.5)])
    sim.run(2.0)
    assert sim.switch_controllers([IMPEDANCE], [TRAJECTORY], 2)[0]
    sim.command_eigenvalues([800.0, 800.0, 800.0])
    sim.command_equilibrium("base_link", [*spot, board_top - 0.03], DOWN)
    sim.run(2.0)
    force, _ = sim.world.external_wrench()
    # Expect the board to push up with what the spring pulls down: K (z - z_ref), the fingers resting on the board
    stretch = sim.state.position[2] - (board_top - 0.03)
    assert 0.0 < stretch < 0.05  # below the attractor clipping
    spring = 800.0 * stretch
    assert force[2] == pytest.approx(spring, rel=0.05)
    assert sim.switch_controllers([TRAJECTORY], [IMPEDANCE], 2)[0]
    sim.command_trajectory(panda.ARM_JOINTS, [(above.tolist(), [0.0] * 7, 0.5)])
    sim.run(0.7)
