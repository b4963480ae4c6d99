#!/usr/bin/env python3
"""Benchmark: does haptic guidance stop the operator fighting the device (thesis III-B, IV; the device's
sensitivity)? Wrong selections, time to each selection and unintended-axis drift, with and without guidance.

Everything runs for real: roscore, the behaviour tree node, the device node (``sigma7_node``, backend ``topic``,
the hand model on, tremor 1, 2 and 3 mm RMS: ``device.launch backend:=topic hand_model:=true tremor:=...``) and the
teaching GUI (``teleteach.gui.app.MainWindow``, in this process; under ``xvfb-run`` when there is no display). The
operator is scripted, but like a person (:class:`Operator`, seeded): the intended hand pose goes to the device node
on ``/sigma7/input/pose`` at 200 Hz; the modelled hand there pulls the device toward it against the guidance's
force. For each selection the operator moves toward the intended button, operation or dial position with a
minimum-jerk reach whose duration follows Fitts' law, lands with an aiming error (endpoint SD = W / 4.133, the
effective width of Fitts' law), drifts on the other axes as a reach does (a ~6 degree direction error; the wrist
turns a little with the hand), settles, looks at what the GUI highlights (after a visual reaction time) and
corrects while it is not the intended one, then clicks (a gripper flick after a motor reaction time). Closing the
gripper with a finger pushes the hand a little (2 mm, 0.02 rad RMS at full closure, following the closure): the
"Heisenberg effect" of selecting with a tracked device, which Wolf et al. (CHI 2020) found behind 30 % of pointing
errors. It never aims at a detent on purpose: the detents sit where the buttons are, and the aim, the pushes and
the timing are the same with and without guidance (same seeds).

Tasks, each ``--trials`` times (default 20) per tremor level, without and with guidance (config/gui.yaml
``guidance``); a GUI + device session runs ``--block`` trials (default 5) of one condition, and the sessions
alternate the condition, so that the load of a shared machine weighs on both alike:

- ``removal`` (III-B): START -> HIGH-LEVEL, select PlaceItem (device X), select remove (device Y);
- ``insertion`` (III-E): START -> HIGH-LEVEL, select the taught skill DemonstratedPlace_1 (a library button; added
  from bench/data at the start), select insert, dial (roll) to index 9 (after MoveBase2);
- ``stiffness`` (LOW-LEVEL, III-C phase 2): START -> LOW-LEVEL, set X = Y = 500 N/m and Z = 1500 N/m in mode ALL,
  click to mode X and to mode Y, raise Y to 2000 N/m, hold 1 s.

A wrong selection is a click that confirmed another choice than the intended one, as the GUI took it (the tab
START opened; the node, operation or dial position of the HIGH-LEVEL step the click confirmed); the tree's edit is
checked too. Time to a selection: from the start of the reach to the confirming click. Unintended-axis drift (the
stiffness task): while raising Y in mode Y, the RMS change of the stiffness the robot is commanded along and
between the axes not being commanded: K = V diag(/eigenvalues) V^T with V from /eigenvectors, taken in the
ellipsoid's axes when mode Y began, all of it but K_yy [N/m]; its part from /eigenvalues alone (X and Z) is
reported too (the GUI's mode Y never changes those: the leak is the axis turning, thesis IV). Between trials the
operator opens the gripper (back to START) and the bench undoes a tree edit over /change_tree (and sets the
LOW-LEVEL mode back to ALL).

Writes bench/results/haptic_guidance.json ({"with": ..., "without": ...}) and haptic_guidance.png; prints a table.

    source build/env.sh && python bench/haptic_guidance.py [--trials N] [--tremors 0.001 0.002 0.003] [--block N]
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import dataclasses
import faulthandler
import json
import math
import pathlib
import re
import signal
import sys
import tempfile
import threading
import time
from typing import Callable, Dict, List, Optional, Sequence

import numpy as np

BENCH = pathlib.Path(__file__).resolve().parent
ROOT = BENCH.parent
RESULTS = BENCH / "results" / "haptic_guidance.json"
SKILL_FILE = BENCH / "data" / "DemonstratedPlace_1.npz"

TREMORS = (0.001, 0.002, 0.003)  # [m] RMS of the hand's 8-12 Hz tremor (the hand model's tremor_rms)
TASKS = ("removal", "insertion", "stiffness")
CONDITIONS = ("without", "with")
SEED = 19
REMOVE_TARGET = "PlaceItem"
INSERT_SKILL = "DemonstratedPlace_1"
INSERT_INDEX = 9  # after MoveBase2, as the main job inserts the taught skill (III-E)
START_CHOICES = ("HIGH-LEVEL", "LOW-LEVEL", "SHARED CONTROL")  # StartTab.selected -> tab selected + 1
PRESET_STIFFNESS = (500.0, 500.0, 1500.0)  # [N/m] X, Y, Z before the single-axis task (III-C: X, Y low, Z high)
RAISED_Y = 2000.0  # [N/m] the Y stiffness the operator raises to
STIFFNESS_TOLERANCE = 100.0  # [N/m] the operator is content within this of the wanted value
HOLD_TIME = 1.0  # [s] the operator holds the raised stiffness
HOME = np.zeros(6)  # intended pose at START between trials: x, y, z [m], roll, pitch, yaw [rad]
INPUT_RATE = 200.0  # [Hz] intended poses sent to the device node
RESTING_GRIPPER, OPEN_GRIPPER = 0.25, 0.5  # [rad]
# sigma7_node's last words: how its 1 kHz loop fared (a busy machine starves it)
LOOP_SUMMARY = re.compile(r"published (\d+) cycles at ([\d.]+) Hz on average, (\d+) failed reads, (\d+) stalls longer")


@dataclasses.dataclass(frozen=True)
class Human:
    """The scripted operator's motor behaviour (typical values of pointing studies; seeded per trial)."""

    fitts_a: float = 0.2  # [s] movement time = a + b log2(D / W + 1) (Shannon form of Fitts' law)
    fitts_b: float = 0.15  # [s/bit]
    endpoint_sd_per_width: float = 1.0 / 4.133  # endpoint SD / target width (Fitts' effective width: 96 % inside)
    direction_error: float = 0.105  # [rad] RMS direction error of a reach (~6 degrees): drift on the other axes
    wrist_coupling: float = 0.3  # [rad/m] RMS turn of each wrist angle per metre the hand moves
    roll_coupling: float = 0.005  # [m/rad] RMS hand displacement per radian the wrist rolls (the dial)
    roll_cross_coupling: float = 0.1  # [rad/rad] RMS pitch and yaw per radian of roll
    settle: float = 0.15  # [s] after a reach, before looking
    reaction: float = 0.25  # [s] mean visual reaction time (look, then act)
    reaction_sd: float = 0.05  # [s]
    click_duration: float = 0.3  # [s] the gripper flick
    click_push: float = 0.002  # [m] RMS per axis of the hand's push while the finger closes the gripper (below)
    click_turn: float = 0.02  # [rad] RMS per angle of the same
    max_corrections: int = 4  # corrective reaches before the operator clicks anyway


class Operator:
    """The operator's intended device pose and gripper angle, sent to the device node at INPUT_RATE.

    A reach is a minimum-jerk motion from the intended pose now to a new one; a click is the gripper flick of
    :func:`teleteach.haptics.click.flick_gripper_angle` (what the click detector recognises).
    """

    def __init__(self, human: Human) -> None:
        import rospy
        from geometry_msgs.msg import PoseStamped
        from std_msgs.msg import Float64

        self.human = human
        self._rospy = rospy
        self._messages = (PoseStamped, Float64)
        self._pose_publisher = rospy.Publisher("/sigma7/input/pose", PoseStamped, queue_size=10)
        self._gripper_publisher = rospy.Publisher("/sigma7/input/gripper_angle", Float64, queue_size=10)
        self._lock = threading.Lock()
        self._from, self._to = HOME.copy(), HOME.copy()
        self._start, self._duration = 0.0, 1e-9
        self._gripper = RESTING_GRIPPER
        self._click_at = -math.inf
        self._push = np.zeros(6)  # the hand's displacement at full closure of the current click
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="operator", daemon=True)
        self._thread.start()

    def intended(self, now: Optional[float] = None) -> np.ndarray:
        """The intended pose (x, y, z, roll, pitch, yaw) at ``now`` [s, monotonic]."""
        from teleteach.core.trajectories import minimum_jerk

        now = time.monotonic() if now is None else now
        with self._lock:
            return self._from + minimum_jerk((now - self._start) / self._duration) * (self._to - self._from)

    def reach(self, pose: Sequence[float], duration: float) -> None:
        """Start a reach from the intended pose now to ``pose`` over ``duration`` [s]."""
        now = time.monotonic()
        start = self.intended(now)
        with self._lock:
            self._from, self._to = start, np.array(pose, dtype=float)
            self._start, self._duration = now, max(duration, 1e-3)

    def click(self, push: Sequence[float] = (0.0,) * 6) -> None:
        """Start a click (a quick close-and-back of the gripper) that pushes the hand by ``push`` at full closure."""
        with self._lock:
            self._click_at = time.monotonic()
            self._push = np.array(push, dtype=float)

    def gripper(self, angle: float) -> None:
        """Hold the gripper at ``angle`` [rad] (fully open: back to START)."""
        with self._lock:
            self._gripper = angle

    def _run(self) -> None:
        from teleteach.core.rotations import rpy_to_quaternion
        from teleteach.haptics.click import flick_gripper_angle

        pose_class, float_class = self._messages
        period = 1.0 / INPUT_RATE
        deadline = time.monotonic()
        while not self._stop.is_set() and not self._rospy.is_shutdown():
            now = time.monotonic()
            pose = self.intended(now)
            with self._lock:
                gripper = flick_gripper_angle(self._gripper, now - self._click_at, self.human.click_duration)
                closure = 1.0 - gripper / self._gripper if self._gripper > 0.0 else 0.0  # 0 resting, 1 closed
                pose = pose + closure * self._push
            message = pose_class()
            message.header.stamp = self._rospy.Time.now()
            message.header.frame_id = "sigma7"
            message.pose.position.x, message.pose.position.y, message.pose.position.z = pose[:3]
            q = message.pose.orientation
            q.x, q.y, q.z, q.w = rpy_to_quaternion(*pose[3:])
            self._pose_publisher.publish(message)
            self._gripper_publisher.publish(float_class(gripper))
            deadline += period
            time.sleep(max(0.0, deadline - time.monotonic()))
            if time.monotonic() - deadline > 0.5:
                deadline = time.monotonic()

    def close(self) -> None:
        """Stop sending (the device node then reports the device lost)."""
        self._stop.set()
        self._thread.join(2.0)
        self._pose_publisher.unregister()
        self._gripper_publisher.unregister()


@dataclasses.dataclass
class Selection:
    """One confirmed (or unconfirmed) selection: what was meant, what the GUI took, how long it took."""

    task: str
    kind: str  # start | node | operation | index
    intended: str
    confirmed: Optional[str]  # None: no click confirmed anything (the trial was abandoned)
    seconds: float  # from the start of the reach to the confirming click
    corrections: int
    clicks: int = 1  # clicks made (one the GUI did not take is made again)
    seen: str = ""  # what the GUI highlighted when the operator decided to click

    @property
    def wrong(self) -> bool:
        return self.confirmed is not None and self.confirmed != self.intended


@dataclasses.dataclass
class TrialResult:
    task: str
    trial: int
    selections: List[Selection]
    edit_as_intended: Optional[bool] = None  # HIGH-LEVEL: the tree changed exactly as intended
    drift: Optional[float] = None  # stiffness: RMS of K outside K_yy while raising Y [N/m]
    eigenvalue_drift: Optional[float] = None  # stiffness: RMS change of the X and Z eigenvalues [N/m]
    final_y: Optional[float] = None  # stiffness: Y reached [N/m]
    abandoned: str = ""  # why the trial could not be completed (the system did not answer in time), or ""


def fitts_time(human: Human, distance: float, width: float) -> float:
    """[s] movement time of a reach over ``distance`` to a target ``width`` wide (same units)."""
    return human.fitts_a + human.fitts_b * math.log2(abs(distance) / width + 1.0)


def reach_pose(human: Human, rng, current: np.ndarray, axis: int, target: float, width: float) -> np.ndarray:
    """Where a reach along ``axis`` toward ``target`` (a choice ``width`` wide) lands: aiming error on the axis,
    the reach's drift on the other axes."""
    pose = current.copy()
    pose[axis] = target + rng.normal(0.0, human.endpoint_sd_per_width * width)
    distance = abs(pose[axis] - current[axis])
    others = [index for index in range(6) if index != axis]
    for index in others:
        if axis < 3:  # a translation: the hand strays sideways and the wrist turns a little
            spread = human.direction_error if index < 3 else human.wrist_coupling
        else:  # a wrist roll (the dial): the hand shifts, the other angles follow a little
            spread = human.roll_coupling if index < 3 else human.roll_cross_coupling
        pose[index] += rng.normal(0.0, spread) * distance
    return pose


def bin_centre(index: int, count: int, half_range: float) -> float:
    """Centre of slider position ``index`` of ``count`` over [-half_range, half_range] (the GUI's bins)."""
    return -half_range + (index + 0.5) * 2.0 * half_range / count


def stiffness_position(stiffness: float, config) -> float:
    """The device coordinate [m] that gives a principal ``stiffness`` [N/m] (inverse of the GUI's scaling)."""
    pixels = stiffness / config.stiffness_per_pixel
    low, high = config.min_stiffness / config.stiffness_per_pixel, config.max_pixels
    return -config.device_range + 2.0 * config.device_range * (pixels - low) / (high - low)


def drift_of(samples: Sequence[tuple]) -> tuple:
    """(RMS of the change of K outside K_yy, RMS change of the X and Z eigenvalues) [N/m] over (eigenvalues,
    quaternion) samples, K taken in the ellipsoid's axes at the first sample (so raising its Y axis, wherever it
    points, changes only K_yy)."""
    if not samples:
        return math.nan, math.nan
    from teleteach.control.stiffness import as_rotation, translational_stiffness

    axes = as_rotation(samples[0][1])
    reference = axes.T @ translational_stiffness(*samples[0]) @ axes
    outside, eigen = [], []
    for eigenvalues, quaternion in samples:
        change = axes.T @ translational_stiffness(eigenvalues, quaternion) @ axes - reference
        change[1, 1] = 0.0
        outside.append(np.sum(change**2))
        eigen.append((eigenvalues[0] - samples[0][0][0]) ** 2 + (eigenvalues[2] - samples[0][0][2]) ** 2)
    return math.sqrt(float(np.mean(outside))), math.sqrt(float(np.mean(eigen)))


class StiffnessLog:
    """/eigenvalues and /eigenvectors (published together with one stamp by the GUI), paired by stamp."""

    def __init__(self) -> None:
        import rospy
        from geometry_msgs.msg import QuaternionStamped, Vector3Stamped

        self._lock = threading.Lock()
        self._values: Dict[float, tuple] = {}
        self._vectors: Dict[float, tuple] = {}
        self.recording = False
        self._subscribers = [
            rospy.Subscriber("/eigenvalues", Vector3Stamped, self._on_values, queue_size=100),
            rospy.Subscriber("/eigenvectors", QuaternionStamped, self._on_vectors, queue_size=100),
        ]

    def _on_values(self, message) -> None:
        if self.recording:
            with self._lock:
                self._values[message.header.stamp.to_sec()] = (message.vector.x, message.vector.y, message.vector.z)

    def _on_vectors(self, message) -> None:
        if self.recording:
            q = message.quaternion
            with self._lock:
                self._vectors[message.header.stamp.to_sec()] = (q.x, q.y, q.z, q.w)

    def start(self) -> None:
        with self._lock:
            self._values.clear()
            self._vectors.clear()
        self.recording = True

    def stop(self) -> List[tuple]:
        """The paired samples since :meth:`start`, in time order."""
        self.recording = False
        with self._lock:
            return [
                (self._values[stamp], self._vectors[stamp]) for stamp in sorted(self._values) if stamp in self._vectors
            ]

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.unregister()


class Bench:
    """The behaviour tree node (with the taught skill in its library) and this process as a rospy node with a Qt
    application; with ``own_master``, on a roscore of its own (else rospy is initialised on a master already)."""

    def __init__(self, log_dir: pathlib.Path, own_master: bool = True) -> None:
        from teleteach.runtime.experiment import Experiment

        self.log_dir = log_dir
        self.own_master = own_master
        self.data_dir = log_dir / "data"
        self.data_dir.mkdir(parents=True, exist_ok=True)
        self.experiment = Experiment(log_dir, self.data_dir)
        self.closed_windows: List[object] = []
        try:
            if own_master:
                os.environ["ROS_LOG_DIR"] = str(log_dir / "ros")
                self.experiment.own_roscore(host="127.0.0.1")
                self.experiment.join("haptic_guidance_bench")
            self._start_ros()
        except BaseException:
            self.experiment.close()
            raise

    def _start_ros(self) -> None:
        import rospy
        from PyQt5.QtWidgets import QApplication

        from teleteach.msg import BehaviourTree
        from teleteach.srv import AddSkill, ChangeTree

        self.app = QApplication.instance() or QApplication(["haptic_guidance_bench"])
        node = str(ROOT / "nodes" / "behaviour_tree")
        # no robot here: tick at once, and the running first leaf waits for its server as long as the bench runs
        command = [node, f"_data_dir:={self.data_dir}", "_startup_timeout:=0", "_server_timeout:=1000000"]
        self.experiment.start("behaviour_tree", command, self.log_dir / "behaviour_tree.log")
        rospy.wait_for_service("/change_tree", timeout=60)
        self._tree_lock = threading.Lock()
        self._tree: List[str] = []
        self._tree_subscriber = rospy.Subscriber("/behaviour_tree/log/tree", BehaviourTree, self._on_tree)
        self.change_tree = rospy.ServiceProxy("/change_tree", ChangeTree)
        answer = rospy.ServiceProxy("/behaviour_tree/add_skill", AddSkill)(INSERT_SKILL, "stiffness", str(SKILL_FILE))
        if not answer.success:
            raise RuntimeError(f"the taught skill was refused: {answer.message}")
        self.wait_for(lambda: bool(self.tree()), 30, "the tree")
        self.baseline = self.tree()

    def _on_tree(self, message) -> None:
        by_id = {behaviour.own_id: behaviour for behaviour in message.behaviours}
        execution = next((b for b in message.behaviours if b.name == "BehaviorExecution"), None)
        children = [by_id[child].name for child in execution.child_ids if child in by_id] if execution else []
        with self._tree_lock:
            self._tree = children

    def tree(self) -> List[str]:
        """BehaviorExecution's children, as the tree last published them."""
        with self._tree_lock:
            return list(self._tree)

    def pump(self, seconds: float) -> None:
        """Let the GUI run for ``seconds``."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.app.processEvents()
            time.sleep(0.002)

    def wait_for(self, predicate: Callable[[], bool], timeout: float, what: str = "") -> Optional[float]:
        """Run the GUI until ``predicate()`` holds; the time it did (monotonic), or None after ``timeout``
        (an error naming ``what`` when given)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self.app.processEvents()
            if predicate():
                return time.monotonic()
            time.sleep(0.002)
        if what:
            raise TimeoutError(f"timed out after {timeout:g} s waiting for {what}")
        return None

    def restore_tree(self) -> None:
        """Undo edits (over /change_tree, not with the device) until the tree is the baseline again."""
        from teleteach.srv import ChangeTreeRequest

        for _ in range(4):
            if self.wait_for(lambda: self.tree() == self.baseline, 1.0):
                return
            self.change_tree(ChangeTreeRequest(operation="undo"))
        self.wait_for(lambda: self.tree() == self.baseline, 5.0, f"the tree restored to {self.baseline}")

    def close(self) -> None:
        import rospy

        self._tree_subscriber.unregister()
        if self.own_master:
            rospy.signal_shutdown("bench done")
        self.experiment.close()


class Session:
    """One GUI window and one device node (a tremor level, guidance on or off), running trials one after another."""

    def __init__(self, bench: Bench, tremor: float, guided: bool, human: Optional[Human] = None) -> None:
        from teleteach.core.gui_config import GuiConfig
        from teleteach.gui.app import MainWindow

        self.bench, self.tremor, self.guided, self.human = bench, tremor, guided, human or Human()
        name = f"device_{tremor * 1000:.0f}mm_{'with' if guided else 'without'}"
        arguments = ["backend:=topic", "hand_model:=true", f"tremor:={tremor}"]
        self.device_log = bench.log_dir / f"{name}.log"
        self.device_log.unlink(missing_ok=True)
        self.device = bench.experiment.start(
            name, ["roslaunch", "teleteach", "device.launch", *arguments], self.device_log
        )
        self.loop: Optional[dict] = None  # the device loop's rate and stalls, once the session is closed
        self.operator = Operator(self.human)
        self.stiffness = StiffnessLog()
        self.config = GuiConfig.load(guidance=guided)
        self.window = MainWindow(self.config, data_root=bench.data_dir)
        self.window.show()
        self.confirmations: List[tuple] = []  # (time, kind, label) of every click a step took
        self.window.start_tab.mode_chosen.connect(self._on_mode_chosen)
        flow = self.window.high_level.flow
        click = flow.click

        def observed_click():
            from teleteach.gui.selection import Step

            kind, label = {
                Step.NODE: ("node", flow.selected_node),
                Step.OPERATION: ("operation", flow.selected_operation),
                Step.INDEX: ("index", str(flow.index)),
            }.get(flow.step, ("other", ""))
            result = click()
            self.confirmations.append((time.monotonic(), kind, label))
            return result

        flow.click = observed_click
        bench.wait_for(lambda: self.window.worker.device_time > 0.0, 60, "the device node's first pose in the GUI")
        bench.wait_for(lambda: INSERT_SKILL in flow.choices, 30, "the HIGH-LEVEL buttons with the taught skill")
        self.bench.pump(0.5)

    def _on_mode_chosen(self, tab: int) -> None:
        self.confirmations.append((time.monotonic(), "start", START_CHOICES[tab - 1]))

    def close(self) -> None:
        self.window.close()
        self.bench.pump(0.3)
        # Closed windows are kept, not deleted: the bench died of a segmentation fault when its fourth session
        # began, three windows closed and collected; teaching_gui runs one window per process, which never dies.
        self.bench.closed_windows.append(self.window)
        self.stiffness.close()
        self.operator.close()
        self.bench.experiment.stop(self.device)
        found = LOOP_SUMMARY.findall(self.device_log.read_text(errors="replace")) if self.device_log.exists() else []
        if found:
            cycles, rate, failed, stalls = found[-1]
            self.loop = {"rate_hz": float(rate), "failed_reads": int(failed), "stalls_over_1s": int(stalls)}

    # the operator's acts ------------------------------------------------------------------------
    def _reaction(self, rng) -> float:
        human = self.human
        return float(np.clip(rng.normal(human.reaction, human.reaction_sd), 0.15, 0.45))

    def _click(self, rng) -> None:
        """After a reaction time, a click with the finger's push on the hand."""
        human = self.human
        self.bench.pump(self._reaction(rng))
        push = np.concatenate([rng.normal(0.0, human.click_push, 3), rng.normal(0.0, human.click_turn, 3)])
        self.operator.click(push)

    def _reach(self, rng, axis: int, target: float, width: float) -> None:
        current = self.operator.intended()
        pose = reach_pose(self.human, rng, current, axis, target, width)
        duration = fitts_time(self.human, pose[axis] - current[axis], width)
        self.operator.reach(pose, duration)
        self.bench.pump(duration + self.human.settle)

    def select(
        self,
        rng,
        task: str,
        kind: str,
        intended: str,
        axis: int,
        target: float,
        width: float,
        shown: Callable[[], str],
    ) -> Selection:
        """Reach for ``intended`` (at ``target`` on ``axis``, ``width`` wide), correct while the GUI shows another
        choice, click; the selection as the GUI confirmed it."""
        begun = time.monotonic()
        self._reach(rng, axis, target, width)
        corrections = 0
        while True:
            self.bench.pump(self._reaction(rng))  # look at the screen
            if shown() == intended or corrections >= self.human.max_corrections:
                break
            corrections += 1
            self._reach(rng, axis, target, width)
        seen = shown()
        before = len(self.confirmations)
        for clicks in range(1, 4):  # a click the GUI did not take is clicked again
            self._click(rng)
            if self.bench.wait_for(lambda: len(self.confirmations) > before, self.human.click_duration + 1.5):
                confirmed_at, _, label = self.confirmations[before]
                return Selection(task, kind, intended, label, confirmed_at - begun, corrections, clicks, seen)
        return Selection(task, kind, intended, None, time.monotonic() - begun, corrections, 3, seen)

    def back_to_start(self) -> None:
        """Open the gripper fully (START from any tab) while the hand goes home, then rest it."""
        self.operator.gripper(OPEN_GRIPPER)
        self.operator.reach(HOME, 0.6)
        self.bench.wait_for(lambda: self.window.tabs.currentIndex() == 0, 5, "START")
        self.bench.pump(0.4)
        self.operator.gripper(RESTING_GRIPPER)
        self.bench.pump(0.5)

    def _open(self, rng, task: str, choice: int) -> Selection:
        """START -> the tab of ``choice`` (0 HIGH-LEVEL, 1 LOW-LEVEL) with device X."""
        start = self.window.start_tab
        return self.select(
            rng, task, "start", START_CHOICES[choice], 0, bin_centre(choice, 2, self.config.device_range),
            self.config.device_range, lambda: START_CHOICES[start.selected],
        )  # fmt: skip

    # the tasks ----------------------------------------------------------------------------------
    def removal(self, rng, trial: int) -> TrialResult:
        """III-B: select PlaceItem, remove it."""
        return self._edit(rng, trial, "removal", REMOVE_TARGET, "remove", None)

    def insertion(self, rng, trial: int) -> TrialResult:
        """III-E: select the taught skill, insert, dial to INSERT_INDEX."""
        return self._edit(rng, trial, "insertion", INSERT_SKILL, "insert", INSERT_INDEX)

    def _edit(self, rng, trial: int, task: str, node: str, operation: str, index: Optional[int]) -> TrialResult:
        from teleteach.gui.selection import OPERATIONS, Step

        flow, config = self.window.high_level.flow, self.config
        result = TrialResult(task, trial, [])
        steps = [lambda: self._open(rng, task, 0)]
        count = len(flow.choices)
        position = flow.choices.index(node)
        steps.append(
            lambda: self.select(
                rng,
                task,
                "node",
                node,
                0,
                bin_centre(position, count, config.device_range),
                2.0 * config.device_range / count,
                lambda: flow.selected_node,
            )  # fmt: skip
        )
        steps.append(
            lambda: self.select(
                rng,
                task,
                "operation",
                operation,
                1,
                bin_centre(OPERATIONS.index(operation), len(OPERATIONS), config.device_range),
                2.0 * config.device_range / len(OPERATIONS),
                lambda: flow.selected_operation,
            )  # fmt: skip
        )
        if index is not None:
            steps.append(
                lambda: self.select(
                    rng,
                    task,
                    "index",
                    str(index),
                    3,
                    bin_centre(index, flow.insert_slots, config.device_angle_range),
                    2.0 * config.device_angle_range / flow.insert_slots,
                    lambda: str(flow.index),
                )  # fmt: skip
            )
        for step in steps:
            selection = step()
            result.selections.append(selection)
            if selection.confirmed != selection.intended:
                break  # the operator sees the GUI took something else and gives up on this trial
        else:
            self.bench.wait_for(lambda: flow.step is Step.NODE and flow.answer, 10, "the tree's answer")
            expected = [name for name in self.bench.baseline if not (operation == "remove" and name == node)]
            if index is not None:
                expected.insert(index, node)
            done = self.bench.wait_for(lambda tree=expected: self.bench.tree() == tree, 3.0)
            result.edit_as_intended = done is not None
        self.back_to_start()
        self.bench.restore_tree()
        self.bench.wait_for(lambda: len(flow.choices) == count, 10, "the buttons of the restored tree")
        return result

    def stiffness_task(self, rng, trial: int) -> TrialResult:
        """III-C phase 2 in LOW-LEVEL: preset the ellipsoid in ALL, click to mode X and to mode Y, raise Y, hold."""
        command, config = self.window.command, self.config
        result = TrialResult("stiffness", trial, [self._open(rng, "stiffness", 1)])
        if result.selections[0].wrong or result.selections[0].confirmed is None:
            self.back_to_start()
            return result
        self.bench.wait_for(lambda: command.mode == "ALL", 5, "mode ALL")
        preset = self.operator.intended()
        preset[:3] = [stiffness_position(value, config) for value in PRESET_STIFFNESS]
        distance = float(np.linalg.norm(preset[:3] - self.operator.intended()[:3]))
        width = stiffness_position(2.0 * STIFFNESS_TOLERANCE + config.min_stiffness, config) + config.device_range
        duration = fitts_time(self.human, distance, width)
        self.operator.reach(preset, duration)
        self.bench.pump(duration + 0.6)
        for mode in ("X", "Y"):
            for _ in range(3):  # a click the GUI did not take is made again, after the double-click window
                self._click(rng)
                if self.bench.wait_for(lambda mode=mode: command.mode == mode, 2.0):
                    break
            else:
                raise TimeoutError(f"three clicks did not change the mode to {mode}")
        self.bench.pump(self._reaction(rng))
        self.stiffness.start()
        target = stiffness_position(RAISED_Y, config)

        def content() -> bool:
            return abs(command.stiffness()[0][1] - RAISED_Y) <= STIFFNESS_TOLERANCE

        self._reach(rng, 1, target, width)
        corrections = 0
        while True:
            self.bench.pump(self._reaction(rng))
            if content() or corrections >= self.human.max_corrections:
                break
            corrections += 1
            self._reach(rng, 1, target, width)
        self.bench.pump(HOLD_TIME)
        samples = self.stiffness.stop()
        result.drift, result.eigenvalue_drift = drift_of(samples)
        result.final_y = float(command.stiffness()[0][1])
        self.back_to_start()
        while command.mode != "ALL":  # the bench's reset, as four clicks would do
            command.next_mode()
        return result

    def run(self, task: str, rng, trial: int) -> TrialResult:
        """One trial; one the system did not answer in time is abandoned (counted), and the next starts afresh."""
        method = {"removal": self.removal, "insertion": self.insertion, "stiffness": self.stiffness_task}[task]
        try:
            return method(rng, trial)
        except TimeoutError as error:
            result = TrialResult(task, trial, [], abandoned=str(error))
        self.window.tabs.setCurrentIndex(0)  # the bench's reset: START, the tree and the mode as at the start
        self.operator.gripper(RESTING_GRIPPER)
        self.operator.reach(HOME, 0.6)
        self.bench.pump(1.0)
        self.bench.restore_tree()
        while self.window.command.mode != "ALL":
            self.window.command.next_mode()
        return result


def summarise(results: Sequence[TrialResult]) -> dict:
    """The figures of a set of trials."""
    selections = [selection for result in results for selection in result.selections]
    confirmed = [selection for selection in selections if selection.confirmed is not None]
    times = np.array([selection.seconds for selection in confirmed]) if confirmed else np.array([math.nan])
    drifts = [result.drift for result in results if result.drift is not None and math.isfinite(result.drift)]
    eigen = [result.eigenvalue_drift for result in results if result.eigenvalue_drift is not None]
    edits = [result.edit_as_intended for result in results if result.edit_as_intended is not None]
    by_kind = {}
    for kind in ("start", "node", "operation", "index"):
        chosen = [selection for selection in confirmed if selection.kind == kind]
        if chosen:
            by_kind[kind] = {
                "selections": len(chosen),
                "wrong_selections": sum(selection.wrong for selection in chosen),
                "selection_time_s": round(float(np.mean([selection.seconds for selection in chosen])), 3),
                "corrections_per_selection": round(float(np.mean([selection.corrections for selection in chosen])), 3),
                "clicks_per_selection": round(float(np.mean([selection.clicks for selection in chosen])), 3),
            }
    return {
        "wrong_selections": int(sum(selection.wrong for selection in confirmed)),
        "selections": len(confirmed),
        "unconfirmed_selections": len(selections) - len(confirmed),
        "selection_time_s": {
            "mean": round(float(np.mean(times)), 3),
            "median": round(float(np.median(times)), 3),
            "p90": round(float(np.percentile(times, 90)), 3),
        },
        "unintended_drift_n_per_m": round(float(np.mean(drifts)), 2) if drifts else None,
        "unintended_eigenvalue_drift_n_per_m": round(float(np.mean(eigen)), 2) if eigen else None,
        "edits_as_intended": f"{sum(edits)}/{len(edits)}",
        "abandoned_trials": sum(bool(result.abandoned) for result in results),
        "by_kind": by_kind,
    }


def run(trials: int, tremors: Sequence[float], block: int, tasks: Sequence[str] = TASKS, log=print) -> dict:
    """All sessions; returns {"with": ..., "without": ...} with the trials' figures, per tremor level too.

    The trials of a tremor level run in blocks of ``block``, alternating the condition (and which goes first), so
    that the machine's load (others' processes) weighs on both alike.
    """
    results: Dict[str, Dict[float, List[TrialResult]]] = {
        condition: {tremor: [] for tremor in tremors} for condition in CONDITIONS
    }
    loops: Dict[str, List[dict]] = {condition: [] for condition in CONDITIONS}
    loads: List[float] = []  # the machine's 1-minute load average after each session
    with tempfile.TemporaryDirectory(prefix="haptic_guidance_") as folder:
        bench = Bench(pathlib.Path(folder))
        try:
            for level, tremor in enumerate(tremors):
                for number, first in enumerate(range(0, trials, block)):
                    order = CONDITIONS if number % 2 == 0 else CONDITIONS[::-1]
                    for condition in order:
                        session = Session(bench, tremor, condition == "with")
                        started = time.monotonic()
                        try:
                            for trial in range(first, min(first + block, trials)):
                                for task in tasks:
                                    seed = [SEED, level, TASKS.index(task), trial]  # the same with and without
                                    rng = np.random.default_rng(seed)
                                    result = session.run(task, rng, trial)
                                    results[condition][tremor].append(result)
                                    if result.abandoned:
                                        log(f"{condition} guidance, {task} trial {trial} abandoned: {result.abandoned}")
                        finally:
                            session.close()
                        if session.loop is not None:
                            loops[condition].append(session.loop)
                        loads.append(os.getloadavg()[0])
                        figures = summarise(results[condition][tremor])
                        log(
                            f"tremor {tremor * 1000:.0f} mm, {condition} guidance, trials up to {trial + 1}: "
                            f"{figures['wrong_selections']} wrong of {figures['selections']} selections, mean "
                            f"{figures['selection_time_s']['mean']} s, drift {figures['unintended_drift_n_per_m']} N/m "
                            f"(block {time.monotonic() - started:.0f} s)"
                        )
        finally:
            bench.close()
    report = {}
    for condition in CONDITIONS:
        everything = [result for tremor in tremors for result in results[condition][tremor]]
        report[condition] = summarise(everything)
        report[condition]["per_tremor"] = {
            f"{tremor * 1000:.0f}mm": summarise(results[condition][tremor]) for tremor in tremors
        }
        report[condition]["per_task"] = {
            task: summarise([result for result in everything if result.task == task]) for task in tasks
        }
        report[condition]["device_loop"] = {
            "sessions": len(loops[condition]),
            "mean_rate_hz": round(float(np.mean([loop["rate_hz"] for loop in loops[condition]])), 1)
            if loops[condition]
            else None,
            "failed_reads": sum(loop["failed_reads"] for loop in loops[condition]),
            "stalls_over_1s": sum(loop["stalls_over_1s"] for loop in loops[condition]),
        }
        report[condition]["trials"] = [
            dict(dataclasses.asdict(result), tremor_m=tremor)
            for tremor in tremors
            for result in results[condition][tremor]
        ]
    report["tasks"] = list(tasks)
    report["trials_per_task"] = trials
    report["trials_per_session"] = block
    report["tremors_m"] = list(tremors)
    report["human"] = dataclasses.asdict(Human())
    report["machine"] = {
        "cpus": os.cpu_count(),
        "mean_load_average": round(float(np.mean(loads)), 1) if loads else None,
    }
    return report


def plot(report: dict, path: pathlib.Path) -> None:
    from matplotlib.figure import Figure

    tremors = [f"{value * 1000:.0f}mm" for value in report["tremors_m"]]
    figure = Figure(figsize=(13, 4.2))
    axes = figure.subplots(1, 3)
    width = 0.38
    positions = np.arange(len(tremors))
    colours = {"without": "#9e9e9e", "with": "#1e88e5"}
    for offset, condition in ((-width / 2, "without"), (width / 2, "with")):
        per = report[condition]["per_tremor"]
        rates = [100.0 * per[t]["wrong_selections"] / max(1, per[t]["selections"]) for t in tremors]
        bars = axes[0].bar(positions + offset, rates, width, label=f"{condition} guidance", color=colours[condition])
        counts = [f"{per[t]['wrong_selections']}/{per[t]['selections']}" for t in tremors]
        axes[0].bar_label(bars, counts, fontsize=8)
        means = [per[t]["selection_time_s"]["mean"] for t in tremors]
        bars = axes[1].bar(positions + offset, means, width, color=colours[condition])
        axes[1].bar_label(bars, [f"{value:.2f}" for value in means], fontsize=8)
        drifts = [per[t]["unintended_drift_n_per_m"] or 0.0 for t in tremors]
        bars = axes[2].bar(positions + offset, drifts, width, color=colours[condition])
        axes[2].bar_label(bars, [f"{value:.1f}" for value in drifts], fontsize=8)
    titles = (
        "wrong selections [% of confirmed]",
        "time to a confirmed selection, mean [s]",
        "unintended stiffness drift while raising Y [N/m RMS]",
    )
    for axis, title in zip(axes, titles):
        axis.set_xticks(positions)
        axis.set_xticklabels([f"tremor {t}" for t in tremors])
        axis.set_title(title, fontsize=10)
        axis.grid(axis="y", alpha=0.3)
        axis.margins(y=0.12)  # room for the bar labels
    figure.legend(*axes[0].get_legend_handles_labels(), loc="upper right", fontsize=8, ncol=2)
    figure.suptitle(f"haptic guidance, {report['trials_per_task']} trials per task, tremor level and condition")
    figure.tight_layout()
    figure.savefig(path, dpi=110)


def table(report: dict) -> str:
    lines = [
        f"{'tremor':>7} {'guidance':>9} {'wrong/selections':>17} {'time mean [s]':>14} {'p90 [s]':>8} "
        f"{'drift [N/m]':>12} {'eigen drift':>12} {'edits ok':>9} {'abandoned':>9}"
    ]
    for tremor in [f"{value * 1000:.0f}mm" for value in report["tremors_m"]] + ["all"]:
        for condition in CONDITIONS:
            figures = report[condition] if tremor == "all" else report[condition]["per_tremor"][tremor]
            lines.append(
                f"{tremor:>7} {condition:>9} {figures['wrong_selections']:>8}/{figures['selections']:<8} "
                f"{figures['selection_time_s']['mean']:>14.3f} {figures['selection_time_s']['p90']:>8.3f} "
                f"{figures['unintended_drift_n_per_m']!s:>12} {figures['unintended_eigenvalue_drift_n_per_m']!s:>12} "
                f"{figures['edits_as_intended']:>9} {figures['abandoned_trials']:>9}"
            )
    return "\n".join(lines)


def main(argv: Optional[Sequence[str]] = None) -> int:
    if not os.environ.get("DISPLAY"):  # the GUI needs an X server that outlives it: run under xvfb-run
        arguments = ["xvfb-run", "-a", "-s", "-screen 0 1400x1000x24", sys.executable, __file__]
        os.execvp("xvfb-run", arguments + list(sys.argv[1:] if argv is None else argv))
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=20, help="trials per task, tremor level and condition")
    parser.add_argument("--tremors", type=float, nargs="+", default=list(TREMORS), help="tremor RMS levels [m]")
    parser.add_argument("--tasks", nargs="+", choices=TASKS, default=list(TASKS), help="the tasks to run")
    parser.add_argument("--block", type=int, default=5, help="trials per session; sessions alternate the condition")
    parser.add_argument("--out", type=pathlib.Path, default=RESULTS, help="the JSON file (the plot goes next to it)")
    arguments = parser.parse_args(argv)
    if arguments.trials < 1 or arguments.block < 1:
        parser.error("--trials and --block must be at least 1")
    # Stopped by Ctrl-C or SIGTERM (also when started in the background, where SIGINT is ignored), the bench still
    # stops its nodes: the handlers raise in the main thread and the sessions' cleanup runs.
    faulthandler.enable()  # a crash in Qt or rospy prints where it happened
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, lambda number, _frame: sys.exit(128 + number))
    started = time.monotonic()
    report = run(arguments.trials, arguments.tremors, arguments.block, arguments.tasks)
    report["duration_s"] = round(time.monotonic() - started, 1)
    arguments.out.parent.mkdir(parents=True, exist_ok=True)
    arguments.out.write_text(json.dumps(report, indent=2) + "\n")
    plot(report, arguments.out.with_suffix(".png"))
    print(table(report))
    for condition in CONDITIONS:
        loop = report[condition]["device_loop"]
        print(
            f"device loop {condition} guidance: {loop['mean_rate_hz']} Hz on average (1000 asked), "
            f"{loop['stalls_over_1s']} stalls over 1 s, {loop['failed_reads']} failed reads, "
            f"{loop['sessions']} sessions"
        )
    print(f"machine: {report['machine']['cpus']} CPUs, load average {report['machine']['mean_load_average']}")
    without, guided = report["without"], report["with"]
    wrong_ratio = (
        f"{without['wrong_selections'] / guided['wrong_selections']:.1f}x"
        if guided["wrong_selections"]
        else "none with guidance"
    )
    drifts = (without["unintended_drift_n_per_m"], guided["unintended_drift_n_per_m"])
    drift_ratio = f"{drifts[0] / drifts[1]:.1f}x" if drifts[0] is not None and drifts[1] else "n/a"
    print(
        f"goal (>= 5x fewer wrong selections and less drift, no slower selections): wrong selections "
        f"{without['wrong_selections']} -> {guided['wrong_selections']} ({wrong_ratio}), drift "
        f"{without['unintended_drift_n_per_m']} -> {guided['unintended_drift_n_per_m']} N/m ({drift_ratio}), "
        f"mean selection time {without['selection_time_s']['mean']} -> {guided['selection_time_s']['mean']} s"
    )
    print(f"took {report['duration_s']:.0f} s; wrote {arguments.out} and {arguments.out.with_suffix('.png')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
