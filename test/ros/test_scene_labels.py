"""scene_labels as rviz.launch starts it, on a real master: a scene published on teleteach/scene comes back on
teleteach/scene_rviz with no name in a shape's text and one label per object, to a subscriber that came after the
scene (RViz started later) and again for each new scene; an object that is no object (NaN) is drawn without a label
and named in one warning, and the node keeps running."""

import json
import subprocess
import sys

from ros_processes import Processes, start_roscore, wait_until

PROBE = r"""
import json, math
import rospy
from std_msgs.msg import Header
from visualization_msgs.msg import MarkerArray
from teleteach.core.observed import PRODUCTS, SCENE_TOPIC, box_marker, observed_from_scene, scene_markers
from teleteach.core.scene import load_objects
from teleteach.viz.scene import SCENE_RVIZ_TOPIC

rospy.init_node("scene_probe", anonymous=True)
scene = rospy.Publisher(SCENE_TOPIC, MarkerArray, queue_size=1, latch=True)
header = Header(frame_id="world")
shelf = [box_marker(header, "shelf", 0, (2.175, 0.0, 0.29), (0, 0, 0, 1), (0.35, 1.2, 0.02), (0.5, 0.4, 0.2, 1), "b")]
scene.publish(scene_markers(observed_from_scene(load_objects()), 1.0, shelf))
deadline = rospy.Time.now() + rospy.Duration(60.0)
while scene.get_num_connections() == 0 and rospy.Time.now() < deadline:
    rospy.sleep(0.1)
rospy.sleep(1.0)  # the latched scene reaches scene_labels before anyone listens to scene_rviz
received = []
rviz = rospy.Subscriber(SCENE_RVIZ_TOPIC, MarkerArray, received.append, queue_size=10)
while not received and rospy.Time.now() < deadline:
    rospy.sleep(0.1)
first = received[0]
broken = box_marker(header, PRODUCTS, 99, (math.nan, 0, 0.5), (0, 0, 0, 1), (0.06, 0.05, 0.14), (1, 0, 0, 1), "broken")
kept = box_marker(header, PRODUCTS, 0, (0.6, 0.0, 0.5), (0, 0, 0, 1), (0.06, 0.05, 0.14), (1, 0, 0, 1), "kept")
scene.publish(MarkerArray(markers=[kept, broken]))
while not any(len(message.markers) == 4 for message in received) and rospy.Time.now() < deadline:
    rospy.sleep(0.1)
second = [message for message in received if len(message.markers) == 4][:1]
after = box_marker(header, PRODUCTS, 1, (0.7, 0.0, 0.5), (0, 0, 0, 1), (0.06, 0.05, 0.14), (1, 0, 0, 1), "after")
scene.publish(MarkerArray(markers=[after]))  # the node lives on after the broken object
while not any(len(message.markers) == 2 for message in received) and rospy.Time.now() < deadline:
    rospy.sleep(0.1)
third = [message for message in received if len(message.markers) == 2][:1]
print(json.dumps([
    [[m.ns, m.id, m.type, m.action, m.text] for m in message.markers] for message in [first] + second + third
]))
"""


def test_the_scene_comes_back_for_rviz_with_labels_and_a_broken_object_without_one(tmp_path):
    with Processes(tmp_path / "logs") as processes:
        start_roscore(processes)
        launch = processes.start(
            "rviz_launch", ["roslaunch", "teleteach", "rviz.launch", "rviz:=false", "ellipsoid:=false"]
        )
        probe = subprocess.run(
            [sys.executable, "-c", PROBE], env=processes.env, capture_output=True, text=True, timeout=120
        )
        assert probe.returncode == 0, probe.stderr + processes.log("rviz_launch")
        wait_until(lambda: "no label for" in processes.log("rviz_launch"), 30, "the warning about the broken object")
        ping = subprocess.run(
            ["rosnode", "ping", "-c", "1", "/scene_labels"],
            env=processes.env,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert launch.poll() is None and "xmlrpc reply from" in ping.stdout, ping.stdout + processes.log("rviz_launch")
        log = processes.log("rviz_launch")
    first, second, third = json.loads(probe.stdout.strip().splitlines()[-1])
    # Expect the whole scene file's scene: 48 objects, each shape without text and followed by its label; the shelf
    # board drawn without one
    shapes = [marker for marker in first if marker[2] != 9]
    labels = [marker for marker in first if marker[2] == 9]
    assert len(shapes) == 49 and {text for *_, text in shapes} == {""}
    assert len(labels) == 48 and {"product_pick_1", "gap_1", "pick_table", "counter_board"} <= {m[4] for m in labels}
    assert first[0][0] == "shelf" and first[1][0] != "shelf/names"
    for shape, label in zip(first[1::2], first[2::2]):
        assert label[:2] == [f"{shape[0]}/names", shape[1]] and label[4]
    # Expect the new scene: the kept product labelled, the broken one drawn without text, its label deleted
    assert second == [
        ["products", 0, 1, 0, ""],
        ["products/names", 0, 9, 0, "kept"],
        ["products", 99, 1, 0, ""],
        ["products/names", 99, 0, 2, ""],
    ]
    # Expect the next scene drawn as well: the broken object ended nothing
    assert third == [["products", 1, 1, 0, ""], ["products/names", 1, 9, 0, "after"]]
    # Expect one warning naming the broken object, no error
    assert "scene_labels: no label for products marker 'broken': position" in log, log
    assert "[ERROR]" not in log and "Traceback" not in log, log
