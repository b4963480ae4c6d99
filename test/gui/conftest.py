"""Fixtures for the GUI tests: a roscore, the real behaviour tree node, the GUI in this process, a device stand-in.

The GUI runs in the X server pytest-xvfb starts (real Mesa OpenGL); the test process is one rospy node that both
hosts the GUI and plays the operator (it publishes the /sigma7 topics the sigma7 node would publish).
"""

import collections
import gc
import os
import pathlib
import subprocess
import threading
import time
import warnings

import pytest

from teleteach.runtime.processes import own_roscore, stop_tree

ROOT = pathlib.Path(__file__).resolve().parents[2]


def stop(process, timeout=10.0):
    """Stop a node or launch and what it left running, reported as a warning: a launch's node alive after its test
    would publish into the next tests (its TF, its /clock)."""
    _, leftovers = stop_tree(process, timeout)
    if leftovers:
        warnings.warn(f"{' '.join(process.args)} left processes {leftovers} running; stopped them", stacklevel=2)


@pytest.fixture(autouse=True)
def collect_garbage():
    """After each GUI test, its garbage goes (Qt widgets in reference cycles included), here and not in a later test."""
    yield
    gc.collect()


@pytest.fixture(autouse=True)
def no_topics_left_behind():
    """A test's publishers and subscribers in this process end with it: one left behind (a stand-in robot's latched
    base in /tf_static) is heard by the next tests' windows, which then fail for a reason that is not theirs."""
    before = own_topics()
    yield
    left = own_topics() - before
    assert not left, f"the test left this process publishing or subscribing: {sorted(left)}"


def own_topics():
    """("publishes" | "subscribes", topic) of this process's node, by the master; empty while it is no node."""
    import rospy

    if not rospy.core.is_initialized():
        return set()
    name = rospy.get_name()
    publishers, subscribers, _ = rospy.get_master().getSystemState()[2]
    return {
        (role, topic)
        for role, table in (("publishes", publishers), ("subscribes", subscribers))
        for topic, nodes in table
        if name in nodes
    }


@pytest.fixture(scope="session")
def ros_master(tmp_path_factory):
    """A roscore on a free port of its own (teleteach.runtime.processes.own_roscore).

    This process becomes the rospy node 'gui_test'.
    """
    import rospy

    if rospy.core.is_initialized():
        raise RuntimeError("rospy was initialised by another test in this process; GUI tests need their own master")
    os.environ["ROS_HOSTNAME"] = "127.0.0.1"
    os.environ["ROS_LOG_DIR"] = str(tmp_path_factory.mktemp("ros_logs"))

    def start_roscore(command, uri):
        os.environ["ROS_MASTER_URI"] = uri
        return subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)

    _, core = own_roscore(start_roscore, stop, host="127.0.0.1")
    uri = os.environ["ROS_MASTER_URI"]
    rospy.init_node("gui_test", disable_signals=True)
    yield uri
    rospy.signal_shutdown("GUI tests done")
    stop(core)


@pytest.fixture
def data_root(tmp_path):
    path = tmp_path / "teleteach_data"
    path.mkdir()
    return path


def start(command, log_path):
    """A node (or launch) in its own process group, its output in ``log_path`` (read it when a test fails)."""
    with open(log_path, "w") as log:
        return subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)


def start_bt(data_root, server_timeout=60.0, resume=False, start_paused=False):
    """The real behaviour tree node (config/tree.yaml, config/skills.yaml), its data in ``data_root``."""
    import rospy

    from teleteach.msg import BehaviourTree

    node = str(ROOT / "nodes" / "behaviour_tree")
    process = start(
        [
            node,
            f"_data_dir:={data_root}",
            f"_server_timeout:={server_timeout}",
            f"_resume:={str(resume).lower()}",
            f"_start_paused:={str(start_paused).lower()}",
            "_startup_timeout:=0",  # no robot here: tick at once, without waiting for skill servers
        ],
        data_root.parent / "behaviour_tree.log",
    )
    rospy.wait_for_service("/change_tree", timeout=60)
    rospy.wait_for_message("/behaviour_tree/log/tree", BehaviourTree, timeout=30)
    return process


@pytest.fixture
def bt_node(ros_master, data_root):
    """The behaviour tree node; its skills wait a minute for their servers (none run), so nobody asks for help."""
    process = start_bt(data_root)
    yield process
    stop(process)


@pytest.fixture(scope="session")
def qapp():
    from PyQt5.QtWidgets import QApplication

    assert os.environ.get("DISPLAY"), "GUI tests need the X server of pytest-xvfb (Debian python3-pytest-xvfb)"
    return QApplication.instance() or QApplication(["gui_test"])


def pump(qapp, seconds):
    """Let the GUI run for ``seconds``."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        qapp.processEvents()
        time.sleep(0.005)


def pump_until(qapp, predicate, timeout, what):
    """Run the GUI until ``predicate()`` holds; fail naming ``what`` after ``timeout`` seconds.

    ``what`` may be a function: what it returns at the timeout names the wait (so it can say what was seen instead).
    """
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        qapp.processEvents()
        if predicate():
            return
        time.sleep(0.005)
    raise AssertionError(f"timed out after {timeout} s waiting for {what() if callable(what) else what}")


class DeviceStandIn:
    """Publishes the /sigma7 topics like the sigma7 node (pose, gripper, emulated button) at 200 Hz.

    The button goes out from the stream's thread only, each press and release of a click at least once and in order
    (``_edges``): a stream starved through a whole 80 ms press still sends it, and a double click stays two.
    """

    def __init__(self):
        import rospy
        from geometry_msgs.msg import PoseStamped
        from std_msgs.msg import Bool, Float64

        self._rospy = rospy
        self._pose = rospy.Publisher("/sigma7/pose", PoseStamped, queue_size=10)
        self._gripper = rospy.Publisher("/sigma7/gripper_angle", Float64, queue_size=10)
        self._button = rospy.Publisher("/sigma7/button", Bool, queue_size=200)  # 1 s: no edge dropped
        self._messages = (PoseStamped, Float64, Bool)
        self._lock = threading.Lock()
        self.position = [0.0, 0.0, 0.0]
        self.quaternion = [0.0, 0.0, 0.0, 1.0]
        self.gripper = 0.25
        self.pressed = False
        self._edges = collections.deque()  # button states set by click() and not yet published
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def move(self, x=0.0, y=0.0, z=0.0, roll=0.0, pitch=0.0, yaw=0.0):
        from teleteach.core.rotations import rpy_to_quaternion

        with self._lock:
            self.position = [x, y, z]
            self.quaternion = list(rpy_to_quaternion(roll, pitch, yaw))

    def raw(self, position, quaternion):
        with self._lock:
            self.position, self.quaternion = list(position), list(quaternion)

    def click(self, hold=0.08):
        for pressed in (True, False):
            with self._lock:
                self.pressed = pressed
                self._edges.append(pressed)
            time.sleep(hold)

    def set_gripper(self, angle):
        with self._lock:
            self.gripper = angle

    def _run(self):
        pose_class, float_class, bool_class = self._messages
        while not self._stop.is_set() and not self._rospy.is_shutdown():
            with self._lock:
                message = pose_class()
                message.header.stamp = self._rospy.Time.now()
                message.header.frame_id = "sigma7"
                p, q = message.pose.position, message.pose.orientation
                p.x, p.y, p.z = self.position
                q.x, q.y, q.z, q.w = self.quaternion
                gripper = self.gripper
                pressed = self._edges.popleft() if self._edges else self.pressed
            self._pose.publish(message)
            self._gripper.publish(float_class(gripper))
            self._button.publish(bool_class(pressed))
            time.sleep(0.005)

    def close(self):
        self._stop.set()
        self._thread.join(2)
        for publisher in (self._pose, self._gripper, self._button):
            publisher.unregister()


@pytest.fixture
def device(ros_master):
    stand_in = DeviceStandIn()
    yield stand_in
    stand_in.close()


@pytest.fixture
def make_window(qapp, ros_master, data_root):
    """Builds the real main window (config/gui.yaml + overrides); closes and destroys it after the test.

    Destroyed here, not by a later garbage collection: a window's Qt objects (its worker thread, its OpenGL view)
    must go while the X server and the event loop are up, and a failure must point at the test that made it.
    """
    from PyQt5.QtCore import QCoreApplication, QEvent

    from teleteach.core.gui_config import GuiConfig
    from teleteach.gui.app import MainWindow

    windows = []

    def make(**overrides):
        window = MainWindow(GuiConfig.load(**overrides), data_root=data_root)
        window.show()
        windows.append(window)
        pump(qapp, 0.3)
        return window

    yield make
    for window in windows:
        window.close()
        assert window.thread.isFinished(), "the closed window's ROS worker thread still runs"
        window.deleteLater()
    pump(qapp, 0.2)
    QCoreApplication.sendPostedEvents(None, QEvent.DeferredDelete)


class TopicLog:
    """Collects the messages of a topic with their arrival times."""

    def __init__(self, topic, message_class):
        import rospy

        self.messages = []
        self._lock = threading.Lock()
        self._subscriber = rospy.Subscriber(topic, message_class, self._on, queue_size=1000)

    def _on(self, message):
        with self._lock:
            self.messages.append((time.monotonic(), message))

    def connected(self):
        """Whether a publisher of the topic is connected (so what it sends from now on arrives here)."""
        return self._subscriber.get_num_connections() > 0

    def last(self):
        with self._lock:
            return self.messages[-1][1] if self.messages else None

    def since(self, start):
        with self._lock:
            return [message for arrival, message in self.messages if arrival >= start]

    def close(self):
        self._subscriber.unregister()


@pytest.fixture
def topic_log():
    logs = []

    def make(topic, message_class):
        log = TopicLog(topic, message_class)
        logs.append(log)
        return log

    yield make
    for log in logs:
        log.close()
