"""Shared set-up for the simulation unit tests: a real RobotSim (pybullet DIRECT) per test module."""

from teleteach.sim.robot_sim import IMPEDANCE, TRAJECTORY, RobotSim

__all__ = ["IMPEDANCE", "TRAJECTORY", "robot_sim_for_module", "to_impedance"]


def robot_sim_for_module():
    """Body of each test module's module-scoped `robot_sim` fixture."""
    sim = RobotSim()
    yield sim
    sim.close()


def to_impedance(sim):
    """Switch the arm to the impedance controller (STRICT) and let it settle."""
    if sim.manager.running != IMPEDANCE:
        ok, message = sim.switch_controllers([IMPEDANCE], [sim.manager.running] if sim.manager.running else [], 2)
        assert ok, message
    sim.run(0.1)
