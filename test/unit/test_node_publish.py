"""node.publish during a shutdown: rospy closes every topic in a pre-shutdown hook, before is_shutdown() turns true,
and a timer that fires in that window must stay quiet (CI saw the GUI's 'publish() to a closed topic' at Ctrl-C)."""

import subprocess
import sys

# In a child process: rospy's shutdown is global and one-way. No master: the node is marked initialised, as
# init_node leaves it. The hook runs where the GUI's timers raced: topics closed, is_shutdown() still false. rospy
# prints a hook's exception as a traceback on stderr.
SHUTDOWN_RACE = """
import rospy
import rospy.core
from std_msgs.msg import String
from teleteach.runtime.node import publish

rospy.core.set_initialized(True)
publisher = rospy.Publisher("/gui_send_race", String, queue_size=1)
def closed_then_published(reason):
    publisher.impl.close()
    assert not rospy.is_shutdown()
    publish(publisher, String(data="late"))
    print("sent quietly")
rospy.core.add_preshutdown_hook(closed_then_published)
rospy.signal_shutdown("test")
"""

# Outside a shutdown a closed topic is a fault: it must still be loud.
CLOSED_WITHOUT_SHUTDOWN = """
import rospy
import rospy.core
from std_msgs.msg import String
from teleteach.runtime.node import publish

rospy.core.set_initialized(True)
publisher = rospy.Publisher("/gui_send_closed", String, queue_size=1)
publisher.impl.close()
publish(publisher, String(data="lost"))
"""


def run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


def test_a_publish_while_rospy_closes_the_topics_is_dropped_quietly():
    result = run(SHUTDOWN_RACE)
    assert "Traceback" not in result.stderr, result.stderr
    assert "sent quietly" in result.stdout, result.stdout + result.stderr


def test_a_publish_to_a_closed_topic_outside_a_shutdown_raises():
    result = run(CLOSED_WITHOUT_SHUTDOWN)
    assert result.returncode != 0
    assert "publish() to a closed topic" in result.stderr, result.stderr
