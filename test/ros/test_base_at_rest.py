"""RosRobot.base_at_rest over a real roscore, with a robot whose clock runs ahead of the one the skill server hears
(a loaded skill server): the base's pose is read only once its own transforms say it stands still, and the scene
used afterwards is one published after that."""

from ros_processes import run_probe

# The robot: /clock lags its stamps by LAG (the skill server hears time late); the base drives along x at 0.1 m/s
# until robot time 2 s, then stands at x = 0.2 m; the scene (10 Hz) says nothing between robot time 1.9 s and 2.6 s.
PROBE = """
import threading, time
import rospy, tf2_ros
from geometry_msgs.msg import TransformStamped
from rosgraph_msgs.msg import Clock
from visualization_msgs.msg import MarkerArray
from teleteach.core.observed import observed_from_scene
from teleteach.core.observed import scene_markers
from teleteach.core.scene import load_scene
from teleteach.skills.ros import RosRobot

LAG = 0.5
rospy.set_param("/use_sim_time", True)
rospy.init_node("rest_probe")
clock = rospy.Publisher("/clock", Clock, queue_size=10)
scene_topic = rospy.Publisher("teleteach/scene", MarkerArray, queue_size=1, latch=True)
broadcaster = tf2_ros.TransformBroadcaster()
observed = observed_from_scene(load_scene())

def robot():
    started, published_scene = time.monotonic(), -1.0
    while not rospy.is_shutdown():
        stamp = round(time.monotonic() - started, 3)
        clock.publish(Clock(clock=rospy.Time.from_sec(max(stamp - LAG, 0.0) + 1e-3)))
        transform = TransformStamped()
        transform.header.stamp, transform.header.frame_id = rospy.Time.from_sec(stamp), "world"
        transform.child_frame_id = "base_link"
        transform.transform.translation.x = 0.1 * min(stamp, 2.0)
        transform.transform.rotation.w = 1.0
        broadcaster.sendTransform(transform)
        if stamp - published_scene >= 0.1 and not 1.9 <= stamp < 2.6:
            scene_topic.publish(scene_markers(observed, stamp))
            published_scene = stamp
        time.sleep(0.01)

threading.Thread(target=robot, daemon=True).start()
rosrobot = RosRobot("position_joint_trajectory_controller", idle_after=60.0)
while rospy.get_time() < 1.0:
    time.sleep(0.01)
x, _, _ = rosrobot.base_at_rest()
print("at rest", round(x, 3))
print("scene after rest", rosrobot.observed_scene().stamp >= 2.6)
rospy.signal_shutdown("probe done")
"""


def test_the_base_is_read_once_it_stands_still_and_the_scene_after_that(tmp_path):
    probe = run_probe(tmp_path, PROBE)
    assert probe.returncode == 0, probe.stdout + probe.stderr
    # Expect: the pose where the base stopped (not one from the drive, 0.1 to 0.15 m), and a scene from after it
    assert probe.stdout.splitlines() == ["at rest 0.2", "scene after rest True"], probe.stdout + probe.stderr
