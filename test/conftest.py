import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def pytest_configure(config):
    if "TELETEACH_ROOT" not in os.environ:
        raise pytest.UsageError("run the tests through `bash scripts/test` (it sources build/env.sh first)")


@pytest.fixture
def artifacts_dir():
    """Folder for files a person should look at after the run (screenshots, plots)."""
    path = ROOT / "test-artifacts"
    path.mkdir(exist_ok=True)
    return path


@pytest.fixture(scope="module")
def roscore(tmp_path_factory):
    """A roscore of our own on a free port (own_roscore), stopped by its PID afterwards: the environment to run in."""
    from teleteach.runtime.processes import Processes, own_roscore

    env = dict(os.environ, ROS_LOG_DIR=str(tmp_path_factory.mktemp("log")))
    processes = Processes()

    def start_roscore(command, uri):
        env["ROS_MASTER_URI"] = uri
        return processes.start("roscore", command, env=env)

    own_roscore(start_roscore, processes.stop)
    try:
        yield env
    finally:
        processes.stop_all()


# --- the skills on the real in-process simulation (pybullet, no ROS) ---------------------------------------------


@pytest.fixture(scope="module")
def kinematics():
    """Panda forward kinematics and Jacobian (pybullet, its own client), shared by a module's tests."""
    from teleteach.control.kinematics import PandaKinematics

    model = PandaKinematics(0.40)
    yield model
    model.close()


@pytest.fixture
def sim():
    """A fresh simulated robot in the supermarket (exact base and perception: RobotSim's defaults)."""
    from teleteach.sim.robot_sim import RobotSim

    simulation = RobotSim()
    yield simulation
    simulation.close()


@pytest.fixture
def sim_robot(sim):
    """The skills' robot interface over ``sim``."""
    from teleteach.run.sim_robot import SimRobot

    return SimRobot(sim)


@pytest.fixture
def runner(sim, sim_robot, kinematics):
    """The skill runner over ``sim_robot``, with the package's motion configuration."""
    from teleteach.skills.config import load_motion_config
    from teleteach.skills.runner import SkillRunner

    return SkillRunner(sim_robot, load_motion_config(), sim.scene, kinematics)
