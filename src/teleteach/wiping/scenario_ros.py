"""run_wipe's ROS side: the system, the scripted operator and the world's record.

What the scenario does and how it is judged: teleteach.wiping.scenario.
"""

import argparse
import math
import pathlib
import shutil
import subprocess
import sys
import threading
import time
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from teleteach.control.stiffness import translational_stiffness
from teleteach.core import skill_file
from teleteach.core.datadir import data_dir
from teleteach.core.frames import Transform
from teleteach.core.gui_config import GuiConfig
from teleteach.core.scene import load_scene
from teleteach.core.wiping import load_wiping_config
from teleteach.gui.arm import pose_to_array
from teleteach.gui.recording import StiffnessRecorder
from teleteach.runtime.experiment import Experiment
from teleteach.runtime.processes import closed_bag
from teleteach.shared_control.config import INPUTS
from teleteach.shared_control.ros import task_of
from teleteach.shared_control.surface import wiping_box
from teleteach.wiping import scenario
from teleteach.wiping.assistance import moving_edge
from teleteach.wiping.ros import ScriptedWipe, WorldRecord, board_in_base, drive_to

TREE_INDEX = 1  # the learned skill goes after MoveBaseAside (config/scenarios/wipe_tree.yaml)
STATUSES = {1: "INVALID", 2: "RUNNING", 3: "SUCCESS", 4: "FAILURE"}


class TreeWatch:
    """The latest status and message of each node of the tree (/behaviour_tree/log/tree) and the library's names."""

    def __init__(self, learned: str):
        import rospy

        from teleteach.msg import BehaviourTree, SkillLibrary

        self.learned = learned
        self._lock = threading.Lock()
        self.nodes: Dict[str, Tuple[str, str]] = {}
        self.library: Tuple[str, ...] = ()
        self.started: Optional[float] = None  # ROS time [s] the learned skill was first seen running
        self._subscribers = [
            rospy.Subscriber("/behaviour_tree/log/tree", BehaviourTree, self._on_tree, queue_size=10),
            rospy.Subscriber("/behaviour_tree/skill_library", SkillLibrary, self._on_library, queue_size=1),
        ]
        self._now = rospy.get_time

    def _on_tree(self, message) -> None:
        with self._lock:
            self.nodes = {b.name: (STATUSES.get(b.status, "?"), b.message) for b in message.behaviours}
            if self.started is None and self.nodes.get(self.learned, ("",))[0] == "RUNNING":
                self.started = self._now()

    def _on_library(self, message) -> None:
        with self._lock:
            self.library = tuple(message.names)

    def status(self, name: str) -> Tuple[str, str]:
        """(status, message) of the node ``name``: ("", "") until it is in the tree."""
        with self._lock:
            return self.nodes.get(name, ("", ""))


class DemonstrationRecorder:
    """What the GUI records of a wipe: each /equilibrium_pose with the stiffness commanded and the arm's pose."""

    def __init__(self, operator: ScriptedWipe):
        import rospy
        from geometry_msgs.msg import PoseStamped

        self.operator, self.recorder, self._measured = operator, StiffnessRecorder(), None
        self._subscribers = [
            rospy.Subscriber("/cartesian_pose", PoseStamped, self._on_arm, queue_size=10),
            rospy.Subscriber("/equilibrium_pose", PoseStamped, self._on_equilibrium, queue_size=100),
        ]

    def _on_arm(self, message) -> None:
        self._measured = pose_to_array(message.pose)

    def _on_equilibrium(self, message) -> None:
        values, quaternion = self.operator.stiffness
        stiffness = translational_stiffness(values, quaternion)
        self.recorder.add(message.header.stamp.to_sec(), stiffness, pose_to_array(message.pose), self._measured)

    def close(self) -> None:
        """Unregister the topics."""
        for subscriber in self._subscribers:
            subscriber.unregister()


class WipeScenario:
    """One run of the scenario into ``<root>/runs/wipe_<time>/``; :meth:`run` returns the summary."""

    def __init__(self, root: pathlib.Path, timeout: float, hand: str = "operator_command"):
        self.root, self.timeout, self.hand = pathlib.Path(root), timeout, hand
        self.folder = self.root / "runs" / ("wipe_" + time.strftime("%Y-%m-%d-%H-%M-%S"))
        self.folder.mkdir(parents=True)
        self.experiment = Experiment(self.folder, self.root)
        self.prefix = "wipe_" + self.folder.name.replace("-", "_")
        self.scene, self.config = load_scene(), load_wiping_config()
        board = self.scene.surface(scenario.BOARD)
        self.footprint = self.scene.wiping_tool.size[:2]
        self.box, self.area = wiping_box(board, self.footprint), board.area
        self._deadline = time.monotonic() + timeout
        stamp = self.folder.name.removeprefix("wipe_").replace("-", "_")  # a run's skills never replace another's
        self.demonstration, self.learned = f"DemonstratedWipe_{stamp}", f"LearnedWipe_{stamp}"

    def say(self, line: str) -> None:
        """One line of progress on stdout."""
        print(f"run_wipe: {line}", flush=True)

    def left(self) -> float:
        """Wall time [s] left of the run's timeout (TimeoutError when none is)."""
        remaining = self._deadline - time.monotonic()
        if remaining <= 0:
            raise TimeoutError(f"the scenario took longer than {self.timeout:.0f} s")
        return remaining

    def run(self) -> dict:
        """Everything; the processes are stopped whatever happens."""
        with self.experiment:
            summary = self._run()
        bag = closed_bag(self.root / "bags", self.prefix, self.folder, 30.0)
        summary["bag"] = str(bag) if bag else None
        scenario.write_summary(self.folder, summary)
        self.say(f"{'PASSED' if summary['passed'] else 'FAILED'}; see {self.folder / 'summary.md'}")
        return summary

    def _run(self) -> dict:
        experiment = self.experiment
        command = ["roslaunch", "teleteach", "wipe.launch", f"data_dir:={self.root}", f"record_prefix:={self.prefix}"]
        command.append(f"input:={self.hand}")
        experiment.own_launch(lambda port: command[:1] + ["-p", str(port)] + command[1:], self.folder / "launch.log")
        experiment.join("run_wipe", anonymous=True, sim_time=True)
        self.say(f"launched wipe.launch (master {experiment.master_uri}), log {self.folder / 'launch.log'}")
        record, tree = WorldRecord(), TreeWatch(self.learned)
        if not experiment.wait_until(lambda: record.poses, self.left()):
            raise TimeoutError("no /cartesian_pose from robot_sim")
        if not drive_to(scenario.TEACHING_POSE, timeout=min(self.left(), 120.0)):
            raise RuntimeError(f"the base did not arrive at {scenario.TEACHING_POSE}")
        seen, true = board_in_base()
        operator = ScriptedWipe(self.hand, scenario.PATTERNS)
        start_stiffness = tuple(float(value) for value in GuiConfig.load().shared_control_stiffness)
        operator.press_with(seen, start_stiffness)
        operator.enable()
        if not experiment.wait_until(lambda: record.states, min(self.left(), 120.0)):
            raise TimeoutError("shared control never started on the board (no /shared_control/state)")
        located = self._located()
        windows, recorder = self._wipe(operator, start_stiffness, located)
        operator.enable(False)
        phases, tracks = self._figures(windows, record, true, located)
        phases["teaching"].update(
            {
                "stiffness_before": list(start_stiffness),
                "stiffness_taught": list(scenario.TAUGHT),
                "demonstration": str(self._save_demonstration(recorder, located)),
            }
        )
        phases["replay"], replay_track = self._replay(tree, record, phases["teaching"]["grid"])
        if replay_track is not None:
            tracks["replay"] = replay_track
        scenario.plot_contact_force(tracks, self.config.contact_threshold, self.folder / "contact_force.png")
        for phase in phases.values():
            phase.pop("grid", None)
        found = scenario.checks(phases, self.config)
        for check in found:
            self.say(f"{'ok  ' if check['passed'] else 'FAIL'} {check['check']}: {check['seen']}")
        passed = all(check["passed"] for check in found)
        return {"passed": passed, "input": self.hand, "checks": found, "phases": phases}

    def _located(self) -> Transform:
        """The board as the node located it on enable (/shared_control/task), in base_link."""
        import rospy

        from teleteach.msg import SharedControlTask

        message = rospy.wait_for_message("/shared_control/task", SharedControlTask, timeout=min(self.left(), 30.0))
        _, surface = task_of(message)
        if surface is None or surface[0] != scenario.BOARD:
            raise RuntimeError(f"shared control wipes {message.surface!r}, not {scenario.BOARD}")
        return surface[1]

    def _tracks(self, record: WorldRecord, start: float, end: float, true: Transform, located: Transform):
        """The phase's TCP and force on the true board and on the board as located."""
        with record.lock:
            poses = [entry for entry in record.poses if start <= entry[0] <= end]
            forces = [entry for entry in record.forces if start - 0.5 <= entry[0] <= end]
        times = [entry[0] for entry in poses]
        positions, quaternions = [entry[1] for entry in poses], [entry[2] for entry in poses]
        force_times, values = [entry[0] for entry in forces], [entry[1] for entry in forces]
        return tuple(
            scenario.board_track(times, positions, quaternions, force_times, values, board) for board in (true, located)
        )

    def _states(self, record: WorldRecord, start: float, end: float):
        with record.lock:
            return [state for stamp, state, _ in record.states if start <= stamp <= end]

    def _wipe(self, operator: ScriptedWipe, start_stiffness, located: Transform):
        """The operator's wipe: each phase's (pattern, start, end, commands sent, obstacle), and the demonstration.

        One phase straight after the other: a pause longer than the node's command_timeout is input lost (it stops).
        """
        import rospy
        from geometry_msgs.msg import PoseStamped

        obstacle = rospy.Publisher("/shared_control/obstacle", PoseStamped, queue_size=10)
        demonstration = DemonstrationRecorder(operator)
        windows = {}
        for name, skill, heading, seconds in scenario.PATTERN_PHASES:
            first, begun = len(operator.sent), rospy.get_time()
            edge = (lambda stamp, begun=begun: moving_edge(stamp - begun)) if name == "cycloid" else None

            def each(k, stamp, edge=edge):
                if edge is not None:
                    obstacle.publish(_edge_message(edge(stamp), stamp))

            self.say(f"{name}: {seconds:.0f} s heading {math.degrees(heading):.0f} deg")
            start, end = operator.pattern(skill, seconds, heading, np.random.default_rng(49), each)
            windows[name] = (skill, start, end, operator.sent[first:], edge)
        before, clutched, after = scenario.TEACHING
        self.say(f"teaching: a wave, the clutch held {clutched:.1f} s shaping {start_stiffness} into {scenario.TAUGHT}")
        first = len(operator.sent)
        demonstration.recorder.start()
        start, _ = operator.pattern("wave", before, math.pi, np.random.default_rng(50))
        clutch = operator.teach(clutched, located, start_stiffness, scenario.TAUGHT)
        _, end = operator.pattern("wave", after, math.pi, np.random.default_rng(51))
        demonstration.recorder.stop()
        demonstration.close()
        obstacle.unregister()
        windows["teaching"] = ("wave", start, end, operator.sent[first:], None, clutch)
        return windows, demonstration.recorder

    def _figures(self, windows, record: WorldRecord, true: Transform, located: Transform):
        """Each phase of the wipe judged from the world (teleteach.wiping.scenario), and its track."""
        phases, tracks = {}, {}
        for name, (skill, start, end, sent, edge, *clutch) in windows.items():
            world, seen = self._tracks(record, start, end, true, located)
            states = [(state.header.stamp.to_sec(), state.skill) for state in self._states(record, start, end)]
            equilibria = record.between("equilibria", start, end)
            reference = np.array([located.inverse().apply_point(point)[:2] for point in equilibria])
            figures = scenario.phase_figures(
                world, seen, self.config, self.box, self.footprint, self.area, edge, reference.reshape(-1, 2)
            )
            phases[name] = {
                "seconds": [start, end],
                **figures,
                **scenario.pattern_figures(skill, [s for s, _ in sent], [c for _, c in sent], seen, states),
            }
            tracks[name] = world
            if clutch:
                held = self._states(record, clutch[0][0] + 0.2, clutch[0][1])
                kept = sum(state.message.startswith("clutch: keeping the wave") for state in held)
                phases[name].update({"clutch_seconds": list(clutch[0]), "clutch_kept_share": kept / max(len(held), 1)})
        return phases, tracks

    def _save_demonstration(self, recorder: StiffnessRecorder, located: Transform) -> pathlib.Path:
        """The demonstration saved as the GUI saves a wipe, in the data directory's skills and the run's folder."""
        skill = scenario_skill(recorder, self.demonstration, located, GuiConfig.load().rotational_stiffness)
        path = skill_file.save(skill, self.root / "skills" / self.demonstration)
        shutil.copy(path, self.folder / path.name)
        self.say(f"teaching: the demonstration ({skill.time[-1] - skill.time[0]:.1f} s) saved to {path}")
        return path

    def _replay(self, tree: TreeWatch, record: WorldRecord, reference_grid: np.ndarray):
        """learn_skill --add, the learned skill into the tree after MoveBaseAside, the tree started: the world says."""
        import rospy
        from std_srvs.srv import Trigger

        from teleteach.srv import ChangeTree

        demonstration, learned = self.root / "skills" / f"{self.demonstration}.npz", self.learned
        said = learn_and_add(demonstration, learned, self.root, self.experiment.environment())
        self.say(f"learned: {said.splitlines()[-1] if said else learned}")
        if not self.experiment.wait_until(lambda: learned in tree.library, min(self.left(), 30.0)):
            raise RuntimeError(f"{learned} never joined the tree's library")
        change = rospy.ServiceProxy("/change_tree", ChangeTree)(
            node_name=learned, operation="insert", index=TREE_INDEX, parent="", node_type="", parameter=0.0
        )
        if not change.success:
            raise RuntimeError(f"the tree refused {learned}: {change.message}")
        rospy.wait_for_service("/behaviour_tree/start", timeout=min(self.left(), 30.0))
        rospy.ServiceProxy("/behaviour_tree/start", Trigger)()
        self.say(f"replay: the tree drives to {scenario.REPLAY_POSE} and wipes with {learned}")
        if not self.experiment.wait_until(lambda: tree.status(learned)[0] in ("SUCCESS", "FAILURE"), self.left()):
            raise TimeoutError(f"{learned} did not end: {tree.status(learned)}")
        status, message = tree.status(learned)
        ended = rospy.get_time()
        _, true = board_in_base()
        figures = {"status": status, "message": message}
        window = self._pressing(record, true, tree.started or 0.0, ended)
        if window is None:
            return figures, None
        world, _ = self._tracks(record, *window, true, true)
        replay = scenario.replay_figures(world, self.config, self.footprint, self.area, reference_grid)
        figures.update({"seconds": list(window), **replay})
        return figures, world

    def _pressing(self, record: WorldRecord, true: Transform, start: float, end: float):
        """The learned skill's pattern: from the first to the last equilibrium below the board's face (None: none).

        Below by at least half the skill's least depth, so the glides on and off are left out.
        """
        learned = skill_file.load(self.root / "skills" / f"{self.learned}.npz")
        reach = self.scene.wiping_tool.reach
        half_depth = 0.5 * float(np.min(reach - learned.equilibrium_pose[:, 2]))
        with record.lock:
            equilibria = [(stamp, point) for stamp, point in record.equilibria if start <= stamp <= end]
        below = [stamp for stamp, point in equilibria if true.inverse().apply_point(point)[2] - reach < -half_depth]
        return (below[0], below[-1]) if len(below) > 1 else None


def scenario_skill(
    recorder: StiffnessRecorder, name: str, located: Transform, rotational_stiffness: float
) -> skill_file.Skill:
    """The recorded wipe as the GUI saves one: a ``shared_control`` skill relative to the board as located."""
    provenance = {"source": "run_wipe", "recorded": time.time(), "wiped": scenario.BOARD}
    skill = recorder.to_skill(name, rotational_stiffness, provenance, kind="shared_control")
    return skill.relative_to(scenario.BOARD, located, skill_file.SURFACE)


def _edge_message(edge, stamp: float):
    """An obstacle edge as /shared_control/obstacle's PoseStamped (task-plane x, y and the free side's yaw)."""
    import rospy
    from geometry_msgs.msg import PoseStamped

    message = PoseStamped()
    message.header.stamp = rospy.Time.from_sec(stamp)
    message.pose.position.x, message.pose.position.y = edge.x, edge.y
    message.pose.orientation.z, message.pose.orientation.w = math.sin(edge.yaw / 2), math.cos(edge.yaw / 2)
    return message


def learn_and_add(demonstration: pathlib.Path, name: str, root: pathlib.Path, environment: Dict[str, str]) -> str:
    """``rosrun teleteach learn_skill DEMONSTRATION --name NAME --add``, as the GUI runs it: into the tree's library."""
    command = ["rosrun", "teleteach", "learn_skill", str(demonstration), "--name", name, "--add"]
    command += ["--data-dir", str(root), "--timeout", "60"]
    learned = subprocess.run(command, capture_output=True, text=True, timeout=300, check=False, env=environment)
    if learned.returncode != 0:
        raise RuntimeError(f"learn_skill failed: {learned.stdout}{learned.stderr}".strip())
    return learned.stdout.strip()


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``run_wipe [--data-dir DIR] [--timeout S]``: 0 when every check passed, 1 when one failed, 2 on an error."""
    parser = argparse.ArgumentParser(prog="run_wipe", description=scenario.__doc__.splitlines()[0])
    parser.add_argument("--data-dir", type=pathlib.Path, default=None, help="data directory (default: the usual)")
    parser.add_argument("--timeout", type=float, default=900.0, help="[s] wall time allowed for the whole scenario")
    parser.add_argument(
        "--input",
        choices=INPUTS,
        default="operator_command",
        help="how the operator's commands come: the task-plane velocity, a joystick (/joy) or the Sigma.7's twist",
    )
    arguments = parser.parse_args(argv)
    try:
        summary = WipeScenario(data_dir(arguments.data_dir), arguments.timeout, arguments.input).run()
    except (RuntimeError, TimeoutError, ValueError) as error:
        print(f"run_wipe: {error}", file=sys.stderr)
        return 2
    return 0 if summary["passed"] else 1
