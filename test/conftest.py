import fcntl
import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]

# --- the tiers (docs/architecture.md, "Tests"): the full run collects everything; --fast what needs no system ------
SYSTEM_FOLDERS = ("ros", "gui", "e2e")  # under test/: real nodes over a master, the GUI in an X server, whole runs
FULL_RUN_ONLY = ("rostest", "gui", "system", "slow")  # markers (pyproject.toml) of what --fast leaves out

# --- side by side (pytest-xdist: scripts/test runs the full suite with -n N --dist loadgroup) ----------------------
# A test file is one unit of work, run by one worker (its module fixtures bring a system up once); the tests of
# SPREAD_ONE_BY_ONE (a rostest launch file each: its own master, on a port the OS picks) each go to the next free
# worker (pytest_xdist_make_scheduler).
# What the workers could share is their own: each worker has its own ROS_HOME, ROS_LOG_DIR and TELETEACH_DATA
# (worker_environment), every master is on a free port (own_roscore, rostest), every X server on a display it picks
# (-displayfd: pytest-xvfb's, one per worker, and start_xvfb's); the solver cache is shared (written atomically).
SPREAD_ONE_BY_ONE = ("test/test_rostests.py",)
# What cannot run side by side: a test of ALONE holds the run's `system` lock exclusively, so no other `system` test
# runs beside it; of those, the ones that measure rates (MEASURES_RATES) also hold the `rates` lock exclusively. A test
# of LIGHT holds only `rates` shared: it runs beside the e2e systems as a test that needs no system does, where the
# other `system` tests hold `system` shared. test/e2e is one unit, run first (the workers' collection puts it first,
# then the files without a `system` test, then LIGHT, then the other `system` tests: run_order).
ALONE = {
    "test/e2e/": "whole systems (simulation, GUI, tree, device, recorder: about 1.5 of 2 cores) with waits bounded on"
    " the wall clock: three at once missed them (the study timed out at 420 s, teach_placement at 480 s, the thesis run"
    " dropped product_pick_1 at a real-time factor of 0.44)",
    "test/test_rostests.py::test_rostest[shared_control_boundary]": "bounds its 50 Hz loop's rate (> 45 Hz) and late"
    " cycles (< 50 %): beside the e2e runs, under other sessions' load, 72 % were late",
    "test/gui/test_bench_haptic_guidance.py": "a modelled hand on the wall clock clicks through the device node's 1 kHz"
    " loop: beside another system test the guidance went stale and a click's push confirmed a neighbour (CI), under"
    " two busy loops three clicks in a row were not taken",
    "test/gui/test_virtual_gestures_under_load.py": "spawns four busy loops on the cores and asks that the virtual"
    " device's key gestures arrive the same through its 1 kHz loop: beside it another system test would starve, and"
    " another's load would be counted as the hogs'",
}
MEASURES_RATES = (
    "test/test_rostests.py::test_rostest[shared_control_boundary]",
    "test/gui/test_bench_haptic_guidance.py",
    "test/gui/test_virtual_gestures_under_load.py",
)
LIGHT = {  # a master and a few nodes of the tree or the runtime, the longest 23 s (docs/benchmarks.md)
    **{
        f"test/test_rostests.py::test_rostest[{name}]": "the tree node and the skill test server (a sleep per skill),"
        " no simulation, GUI or device loop"
        for name in (
            "bt_change_tree",
            "bt_help",
            "bt_pause",
            "bt_persistence",
            "bt_recovery",
            "bt_respawn",
            "bt_sequence",
            "bt_server_lost",
            "bt_startup",
            "bt_tree_policy",
        )
    },
    "test/test_rostests.py::test_rostest[one_goal_action_server]": "an action server and its client",
    "test/test_rostests.py::test_rostest[stiffness_bridge]": "the stiffness bridge and a check",
    "test/ros/test_bt_action_internals.py": "an action server and client in one node",
    "test/ros/test_node_init.py": "a node's start against a master",
    "test/ros/test_scene_labels.py": "the scene_labels node and a probe",
    "test/unit/test_experiment.py": "a master, an Xvfb and child processes that end on their own",
    "test/unit/test_learning_command.py": "the learn_skill command",
    "test/unit/test_node_start.py": "nodes started and stopped at once",
}
E2E = "test/e2e/"
LOCKS = ("system", "rates")  # taken in this order, so no two workers wait on each other


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
    worker = getattr(config, "workerinput", {}).get("workerid")  # "gw0", "gw1", ...: an xdist worker
    if worker:
        os.environ.update(worker_environment(config, worker))
        config.teleteach_locks = RunLocks(run_folder(config))


def run_folder(config) -> pathlib.Path:
    """The folder of this run that every worker shares: the parent of a worker's basetemp (xdist's
    ``<the run's basetemp>/popen-<worker>``)."""
    return pathlib.Path(config.option.basetemp).parent  # xdist sets it in every worker


class RunLocks:
    """The run's lock files (LOCKS), each held by a worker's test exclusively or shared, as locks_needed says."""

    def __init__(self, folder: pathlib.Path):
        # open for the worker's life: the OS releases a dead worker's locks
        self.files = {name: open(folder / f"{name}.lock", "a") for name in LOCKS}
        self.held = {}  # name -> "exclusive" | "shared"

    def hold(self, needed: dict):
        """Release what ``needed`` does not name, then take what it names in LOCKS' order."""
        for name in [name for name in self.held if name not in needed]:
            fcntl.flock(self.files[name], fcntl.LOCK_UN)
            del self.held[name]
        for name in LOCKS:
            if name in needed and self.held.get(name) != needed[name]:
                fcntl.flock(self.files[name], fcntl.LOCK_EX if needed[name] == "exclusive" else fcntl.LOCK_SH)
                self.held[name] = needed[name]

    def release(self):
        self.hold({})


def alone(item) -> bool:
    return item.nodeid.startswith(tuple(ALONE))


def locks_needed(item) -> dict:
    """ALONE: `system` exclusively (and `rates`, if it measures them); LIGHT: `rates` shared; another `system` test:
    `system` shared; a test that needs no system: nothing."""
    if alone(item):
        rates = {"rates": "exclusive"} if item.nodeid.startswith(MEASURES_RATES) else {}
        return {"system": "exclusive", **rates}
    if item.nodeid.startswith(tuple(LIGHT)):
        return {"rates": "shared"}
    return {"system": "shared"} if item.get_closest_marker("system") else {}


@pytest.hookimpl(hookwrapper=True, tryfirst=True)  # outside pytest-timeout's: the wait for the lock is no test's time
def pytest_runtest_protocol(item, nextitem):
    """In a worker: the test holds the locks it needs (from the first of consecutive ALONE tests to the last)."""
    locks = getattr(item.config, "teleteach_locks", None)
    if locks is not None:
        locks.hold(locks_needed(item))
    try:
        yield
    finally:
        if locks is not None and not (alone(item) and nextitem is not None and alone(nextitem)):
            locks.release()


def worker_environment(config, worker: str) -> dict:
    """ROS_HOME, ROS_LOG_DIR and TELETEACH_DATA of an xdist worker: folders of its own beside its basetemp (which
    pytest empties when it first hands out a tmp_path), in the run's folder, which pytest's retention cleans."""
    root = run_folder(config)
    folders = {
        "ROS_HOME": root / f"{worker}-ros_home",
        "ROS_LOG_DIR": root / f"{worker}-ros_home" / "log",
        "TELETEACH_DATA": root / f"{worker}-teleteach_data",
    }
    for folder in folders.values():
        folder.mkdir(parents=True, exist_ok=True)
    return {name: str(folder) for name, folder in folders.items()}


def pytest_collection_modifyitems(config, items):
    """Mark ``system`` what brings up a system (a test in SYSTEM_FOLDERS, a user of the roscore fixture, a rostest); in
    an xdist worker, put test/e2e first and the files without a `system` test next; with --fast, leave out everything
    marked with one of FULL_RUN_ONLY."""
    folders = [ROOT / "test" / folder for folder in SYSTEM_FOLDERS]
    for item in items:
        in_folder = any(folder in item.path.parents for folder in folders)
        if in_folder or "roscore" in item.fixturenames or item.get_closest_marker("rostest"):
            item.add_marker(pytest.mark.system)
    if hasattr(config, "workerinput"):  # the order the scheduler hands the units out in: the longest first
        with_system = {item.path for item in items if item.get_closest_marker("system")}
        items.sort(key=lambda item: run_order(item, with_system))
    if not config.getoption("fast"):
        return
    kept, left_out = [], []
    for item in items:
        (left_out if any(item.get_closest_marker(name) for name in FULL_RUN_ONLY) else kept).append(item)
    if left_out:
        config.hook.pytest_deselected(items=left_out)
        items[:] = kept


def run_order(item, with_system: set) -> int:
    """test/e2e first, then the files without a `system` test, LIGHT, and the other `system` tests."""
    if item.nodeid.startswith(E2E):
        return 0
    if item.path not in with_system:
        return 1
    return 2 if item.nodeid.startswith(tuple(LIGHT)) else 3


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """With --dist loadgroup: a unit of work is a test file (a test of SPREAD_ONE_BY_ONE on its own, test/e2e's
    together, tests marked ``xdist_group`` with their group), handed out in the workers' collection order
    (pytest_collection_modifyitems), where xdist's loadgroup would sort the units by their number of tests."""
    if config.getoption("dist") != "loadgroup":
        return None
    from collections import OrderedDict

    from xdist.scheduler import LoadGroupScheduling

    class FilesInCollectionOrder(LoadGroupScheduling):
        def _split_scope(self, nodeid):
            if "@" in nodeid.rsplit("]", 1)[-1]:  # an xdist_group marker's name, added to the id by loadgroup
                return nodeid.rsplit("@", 1)[1]
            path = nodeid.split("::", 1)[0]
            return E2E if path.startswith(E2E) else nodeid if path in SPREAD_ONE_BY_ONE else path

        def _reschedule(self, node):
            """The next unit once the node's is down to its last test (xdist: two), so that a node holds at most one
            unit beyond the test it runs, and a long one waits for the first node free instead of a busy one."""
            if node.shutting_down:
                return
            if not self.workqueue:
                node.shutdown()
            elif self._pending_of(self.assigned_work[node]) <= 1:
                self._assign_work_unit(node)

        def _assign_work_unit(self, node):
            if not getattr(self, "in_collection_order", False):  # the first unit handed out: the queue is complete
                index = {nodeid: position for position, nodeid in enumerate(self.collection)}
                units = sorted(self.workqueue.items(), key=lambda unit: min(index[nodeid] for nodeid in unit[1]))
                self.workqueue = OrderedDict(units)
                self.in_collection_order = True
            super()._assign_work_unit(node)

    return FilesInCollectionOrder(config, log)


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
