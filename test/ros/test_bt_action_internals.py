"""The rospy internals that teleteach.bt.ros.ActionClients reads (why: see its docstring), pinned against the installed
rospy and actionlib: a real action server and client in one node over a real roscore."""

from ros_processes import run_probe

PROBE = """
import actionlib, rospy
from teleteach.bt.ros import ActionClients
from teleteach.msg import ExecuteSkillAction
rospy.init_node("internals_probe")
server = actionlib.SimpleActionServer("/skills/Probe", ExecuteSkillAction, lambda goal: None, auto_start=False)
server.start()
clients = ActionClients("/skills")
client = clients.get("Probe")
assert client.wait_for_server(rospy.Duration(30.0)), "the server never connected"
print("ready", ActionClients.ready(client), clients.missing())
print("server", ActionClients.server_id(client))
print("connected", ActionClients.connected_to(client, "/internals_probe"), ActionClients.connected_to(client, "/other"))
rospy.signal_shutdown("probe done")  # ends the action server's thread, so the process exits
"""


def test_action_clients_read_who_serves_a_skill_and_whether_it_is_still_connected(tmp_path):
    probe = run_probe(tmp_path, PROBE)
    assert probe.returncode == 0, probe.stdout + probe.stderr
    # Expect: a connected server is ready and named by its node, and only that node counts as connected
    assert probe.stdout.splitlines() == ["ready True []", "server /internals_probe", "connected True False"]
