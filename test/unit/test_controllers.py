"""Controller manager semantics (ros_control), joint trajectory interpolation, bumpless switching on the real sim."""

import numpy as np
import pytest
from sim_support import IMPEDANCE, TRAJECTORY, robot_sim_for_module, to_impedance

from teleteach.control.joint_trajectory import JointTrajectoryController
from teleteach.control.manager import BEST_EFFORT, STRICT
from teleteach.core.validation import InvalidCommandError


@pytest.fixture(scope="module")
def robot_sim():
    yield from robot_sim_for_module()


def states(sim):
    return {info.name: info.state for info in sim.manager.list_controllers()}


def test_list_controllers(robot_sim):
    infos = {info.name: info for info in robot_sim.manager.list_controllers()}
    assert infos[TRAJECTORY].state == "running" and infos[IMPEDANCE].state == "stopped"
    assert infos[IMPEDANCE].hardware_interface == "hardware_interface::EffortJointInterface"
    assert infos[TRAJECTORY].hardware_interface == "hardware_interface::PositionJointInterface"
    assert infos[IMPEDANCE].resources == tuple(f"panda_joint{i}" for i in range(1, 8))


@pytest.mark.parametrize(
    ("start", "stop"),
    [
        ([IMPEDANCE, "unknown"], [TRAJECTORY]),  # unknown controller to start
        ([IMPEDANCE], [TRAJECTORY, "unknown"]),  # unknown controller to stop
        ([], [IMPEDANCE]),  # stopping a stopped controller
        ([TRAJECTORY], []),  # starting a running controller
    ],
)
def test_strict_fails_and_changes_nothing(robot_sim, start, stop):
    before = states(robot_sim)
    ok, message = robot_sim.switch_controllers(start, stop, STRICT)
    assert not ok and message
    assert states(robot_sim) == before


def test_resource_conflict_fails_in_both_modes(robot_sim):
    for strictness in (STRICT, BEST_EFFORT):
        ok, message = robot_sim.switch_controllers([IMPEDANCE], [], strictness)
        assert not ok and "resource conflict" in message
    assert states(robot_sim) == {TRAJECTORY: "running", IMPEDANCE: "stopped"}


def test_best_effort_does_what_it_can_and_switching_is_bumpless(robot_sim):
    sim = robot_sim
    sim.run(0.2)
    before = sim.state.position.copy()
    ok, _ = sim.switch_controllers([IMPEDANCE, "unknown"], [TRAJECTORY, "unknown"], BEST_EFFORT)
    assert ok
    # Expect the impedance controller running and holding: < 5 mm in the 0.5 s after the switch
    assert states(sim) == {TRAJECTORY: "stopped", IMPEDANCE: "running"}
    motion = []
    for _ in range(500):
        sim.tick()
        motion.append(np.linalg.norm(sim.state.position - before))
    assert max(motion) < 0.005
    # and back, STRICT
    before = sim.state.position.copy()
    ok, _ = sim.switch_controllers([TRAJECTORY], [IMPEDANCE], STRICT)
    assert ok
    for _ in range(500):
        sim.tick()
        motion.append(np.linalg.norm(sim.state.position - before))
    assert max(motion) < 0.005


def test_no_controller_freezes_physics(robot_sim):
    sim = robot_sim
    assert sim.switch_controllers([], [sim.manager.running], STRICT)[0]
    q = sim.state.q.copy()
    sim.run(0.3)
    # Expect the arm exactly where it was (physics is not stepped while no controller holds the arm)
    np.testing.assert_allclose(sim.state.q, q, rtol=0.0, atol=1e-12)
    assert sim.switch_controllers([TRAJECTORY], [], STRICT)[0]


def test_joint_trajectory_follows_and_holds(robot_sim):
    sim = robot_sim
    start = sim.state.q.copy()
    goal = start + np.array([0.2, -0.1, 0.0, 0.1, 0.0, 0.1, 0.0])
    names = [f"panda_joint{i}" for i in range(1, 8)]
    sim.command_trajectory(names, [(goal.tolist(), [0.0] * 7, 1.0)])
    sim.run(1.5)
    np.testing.assert_allclose(sim.state.q, goal, atol=2e-3)
    sim.command_trajectory(names, [(start.tolist(), [], 0.5)])
    sim.run(1.0)
    np.testing.assert_allclose(sim.state.q, start, atol=2e-3)


def test_interpolation_linear_and_cubic():
    controller = JointTrajectoryController()
    controller.hold(np.zeros(7), now=0.0)
    controller.set_trajectory(0.0, [1.0, 2.0], np.array([np.ones(7), 3 * np.ones(7)]), None, now=0.0)
    np.testing.assert_allclose(controller.sample(0.5)[0], 0.5)
    np.testing.assert_allclose(controller.sample(1.5)[0], 2.0)
    np.testing.assert_allclose(controller.sample(1.5)[1], 2.0)  # slope of the second segment [rad/s]
    np.testing.assert_allclose(controller.sample(5.0)[0], 3.0)  # holds the last point
    np.testing.assert_allclose(controller.sample(5.0)[1], 0.0)
    # cubic with zero end velocities: smooth start and stop, midpoint at half way
    controller.hold(np.zeros(7), now=0.0)
    controller.set_trajectory(0.0, [2.0], np.array([np.ones(7)]), np.zeros((1, 7)), now=0.0)
    np.testing.assert_allclose(controller.sample(1.0)[0], 0.5)
    np.testing.assert_allclose(controller.sample(1e-6)[1], 0.0, atol=1e-5)
    np.testing.assert_allclose(controller.sample(1.0)[1], 0.75)  # 1.5 * distance / duration


def test_trajectory_in_the_past_is_rejected_and_past_points_dropped():
    controller = JointTrajectoryController()
    controller.hold(np.zeros(7), now=10.0)
    with pytest.raises(InvalidCommandError, match="past"):
        controller.set_trajectory(5.0, [1.0, 2.0], np.ones((2, 7)), None, now=10.0)
    controller.set_trajectory(9.0, [0.5, 2.0], np.array([np.ones(7), 2 * np.ones(7)]), None, now=10.0)
    np.testing.assert_allclose(controller.sample(10.0)[0], 0.0)  # starts from the current setpoint
    np.testing.assert_allclose(controller.goal, 2.0)


def test_the_impedance_torque_changes_at_most_1_nm_per_ms(robot_sim):
    sim = robot_sim
    to_impedance(sim)
    sim.command_eigenvalues([3000.0] * 3)
    sim.run(1.5)  # the stiffness filter's 0.2 s time constant: at its target
    position, quaternion = sim.state.position.copy(), sim.state.quaternion.copy()
    sim.command_equilibrium("base_link", position + np.array([0.0, 0.05, 0.05]), quaternion)
    torques = [sim.impedance.last_torque.copy()]
    for _ in range(100):
        sim.tick()
        torques.append(sim.impedance.last_torque.copy())
    steps = np.abs(np.diff(torques, axis=0)).max(axis=1)  # [Nm] per 1 ms tick, the largest joint's
    # Expect the 150 N pull of the jump (K e at the 5 cm clip) to build up at the limit of 1 Nm per tick, not at once
    assert sim.world.time_step == 0.001
    assert steps.max() <= 1.0 + 1e-9
    assert np.all(steps[:10] == pytest.approx(1.0))
    sim.command_equilibrium("base_link", position, quaternion)
    sim.run(1.0)
    assert sim.switch_controllers([TRAJECTORY], [IMPEDANCE], STRICT)[0]
