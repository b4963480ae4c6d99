"""Record a scripted teaching session (device script -> real GUI + real behaviour tree) with record.launch, replay
its device input with replay.launch into a fresh system (new roscore, new GUI, new tree), and get the same device
stream, the same tree edits and the same stiffness commands; then make the offline report of the recorded bag
(figures kept in test-artifacts/)."""

import shutil
import subprocess

import numpy as np
from conftest import ROOT
from ros_processes import Processes, echo_once, start_roscore, start_xvfb, wait_until

from teleteach.recording.bags import DEVICE_TOPICS
from teleteach.recording.report import make_report, tree_edits
from teleteach.recording.session import open_bag, read_session

SCRIPTED_DEVICE = ROOT / "test" / "ros" / "scripted_device.py"
DEVICE_RATE = 100  # [Hz] lower than the real 1 kHz to keep the test light on a loaded 2-core machine
HELD = 0.3  # [s] a stiffness command held this long is deliberate (the script holds each for 1.5 s), not a transient


def device_stream(bag):
    """Every device message's content (stamps included) in order, per topic."""
    streams = {f"/{topic}": [] for topic in DEVICE_TOPICS}  # recorded at the root: /sigma7/...
    with open_bag(bag) as reader:
        wanted = [connection for connection in reader.connections if connection.topic in streams]
        for connection, _, raw in reader.messages(connections=wanted):
            message = reader.deserialize(raw, connection.msgtype)
            if connection.topic == "/sigma7/pose":
                p, q = message.pose.position, message.pose.orientation
                row = (message.header.stamp.sec, message.header.stamp.nanosec, p.x, p.y, p.z, q.x, q.y, q.z, q.w)
            elif connection.topic == "/sigma7/twist":
                linear, angular = message.twist.linear, message.twist.angular
                row = (message.header.stamp.sec, message.header.stamp.nanosec, linear.x, linear.y, linear.z)
                row += (angular.x, angular.y, angular.z)
            else:
                row = (float(message.data),)
            streams[connection.topic].append(row)
    return {topic: np.array(rows) for topic, rows in streams.items()}


def held_commands(series):
    """The distinct stiffness commands (rows) that were held at least HELD seconds, in order."""
    held = []
    start = 0
    for index in range(1, len(series.times) + 1):
        if index == len(series.times) or not np.array_equal(series.values[index], series.values[start]):
            if series.times[index - 1] - series.times[start] >= HELD:
                held.append(tuple(np.round(series.values[start], 6)))
            start = index
    return held


def teaching_outcome(bag):
    session = read_session(bag)
    tabs = [int(value) for value in session.active_tab.values[:, 0]]
    tab_changes = [tab for index, tab in enumerate(tabs) if index == 0 or tab != tabs[index - 1]]
    edits = [(edit.removed, edit.added, edit.moved) for edit in tree_edits(session.trees)]
    return tab_changes, edits, held_commands(session.eigenvalues), held_commands(session.eigenvectors)


def the_bag(folder, prefix):
    bags = sorted((folder / "bags").glob(f"{prefix}_*.bag"))
    assert len(bags) == 1, sorted((folder / "bags").iterdir())
    return bags[0]


def start_teaching_system(processes, data_dir, prefix):
    """Xvfb, roscore, tree, GUI and a recorder; returns once the tree and the GUI are up and the bag is open."""
    start_xvfb(processes, "1024x768x24")
    start_roscore(processes)
    processes.env["TELETEACH_DATA"] = str(data_dir / prefix)  # the tree and the GUI save what was taught there
    processes.start("bt", ["roslaunch", "teleteach", "bt.launch"])
    processes.start("gui", ["roslaunch", "teleteach", "gui.launch", "repaint_rate:=10"])
    processes.start("record", ["roslaunch", "teleteach", "record.launch", f"data_dir:={data_dir}", f"prefix:={prefix}"])
    wait_until(lambda: echo_once(processes, "/behaviour_tree/log/tree", 90), 120, "the tree")
    wait_until(lambda: echo_once(processes, "/teleteach/active_tab", 90), 120, "the GUI")
    wait_until(lambda: list((data_dir / "bags").glob(f"{prefix}_*.bag.active")), 60, f"the {prefix} bag to open")


def test_replayed_device_input_gives_the_same_tree_edits_and_stiffness(tmp_path, artifacts_dir):
    data_dir = tmp_path / "data"
    with Processes(tmp_path / "session") as processes:
        start_teaching_system(processes, data_dir, "scripted")
        device = processes.start("device", [str(SCRIPTED_DEVICE), "--rate", str(DEVICE_RATE)])
        device.wait(120)
        processes.stop("record")
    recorded = the_bag(data_dir, "scripted")

    with Processes(tmp_path / "replay") as processes:
        start_teaching_system(processes, data_dir, "replayed")
        # delay: time for the fresh GUI and the recorder to connect to the player before the first message
        player = processes.start("replay", ["roslaunch", "teleteach", "replay.launch", f"bag:={recorded}", "delay:=3"])
        player.wait(120)
        processes.stop("record")
        replay_log = processes.log("replay")
    assert "--topics /sigma7/pose /sigma7/twist /sigma7/gripper_angle /sigma7/button" in replay_log, replay_log
    replayed = the_bag(data_dir, "replayed")

    # The replay fed exactly the recorded device input into the fresh system
    original_stream, replayed_stream = device_stream(recorded), device_stream(replayed)
    assert len(original_stream["/sigma7/pose"]) > 0.5 * 15.5 * DEVICE_RATE  # (rospy.Rate lags on a busy machine)
    for topic in original_stream:
        np.testing.assert_array_equal(original_stream[topic], replayed_stream[topic], err_msg=topic)

    # The session did teach something: START -> HIGH-LEVEL -> START -> LOW-LEVEL -> START, one node removed,
    # a stiffness ellipsoid shaped and held
    tabs, edits, eigenvalues, eigenvectors = teaching_outcome(recorded)
    assert tabs == [0, 1, 0, 2, 0]
    assert len(edits) == 1 and len(edits[0][0]) == 1 and edits[0][1] == ()
    assert len(eigenvalues) == 3 and max(max(row) for row in eigenvalues) > 2000.0
    # Expect the same outcome from the replay
    assert teaching_outcome(replayed) == (tabs, edits, eigenvalues, eigenvectors)

    report = make_report(recorded, tmp_path / "report")
    assert sorted(report.figures) == ["high_level.png", "rotation.png", "stiffness.png"]
    assert [edit.removed for edit in report.edits] == [edits[0][0]]
    shutil.copytree(tmp_path / "report", artifacts_dir / "report_recorded_session", dirs_exist_ok=True)


def test_replay_of_a_foreign_file_fails_with_one_line(tmp_path):
    foreign = tmp_path / "notes.bag"
    foreign.write_text("hello\n")
    result = subprocess.run(
        [str(ROOT / "nodes" / "session_bag"), "replay", str(foreign)], capture_output=True, text=True
    )
    assert result.returncode == 2
    assert result.stderr.strip() == f"session_bag: {foreign} is not a ROS 1 bag (it does not start with '#ROSBAG V2.0')"
