"""A robot_sim that follows another one's /clock (``clock:=follow``, docs/reference.md: namespaces), over a real
roscore: it steps its world up to /clock, takes commands stamped with /clock while it keeps up, and once it has
fallen behind by more than the commands' max_age it rejects them and says so on ~rejected (nothing reaches its arm)."""

import re
import subprocess
import sys

from conftest import ROOT
from ros_processes import Processes, start_roscore

# The leader: /clock from 1 s, 10 ms per 10 ms of wall time. A command stamped with /clock while the follower keeps
# up, then /clock jumps 300 s ahead (far more than the follower can step at once) and a command stamped with it.
PROBE = """
import time
import rospy
from geometry_msgs.msg import Vector3Stamped
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import String

rospy.init_node("leader_probe")
clock = rospy.Publisher("/clock", Clock, queue_size=1)
eigenvalues = rospy.Publisher("/eigenvalues", Vector3Stamped, queue_size=10)
rejections, follower = [], []
rospy.Subscriber("/robot_sim/rejected", String, lambda message: rejections.append(message.data))
rospy.Subscriber("/joint_states", JointState, lambda message: follower.append(message.header.stamp.to_sec()))
now = 1.0

def advance(seconds):
    global now
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        now += 0.01
        clock.publish(Clock(clock=rospy.Time.from_sec(now)))
        time.sleep(0.01)

def command():
    message = Vector3Stamped()
    message.header.stamp = rospy.Time.from_sec(now)
    message.vector.x = message.vector.y = message.vector.z = 500.0
    eigenvalues.publish(message)

deadline = time.monotonic() + 60
while not follower or eigenvalues.get_num_connections() == 0:
    advance(0.1)
    assert time.monotonic() < deadline, "the follower never published its joint states"
advance(2.0)
print("keeping up", abs(follower[-1] - now) < 0.5)
command()
advance(1.0)
print("rejected while keeping up", rejections)
now += 300.0
advance(0.5)
command()
advance(2.0)
print("behind by more than 100 s", now - follower[-1] > 100.0)
print("rejected once behind", rejections)
"""


def test_a_follower_takes_commands_while_it_keeps_up_and_rejects_them_once_behind(tmp_path):
    with Processes(tmp_path) as processes:
        start_roscore(processes)
        subprocess.run(["rosparam", "set", "/use_sim_time", "true"], env=processes.env, check=True)
        processes.start("robot_sim", [str(ROOT / "nodes" / "robot_sim"), "_clock:=follow"])
        probe = subprocess.run(
            [sys.executable, "-c", PROBE],
            env=processes.env,
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
        lines = probe.stdout.splitlines()
        assert probe.returncode == 0 and len(lines) == 4, probe.stdout + probe.stderr + processes.log("robot_sim")
        assert lines[0] == "keeping up True", lines
        assert lines[1] == "rejected while keeping up []", lines
        assert lines[2] == "behind by more than 100 s True", lines
        # Expect: the command from 300 s ahead rejected as such (the follower's time minus its stamp)
        ages = re.findall(
            r"/eigenvalues: stale stamp: ([-+0-9.]+) s away from the current time \(limit 1.000 s\)", lines[3]
        )
        assert len(ages) == 1 and -300.5 < float(ages[0]) < -290.0, lines
