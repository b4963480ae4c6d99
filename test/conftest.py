import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]

# --- the tiers (docs/architecture.md, "Tests"): the full run collects everything; --fast what needs no system ------
SYSTEM_FOLDERS = ("ros", "gui", "e2e")  # under test/: real nodes over a master, the GUI in an X server, whole runs
FULL_RUN_ONLY = ("rostest", "gui", "system", "slow")  # markers (pyproject.toml) of what --fast leaves out


def pytest_addoption(parser):
    parser.addoption(
        "--fast",
        action="store_true",
        help="the fast tier: lint and every test that needs no ROS master, X server or launch, unless marked slow",
    )


@pytest.hookimpl(tryfirst=True)  # before pytest-xvfb's: the fast tier starts no X server
def pytest_configure(config):
    if "TELETEACH_ROOT" not in os.environ:
        raise pytest.UsageError("run the tests through `bash scripts/test` (it sources build/env.sh first)")
    if config.getoption("fast"):
        config.option.no_xvfb = True


def pytest_collection_modifyitems(config, items):
    """Mark ``system`` what brings up a system (a test in SYSTEM_FOLDERS, or one that uses the roscore fixture); with
    --fast, leave out everything marked with one of FULL_RUN_ONLY."""
    folders = [ROOT / "test" / folder for folder in SYSTEM_FOLDERS]
    for item in items:
        if any(folder in item.path.parents for folder in folders) or "roscore" in item.fixturenames:
            item.add_marker(pytest.mark.system)
    if not config.getoption("fast"):
        return
    kept, left_out = [], []
    for item in items:
        (left_out if any(item.get_closest_marker(name) for name in FULL_RUN_ONLY) else kept).append(item)
    if left_out:
        config.hook.pytest_deselected(items=left_out)
        items[:] = kept


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
