"""The virtual device's key gestures arrive as the same gestures on a loaded machine as on an idle one (issue 54).

The real sigma7_node with the virtual backend, started by launch/device.launch as full.launch starts it (its loop at
the launch's real-time priority: at the ordinary one, 2 of 13 runs here lost a gesture beside the busy loops, the loop
stalled up to 0.9 s), opens its window in the X server of pytest-xvfb; xdotool sends it a
fixed script of keys from outside the process, through the X server's XTEST extension as a keyboard would (a held key
is repeated by the X server as a real one is): Space (a click), Enter (a double click), C held (TELEOP's clutch), O
held (the gripper opened fully: back to START). This process hears /sigma7/button and /sigma7/gripper_angle through
the GUI's own ROS worker (teleteach.gui.worker.RosWorker: its edge detectors, its clicks stamped with the device's
clock) and tells the gestures apart as the GUI's tabs do: LOW-LEVEL's ClickClassifier for clicks (config/gui.yaml's
double_click_window), TELEOP's GripperClutch for the clutch (gui.yaml's teleop.clutch_*), the worker's
gripper_opened for the opened gripper. The script is played twice: on the machine as it is, then with four busy loops
spread over the cores (bench/stress.py's, as `scripts/stress --hogs 4` runs them). Each time the gestures that arrive
must be the gestures sent, in order.
"""

import collections
import os
import subprocess
import time

import pytest
from bench_scripts import bench_module
from conftest import pump, pump_until, start, stop

pytestmark = pytest.mark.gui

WINDOW_TITLE = "teleteach: virtual Sigma.7"
HOGS = 4  # busy loops, as `scripts/stress --hogs 4`
GAP = 1.2  # [s] after each gesture: two double-click windows (0.6 s), so two single clicks stay two
HOLD_C = 1.0  # [s] C held: the clutch engages after 0.6 s of a closed gripper
HOLD_O = 0.6  # [s] O held: the gripper opened fully
# (gesture sent, the key, how long it is held: 0 is a press and release at once)
SCRIPT = [
    ("single", "space", 0.0),
    ("double", "Return", 0.0),
    ("single", "space", 0.0),
    ("single", "space", 0.0),
    ("clutch", "c", HOLD_C),
    ("double", "Return", 0.0),
    ("open", "o", HOLD_O),
    ("single", "space", 0.0),
    ("double", "Return", 0.0),
]


def xdotool(*arguments):
    subprocess.run(["xdotool", *arguments], check=True, timeout=30, capture_output=True)


class Gestures:
    """What the GUI would make of the device's topics: the gestures in the order the tabs would act on them."""

    def __init__(self, qapp, config):
        from PyQt5.QtCore import QObject, Qt, QThread, QTimer, pyqtSlot

        from teleteach.core.teleoperation import GripperClutch
        from teleteach.gui.device import ClickClassifier
        from teleteach.gui.ellipsoid import EllipsoidCommand
        from teleteach.gui.recording import StiffnessRecorder
        from teleteach.gui.worker import RosWorker

        self.qapp = qapp
        self.seen = []
        self.presses = []  # the stamps of the button's presses the worker passed on (a double click is two)
        self.classifier = ClickClassifier(config.double_click_window)  # LOW-LEVEL's: click = single, two = double
        self.clutch = GripperClutch(config.teleop)  # TELEOP's clutch, fed as its adapter feeds it
        self.worker = RosWorker(config, EllipsoidCommand(config), StiffnessRecorder(), lambda: None)
        gestures = self

        class Receiver(QObject):  # in the GUI thread, as the window that receives the worker's signals
            @pyqtSlot(float)
            def clicked(self, stamp):
                gestures.presses.append(stamp)
                gestures._classified(gestures.classifier.click(stamp))

            @pyqtSlot()
            def opened(self):
                gestures.seen.append("open")

        self.receiver = Receiver()
        self.thread = QThread()
        self.worker.moveToThread(self.thread)
        self.thread.started.connect(self.worker.start)
        self.worker.clicked.connect(self.receiver.clicked, Qt.QueuedConnection)
        self.worker.gripper_opened.connect(self.receiver.opened, Qt.QueuedConnection)
        self.thread.start()
        self.timer = QTimer()  # the tabs' ticks: LOW-LEVEL's pending click, TELEOP's clutch
        self.timer.timeout.connect(self._tick)
        self.timer.start(int(round(1000.0 / config.publish_rate)))

    def _classified(self, kind):
        if kind is not None:
            self.seen.append(kind)

    def _tick(self):
        import rospy

        worker = self.worker
        self._classified(self.classifier.poll(worker.device_time, worker.last_click))
        if self.clutch.update(rospy.get_time(), worker.gripper_angle):
            self.seen.append("clutch")

    def wait_for_the_device(self):
        pump_until(self.qapp, lambda: self.worker.gripper_angle is not None, 60, "/sigma7/gripper_angle")
        pump(self.qapp, 1.0)  # /sigma7/button's connection too

    def close(self):
        from PyQt5.QtCore import QMetaObject, Qt

        self.timer.stop()
        QMetaObject.invokeMethod(self.worker, "stop", Qt.BlockingQueuedConnection)
        self.thread.quit()
        self.thread.wait(3000)


Run = collections.namedtuple("Run", "seen lags seconds longest_gap")


def play(qapp, gestures, window, poses):
    """The script's keys to the device's window: the gestures that arrived, each press's stamp after its key was sent
    [s], how long it took [s] and the longest the device loop went without a pose [s] (between the stamps of
    /sigma7/pose: a stall of its loop)."""
    import rospy

    xdotool("windowfocus", "--sync", window)  # the operator clicks the window: its keys go to it
    pump(qapp, 0.5)
    start_index, presses, started = len(gestures.seen), len(gestures.presses), time.monotonic()
    keys = []  # when each key went (wall clock, as the device's stamps)
    for _, key, hold in SCRIPT:
        keys.append(rospy.get_time())
        if hold:
            xdotool("keydown", key)
            pump(qapp, hold)
            xdotool("keyup", key)
        else:
            xdotool("key", key)
        pump(qapp, GAP)
    pump(qapp, 1.0)  # the last click's window
    stamps = [message.header.stamp.to_sec() for message in poses.since(started)]
    longest = max(later - earlier for earlier, later in zip(stamps, stamps[1:]))
    lags = [stamp - max((key for key in keys if key <= stamp), default=stamp) for stamp in gestures.presses[presses:]]
    return Run(gestures.seen[start_index:], lags, time.monotonic() - started, longest)


def test_the_virtual_device_s_gestures_arrive_the_same_under_four_busy_loops(qapp, ros_master, topic_log, tmp_path):
    from geometry_msgs.msg import PoseStamped

    from teleteach.core.gui_config import GuiConfig

    stress = bench_module("stress")
    node = start(["roslaunch", "teleteach", "device.launch", "backend:=virtual"], tmp_path / "sigma7_node.log")
    gestures = Gestures(qapp, GuiConfig.load())
    poses = topic_log("/sigma7/pose", PoseStamped)
    runs = {}
    try:
        found = subprocess.run(
            ["xdotool", "search", "--sync", "--name", WINDOW_TITLE],
            capture_output=True,
            text=True,
            timeout=60,
            check=True,
        )
        window = found.stdout.split()[0]
        gestures.wait_for_the_device()
        runs["idle"] = play(qapp, gestures, window, poses)
        cores = stress.hog_cores(HOGS, os.cpu_count() or 1)
        hogs = [stress.busy_loop(core) for core in cores]
        try:
            runs[f"{HOGS} busy loops on cores {cores}"] = play(qapp, gestures, window, poses)
        finally:
            for hog in hogs:
                hog.kill()
                hog.wait()
    finally:
        gestures.close()
        stop(node)
    sent = [gesture for gesture, _, _ in SCRIPT]
    presses = sum({"single": 1, "double": 2}.get(gesture, 0) for gesture in sent)
    print(f"\nsent: {dict(collections.Counter(sent))} {sent}, {presses} presses")
    for name, run in runs.items():
        print(
            f"{name}: {dict(collections.Counter(run.seen))} {run.seen}, {len(run.lags)} presses stamped"
            f" {[round(lag, 2) for lag in run.lags]} s after their key ({run.seconds:.1f} s, the device loop's"
            f" longest gap {1000 * run.longest_gap:.0f} ms)"
        )
    log = (tmp_path / "sigma7_node.log").read_text().splitlines()
    print("sigma7_node:", next((line for line in reversed(log) if "published" in line), "no summary line"))
    # Expect every gesture to arrive as the one sent, in order, idle and under the busy loops
    for name, run in runs.items():
        assert run.seen == sent, f"{name}: sent {sent}, the GUI would have seen {run.seen}"
