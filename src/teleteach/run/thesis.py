"""The main job: the thesis' experiments (III-B to III-E) unattended, headless, with a run folder of results.

:func:`run_thesis` starts Xvfb when there is no display, launches ``full.launch`` headless with the scripted device
playing ``config/scenarios/thesis_full.yaml`` and the session recorder on, watches the tree and the scene until the
scenario has ended and the tree has finished (bounded in wall time), screenshots the GUI tabs and an RViz view, stops
everything newest first, and writes into ``<data dir>/runs/<timestamp>/``: the bag, the taught skill(s), the tree
before and after, the report with the thesis-style plots, the screenshots and ``summary.json``/``summary.md``.
"""

import dataclasses
import functools
import pathlib
import shutil
import signal
import subprocess
import threading
import time
from typing import Callable, Dict, List, Optional, Tuple

import numpy as np
import yaml
from py_trees.common import Status

from teleteach.bt.library import SkillEntry, SkillLibrary
from teleteach.bt.tree import TreeSpec, load_tree
from teleteach.core.active_tab import Tab
from teleteach.core.datadir import atomic_write_text, data_dir
from teleteach.core.observed import TRUE_SCENE_TOPIC, product_positions
from teleteach.core.paths import config_file, share_dir
from teleteach.core.scene import SceneError, load_scene
from teleteach.haptics.scenario import load_scenario
from teleteach.recording.report import make_report
from teleteach.recording.session import SessionError, read_session, yaw_of
from teleteach.run import outcome
from teleteach.run.narration import Narration
from teleteach.run.outcome import RunSummary
from teleteach.run.pictures import background_colour, rviz_picture
from teleteach.runtime.experiment import Experiment
from teleteach.runtime.node import server_has, server_value
from teleteach.runtime.processes import (
    ProcessError,
    closed_bag,
    full_launch,
    screenshot,
    scripted_device,
    start_xvfb,
)

DEFAULT_SCENARIO = config_file("scenarios", "thesis_full.yaml")
TREE_FILE = config_file("tree.yaml")
SKILLS_FILE = config_file("skills.yaml")
RVIZ_CONFIG = share_dir() / "rviz" / "teleteach.rviz"
RVIZ_SCREEN = "1200x846x24"  # the layout's window size: RViz fills its display
RVIZ_TIMEOUT = 45.0  # [s] wall time for RViz to show its window and draw the scene (loaded 2-core machine: ~20 s)
RVIZ_STARTS = 2  # RViz is started again once when it exited or showed nothing in time
MASTER_GONE_WAIT = 30.0  # [s] for roslaunch to end once its master stopped answering (it stops its nodes first)
EXECUTION = "BehaviorExecution"
# teleteach/Behaviour's status constants (INVALID, RUNNING, SUCCESS, FAILURE) as py_trees' statuses
STATUSES = {1: Status.INVALID, 2: Status.RUNNING, 3: Status.SUCCESS, 4: Status.FAILURE}


@dataclasses.dataclass
class Options:
    """What to run and the thesis' expectations (defaults: thesis_full.yaml; see :func:`options_for`)."""

    scenario: pathlib.Path = DEFAULT_SCENARIO
    data_root: Optional[pathlib.Path] = None
    # [s] wall time allowed for the scenario and the tree: a bound for a run that hangs, not a speed goal (74 s of
    # simulated scenario plus its waits took 234 s at load 7 on 2 cores, both products placed)
    timeout: float = 300.0
    rviz: bool = True
    tree: pathlib.Path = TREE_FILE
    skills: pathlib.Path = SKILLS_FILE
    trajectory: str = "perpendicular"
    phases: Optional[str] = None  # the stiffness phases' timing (outcome.PHASES); None: the trajectory's
    taught_used_by: Optional[str] = None  # a leaf that must succeed placing with the taught skill (PlaceTaught)
    # (product, gap, who must set it down: a tree leaf, TAUGHT_SKILL for the taught skill's, None for anyone) for
    # every product that must end in a gap: III-C's demonstration puts product 1 into gap_1, the tree's second round
    # reuses the taught skill to put product 2 into gap_2 (III-E)
    placements: Tuple[Tuple[str, str, Optional[str]], ...] = (
        ("product_pick_1", "gap_1", None),
        ("product_pick_2", "gap_2", outcome.TAUGHT_SKILL),
    )
    removed: Optional[str] = "PlaceItem"  # III-B; None: the tree must stay as it was
    insert_index: Optional[int] = 8  # III-E: after MoveBase2 (to gap_2); None: the taught skill is not inserted
    stiffer_insertion: bool = True  # III-C's peg-in-hole X stiffening (III-D omits it)
    alignment_yaw: Optional[float] = None  # [deg] III-D: direction of the stiffest horizontal axis after alignment
    device_rate: float = 250.0
    # simulated seconds per wall second (full.launch's real_time_factor); None: config/controllers.yaml's (1.0). The
    # scenario, the tree and every node run on the simulation's clock, so a factor of 2 plays the same run in about
    # half the wall time where the machine has the cores for it (the sim's step is ~0.25 ms of its 1 ms)
    real_time_factor: Optional[float] = None


def options_for(scenario: pathlib.Path, **overrides) -> Options:
    """The expectations of a scenario: thesis_III_D.yaml runs its own tree and the 45-degree trajectory.

    Both reuse the taught skill at gap_2, inserted at index 8 (after the move to gap_2). teach_placement.yaml (issue
    34) runs its own tree and library: nothing is removed or inserted; its second PlaceTaught places product 2 with
    what the operator taught.
    """
    scenario = pathlib.Path(scenario).resolve()
    if scenario.stem == "teach_placement":
        profile = dict(
            tree=scenario.with_name("teach_placement_tree.yaml"),
            skills=scenario.with_name("teach_placement_skills.yaml"),
            phases="teach_placement",
            taught_used_by="PlaceTaught2",
            removed=None,
            insert_index=None,
            placements=(("product_pick_1", "gap_1", None), ("product_pick_2", "gap_2", "PlaceTaught2")),
        )
    elif scenario.stem == "thesis_III_D":
        profile = dict(
            tree=scenario.with_name("thesis_III_D_tree.yaml"),
            trajectory="angled_45",
            removed=None,
            stiffer_insertion=False,
            alignment_yaw=45.0,
        )
    else:
        profile = {}
    return Options(scenario=scenario, **{**profile, **overrides})


class Monitor:
    """Subscribes to the tree, the library, the scene, the active tab and what the operator does (needs rospy).

    Args:
        initial_children: the execution sequence of the tree file: the operator's first edit is told against it.
    """

    def __init__(self, initial_children: Tuple[str, ...]):
        import rospy
        from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
        from std_msgs.msg import Bool, Int8, String
        from visualization_msgs.msg import MarkerArray

        from teleteach.msg import BehaviourTree, HelpRequest, SkillLibrary

        self._lock = threading.Lock()
        self.children: List[Tuple[float, Tuple[str, ...]]] = []
        self.leaves: Dict[str, Tuple[Status, str, str]] = {}
        self.completed = False
        self.ascii: List[str] = []
        self.library: Optional[SkillLibrary] = None
        self.initial_products: Dict[str, np.ndarray] = {}
        self.final_products: Dict[str, np.ndarray] = {}
        self.help_requests: List[Tuple[float, str, str]] = []
        self.help_closed: List[float] = []  # when each help request closed (the tree went on)
        self.tabs: List[Tuple[float, int]] = []
        self._narration = Narration(initial_children)
        self._news: List[Tuple[float, str]] = []  # (ROS time, line) of the operator's steps not yet printed
        self._eigenvalues: Optional[np.ndarray] = None  # the last /eigenvalues [N/m]
        self._subscribers = [
            rospy.Subscriber("behaviour_tree/log/tree", BehaviourTree, self._tree, queue_size=20),
            rospy.Subscriber("behaviour_tree/ascii/tree", String, self._ascii, queue_size=5),
            rospy.Subscriber("behaviour_tree/skill_library", SkillLibrary, self._library, queue_size=5),
            rospy.Subscriber("behaviour_tree/help_request", HelpRequest, self._help, queue_size=5),
            rospy.Subscriber(TRUE_SCENE_TOPIC, MarkerArray, self._scene, queue_size=1),  # judged from the truth
            rospy.Subscriber("teleteach/active_tab", Int8, self._tab, queue_size=5),
            rospy.Subscriber("teleteach/recording", Bool, self._recording, queue_size=5),
            rospy.Subscriber("eigenvalues", Vector3Stamped, self._values, queue_size=1),
            rospy.Subscriber("eigenvectors", QuaternionStamped, self._axes, queue_size=1),
        ]
        self._now = rospy.get_time

    def _tree(self, message) -> None:
        by_id = {behaviour.own_id: behaviour for behaviour in message.behaviours}
        execution = next((b for b in message.behaviours if b.name == EXECUTION), None)
        root = next((b for b in message.behaviours if b.parent_id not in by_id), None)
        with self._lock:
            if execution is not None:
                children = tuple(by_id[child].name for child in execution.child_ids if child in by_id)
                self.children.append((self._now(), children))
                self._tell(self._narration.tree(children))
            for behaviour in message.behaviours:
                if not behaviour.child_ids:
                    self.leaves[behaviour.name] = (
                        STATUSES.get(behaviour.status),
                        behaviour.message,
                        behaviour.class_name,
                    )
            done = [node is not None and STATUSES.get(node.status) == Status.SUCCESS for node in (execution, root)]
            self.completed = all(done)

    def _ascii(self, message) -> None:
        with self._lock:
            if not self.ascii or self.ascii[-1] != message.data:
                self.ascii.append(message.data)

    def _library(self, message) -> None:
        with self._lock:
            self.library = message
        taught = [name for name, _ in self.demonstrated()]
        with self._lock:
            self._tell(self._narration.taught(taught))

    def _help(self, message) -> None:
        with self._lock:
            if message.node_name:
                self.help_requests.append((self._now(), message.node_name, message.reason))
                self._tell(self._narration.help_request(message.node_name, message.reason))
            elif len(self.help_closed) < len(self.help_requests):
                self.help_closed.append(self._now())

    def _scene(self, message) -> None:
        products = product_positions(message.markers)
        with self._lock:
            if not self.initial_products:
                self.initial_products = products
            self.final_products = products

    def _tab(self, message) -> None:
        with self._lock:
            self.tabs.append((self._now(), int(message.data)))
            self._tell(self._narration.tab(int(message.data)))

    def _recording(self, message) -> None:
        with self._lock:
            self._tell(self._narration.recording(bool(message.data)))

    def _values(self, message) -> None:
        with self._lock:
            self._eigenvalues = np.array([message.vector.x, message.vector.y, message.vector.z])

    def _axes(self, message) -> None:
        q = message.quaternion
        yaw = float(np.degrees(yaw_of(np.array([[q.x, q.y, q.z, q.w]]))[0]))
        with self._lock:
            if self._eigenvalues is not None:
                self._tell(self._narration.stiffness(self._now(), self._eigenvalues, yaw))

    def _tell(self, line: Optional[str]) -> None:
        """Keep a line of the operator's steps for :meth:`news` (lock held)."""
        if line:
            self._news.append((self._now(), line))

    def news(self) -> List[Tuple[float, str]]:
        """The operator's steps since the last call: (ROS time, line)."""
        with self._lock:
            news, self._news = self._news, []
        return news

    def tab_name(self) -> Optional[str]:
        """The GUI's open tab, lower case (``low_level``); None before the GUI said."""
        with self._lock:
            if not self.tabs:
                return None
            tab = self.tabs[-1][1]
        return Tab(tab).name.lower() if tab in list(Tab) else str(tab)

    def demonstrated(self) -> List[Tuple[str, str]]:
        """(name, data file) of every demonstrated skill in the library."""
        with self._lock:
            library = self.library
        if library is None:
            return []
        entries = zip(library.names, library.kinds, library.data_files)
        return [(name, data_file) for name, kind, data_file in entries if SkillEntry(name, kind).demonstrated]

    def close(self) -> None:
        """Unsubscribe."""
        for subscriber in self._subscribers:
            subscriber.unregister()


def _run_folder(root: pathlib.Path) -> pathlib.Path:
    stamp = time.strftime("%Y-%m-%d-%H-%M-%S")
    folder = root / "runs" / stamp
    suffix = 1
    while folder.exists():
        suffix += 1
        folder = root / "runs" / f"{stamp}_{suffix}"
    folder.mkdir(parents=True)
    return folder


def execution_children(tree: TreeSpec) -> Tuple[str, ...]:
    """The names of the execution composite's children (the sequence the thesis' edits change)."""
    stack = [tree.root]
    while stack:
        node = stack.pop()
        if node["name"] == tree.execution:
            return tuple(child["name"] for child in node["children"])
        stack.extend(node.get("children", []))
    raise ValueError(f"the tree has no {tree.execution}")


def _tree_yaml(children: Tuple[str, ...], leaves: Dict[str, Tuple[Status, str, str]]) -> str:
    """The execution sequence's leaves with what each last did: skill, status (lower case), message."""
    entries = []
    for name in children:
        status, message, skill = leaves.get(name, (None, "", name))
        entries.append(
            {"name": name, "skill": skill, "status": status.value.lower() if status else "unknown", "message": message}
        )
    data = {"execution": EXECUTION, "children": entries}
    return yaml.safe_dump(data, sort_keys=False, width=120)


class ThesisRun:
    """One run of the main job; :meth:`run` returns the summary (also written into the run folder)."""

    def __init__(self, options: Options, say: Callable[[str], None] = functools.partial(print, flush=True)):
        self.options = options  # say flushes: progress reaches a pipe (tee, bench/stress.py) when it happens
        self.say = say
        self.scenario = load_scenario(options.scenario)  # a bad file is refused before anything is created
        self.root = data_dir(options.data_root)
        self.folder = _run_folder(self.root)
        self.experiment = Experiment(self.folder, self.root)
        self.prefix = "thesis_" + self.folder.name.replace("-", "_")
        self.timings: Dict[str, float] = {}
        self._start = time.monotonic()

    def _mark(self, name: str) -> None:
        self.timings[name] = round(time.monotonic() - self._start, 1)

    def run(self) -> RunSummary:
        """Everything; processes are stopped whatever happens."""
        with self.experiment:
            return self._run()

    def _run(self) -> RunSummary:
        options, scenario, experiment = self.options, self.scenario, self.experiment
        if experiment.own_display():
            self.say(f"run_thesis: started Xvfb on {experiment.display}")
        arguments = self.launch_arguments()
        launch = experiment.own_launch(lambda port: full_launch(arguments, port), self.folder / "launch.log")
        self.say(f"run_thesis: launched full.launch (master {experiment.master_uri}), log {self.folder / 'launch.log'}")
        experiment.join("run_thesis", anonymous=True, sim_time=True)
        import rospy

        monitor = Monitor(execution_children(load_tree(options.tree, SkillLibrary.load(options.skills))))
        shots = experiment.screenshots("gui", monitor.tab_name, delay=1.5, period=3.0)
        self._mark("master_up")
        try:
            finished, reason = self._wait(monitor, launch, scenario.duration, rospy)
            self._mark("scenario_done")
            shots.stop()
            shots.take(self.folder / "gui_final.png")
            missing = self.rviz_view() if options.rviz and launch.poll() is None else ""
            if missing:
                shots.errors.append(missing)
            self._mark("screenshots_done")
        finally:
            shots.stop()
            monitor.close()
            rospy.signal_shutdown("run_thesis done")
            experiment.stop(launch, grace=25.0)
            self._mark("launch_stopped")
        return self._results(monitor, finished, reason, shots.errors)

    def launch_arguments(self) -> Dict[str, object]:
        """full.launch's arguments of the run: headless, the scripted operator, the tree, the recorder."""
        options = self.options
        arguments = {
            **scripted_device(options.scenario, options.device_rate),
            "headless": True,
            "tree": options.tree,
            "skills": options.skills,
            "trajectory": options.trajectory,
            "record": True,
            "record_prefix": self.prefix,
            "data_dir": self.root,
        }
        if options.real_time_factor is not None:
            arguments["real_time_factor"] = f"{options.real_time_factor:g}"
        return arguments

    def _wait(self, monitor: Monitor, launch, duration: float, rospy) -> Tuple[bool, str]:
        """Until the scenario has ended and the tree has finished, roslaunch died or the wall time is up."""
        deadline = time.monotonic() + self.options.timeout
        start, played_at = None, None
        reported = set()
        while time.monotonic() < deadline:
            if self.experiment.ended():
                return self._ended_early()
            try:
                if start is None and server_has("sigma7_node/scenario_start"):
                    start = float(server_value("sigma7_node/scenario_start"))
                    self.say(
                        f"run_thesis: scenario started at simulated t = {start:.2f} s ({duration:.0f} s without waits)"
                    )
                now = rospy.get_time()
                if played_at is None and server_value("sigma7_node/scenario_played", False):
                    played_at = now  # the device node says so: with waits, the end is not start + duration
            except OSError as error:  # the master is roslaunch's: it goes first when a required node ends the launch
                try:
                    launch.wait(timeout=MASTER_GONE_WAIT)
                except subprocess.TimeoutExpired:
                    return False, f"the ROS master stopped answering ({error}) while roslaunch still runs"
                return self._ended_early()
            played = played_at is not None and now >= played_at + 1.0
            for moment, line in monitor.news():
                self.say(f"run_thesis: t = {moment:6.1f} s  {line}")
            for name, (status, message, _) in list(monitor.leaves.items()):
                ended = status in (Status.SUCCESS, Status.FAILURE)
                if ended and (name, status) not in reported and name != "PauseCondition":
                    reported.add((name, status))
                    said = "done" if status == Status.SUCCESS else "FAILED"
                    self.say(f"run_thesis: t = {now:6.1f} s  {name}: {said} {message}")
            if played and monitor.completed:
                rospy.sleep(1.0)  # a last scene message after the tree's end
                return True, "scenario played and tree finished"
            time.sleep(0.2)
        state = "scenario not over" if played_at is None else "tree not finished"
        return False, f"timeout after {self.options.timeout:.0f} s wall time ({state})"

    def _ended_early(self) -> Tuple[bool, str]:
        """The reason the launch ended before the scenario did: the required node that died first, if one did."""
        reason = self.experiment.ended()
        self.say(f"run_thesis: stopped waiting: {reason}")
        return False, reason

    def rviz_view(self) -> str:
        """Why rviz.png (RViz's picture of the robot, the shelf and the ellipsoid) was not taken; "" when it was.

        Its own display: nothing else can lie on top of it. RViz is started a second time when the first one exited
        or showed nothing in time (on llvmpipe it can die while it opens its window); what each start showed is said.
        """
        try:
            screen = start_xvfb(self.experiment.processes, size=RVIZ_SCREEN, parent_death_signal=signal.SIGTERM)
        except ProcessError as error:
            return f"rviz.png: {error}"
        tries = []
        for start in range(1, RVIZ_STARTS + 1):
            why = self._rviz_picture(dict(self.experiment.environment(), DISPLAY=screen), screen)
            if not why:
                return ""
            tries.append(f"start {start}: {why}")
            self.say(f"run_thesis: rviz.png: {tries[-1]}")
        return "rviz.png: " + "; ".join(tries)

    def _rviz_picture(self, env, screen: str) -> str:
        """What RViz showed instead of the scene, or "" once rviz.png shows the 3D view with the scene drawn.

        A picture is kept when it is drawn (teleteach.run.pictures) and the same in two shots in a row.
        """
        picture, attempt = self.folder / "rviz.png", self.folder / "rviz_attempt.png"
        try:
            rviz = self.experiment.processes.start(
                "rviz",
                ["rviz", "-d", str(RVIZ_CONFIG)],
                self.folder / "rviz.log",
                env,
                parent_death_signal=signal.SIGTERM,
            )
        except ProcessError as error:
            return str(error)
        background, previous, why = background_colour(RVIZ_CONFIG), None, "no picture taken"
        started = time.monotonic()
        try:
            while time.monotonic() < started + RVIZ_TIMEOUT:
                time.sleep(2.0)
                if rviz.poll() is not None:
                    return (
                        f"RViz exited (code {rviz.returncode}) after {time.monotonic() - started:.0f} s before it "
                        f"showed the scene (rviz.log; {why or 'its last picture was drawn'})"
                    )
                error = screenshot(screen, attempt)
                if error:
                    why = error
                    continue
                drawn, share, why = rviz_picture(attempt, background)
                if drawn and previous is not None and abs(share - previous) <= 0.1 * previous:
                    attempt.replace(picture)
                    return ""
                previous = share if drawn else None
            shown = why or "drawn, but not the same in two shots in a row"
            return f"RViz did not show the robot and the scene within {RVIZ_TIMEOUT:.0f} s: {shown} ({attempt.name})"
        finally:
            self.experiment.stop(rviz, grace=5.0)

    def _results(self, monitor: Monitor, finished: bool, reason: str, screenshot_errors: List[str]) -> RunSummary:
        options, folder = self.options, self.folder
        problems: List[str] = [] if finished else [reason]
        bag = closed_bag(self.root / "bags", self.prefix, self.folder, timeout=15.0)
        if bag is None:
            problems.append("no bag was written")
        initial = execution_children(load_tree(options.tree, SkillLibrary.load(options.skills)))
        changes = outcome.sequence_changes([children for _, children in monitor.children])
        final_children = changes[-1] if changes else initial
        self._save_trees(monitor, final_children)
        taught = monitor.demonstrated()
        self._save_skills(taught)
        taught_name = taught[0][0] if taught else None
        after_removal, after_insertion = outcome.expected_sequences(
            initial, options.removed, taught_name, options.insert_index
        )
        # one check per experiment
        problems += outcome.check_iii_b(changes, after_removal, options.removed)
        problems_cd, seen = self._taught_profile_checks(taught[0][1] if taught else None)
        problems_e, status, message = self._taught_skill_checks(monitor, final_children, after_insertion, taught_name)
        problems_p, placements, figures = self._placements_and_report(bag, taught_name)
        problems += problems_cd + problems_e + problems_p
        self._mark("report_done")
        summary = RunSummary(
            folder=str(folder),
            problems=problems,
            finished=finished,
            bag=bag.name if bag else None,
            tree_initial=list(initial),
            tree_changes=[list(children) for children in changes],
            tree_edits=[outcome.describe_edit(a, b) for a, b in zip(changes, changes[1:])],
            tree_final=list(final_children),
            expected_after_iii_b=list(after_removal),
            expected_after_iii_e=list(after_insertion),
            taught_skills=[{"name": n, "file": f"skills/{pathlib.Path(f).name}"} for n, f in taught],
            taught_skill_result={"status": status.value, "message": message} if status else None,
            placements=placements,
            help_requests=monitor.help_requests,
            help_time_s=outcome.help_time(monitor.help_requests, monitor.help_closed),
            tabs=monitor.tabs,
            screenshots=sorted(path.name for path in folder.glob("*.png")),
            screenshot_errors=screenshot_errors,
            figures=figures,
            timings_wall_s=self.timings,
            **seen,
        )
        atomic_write_text(folder / "summary.json", summary.to_json())
        atomic_write_text(folder / "summary.md", summary.to_markdown())
        return summary

    def _taught_skill_checks(
        self,
        monitor: Monitor,
        final_children: Tuple[str, ...],
        after_insertion: Tuple[str, ...],
        taught_name: Optional[str],
    ) -> Tuple[List[str], Optional[Status], str]:
        """III-E (the taught skill inserted and run by the tree) and the node meant to use it: problems, its result."""
        options = self.options
        ran_by = options.taught_used_by or taught_name
        status, message, _ = monitor.leaves.get(ran_by, (None, "", "")) if taught_name else (None, "", "")
        inserted = options.insert_index is not None
        problems = outcome.check_iii_e(final_children, after_insertion, taught_name, status, message, inserted)
        problems += outcome.check_taught_used(taught_name, options.taught_used_by, status, message)
        return problems, status, message

    def _taught_profile_checks(self, taught_file: Optional[str]) -> Tuple[List[str], dict]:
        """III-C (the taught stiffness, phase by phase) and III-D (its alignment axis' yaw): problems, figures."""
        options = self.options
        phases = options.phases or options.trajectory
        problems, seen = outcome.check_iii_c(taught_file, phases, options.stiffer_insertion)
        return problems + outcome.check_iii_d(seen["alignment_axis_yaw_deg"], options.alignment_yaw), seen

    def _placements_and_report(
        self, bag: Optional[pathlib.Path], taught_name: Optional[str]
    ) -> Tuple[List[str], List[dict], List[str]]:
        """The placements judged from the bag's true scene and the report's figures: problems, placements, figures."""
        problems: List[str] = []
        if bag is None:
            return problems, [], []
        expected = {
            product: (gap, taught_name if setter == outcome.TAUGHT_SKILL else setter)
            for product, gap, setter in self.options.placements
        }
        session, placements, figures = None, [], []
        try:
            session = read_session(bag)  # read once: the placements and the report
            problems, placements = outcome.check_placements(session, load_scene(), expected)
        except (SessionError, SceneError) as error:
            problems.append(f"placements unreadable: {error}")
        try:
            report = make_report(bag, self.folder / "report", session=session)
            figures = sorted(str(path.relative_to(self.folder)) for path in report.figures.values())
        except (SessionError, OSError) as error:
            problems.append(f"report failed: {error}")
        return problems, placements, figures

    def _save_trees(self, monitor: Monitor, final_children: Tuple[str, ...]) -> None:
        """The tree before and after, as yaml and as the tree node's ascii view, and the node's own saved tree."""
        folder = self.folder
        shutil.copy(self.options.tree, folder / "tree_before.yaml")
        if monitor.ascii:
            atomic_write_text(folder / "tree_before.txt", monitor.ascii[0] + "\n")
            atomic_write_text(folder / "tree_after.txt", monitor.ascii[-1] + "\n")
        atomic_write_text(folder / "tree_after.yaml", _tree_yaml(final_children, monitor.leaves))
        saved_tree = self.root / "trees" / "current_tree.yaml"
        if saved_tree.is_file():
            shutil.copy(saved_tree, folder / "tree_after_saved.yaml")

    def _save_skills(self, taught: List[Tuple[str, str]]) -> None:
        """Copies of the taught skill files."""
        (self.folder / "skills").mkdir(exist_ok=True)
        for _, data_file in taught:
            if pathlib.Path(data_file).is_file():
                shutil.copy(data_file, self.folder / "skills" / pathlib.Path(data_file).name)


def main(argv=None) -> int:
    """Command line: run the thesis scenario, print the summary; exit 0 when every check passed."""
    import argparse

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument(
        "--scenario",
        default=str(DEFAULT_SCENARIO),
        help="device scenario (default thesis_full; thesis_III_D.yaml runs with its own tree and trajectory)",
    )
    parser.add_argument("--data-dir", default=None, help="data directory (default $TELETEACH_DATA or ~/.ros/teleteach)")
    parser.add_argument(
        "--timeout", type=float, default=Options.timeout, help="[s] wall time for the scenario and the tree"
    )
    parser.add_argument("--no-rviz", action="store_true", help="skip the RViz screenshot at the end")
    parser.add_argument(
        "--real-time-factor",
        type=float,
        default=None,
        help="simulated seconds per wall second (default: config/controllers.yaml's, 1.0)",
    )
    arguments = parser.parse_args(argv)
    if arguments.real_time_factor is not None and arguments.real_time_factor < 0.0:
        parser.error(f"--real-time-factor must be 0 (as fast as possible) or more, got {arguments.real_time_factor:g}")
    options = options_for(
        pathlib.Path(arguments.scenario),
        data_root=pathlib.Path(arguments.data_dir).expanduser() if arguments.data_dir else None,
        timeout=arguments.timeout,
        rviz=not arguments.no_rviz,
        real_time_factor=arguments.real_time_factor,
    )
    try:
        summary = ThesisRun(options).run()
    except (ProcessError, OSError, ValueError) as error:
        print(f"run_thesis: error: {error}")
        return 2
    print(summary.to_markdown(), end="")
    return 0 if summary.passed else 1
