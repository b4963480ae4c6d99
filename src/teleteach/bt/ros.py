"""The ROS layer of the teaching tree (py_trees_ros conventions, for ROS 1 where py_trees_ros is not available).

:class:`ActionSkill` leaves are actionlib clients of ``/skills/<Skill>`` (demonstrated skills: ``/skills/ReplaySkill``
with ``parameters`` = yaml ``{data_file, kind}``). :class:`BehaviourTreeNode` ticks a
:class:`~teleteach.bt.teaching.TeachingTree`, serves ``/change_tree`` and ``/behaviour_tree/add_skill``, listens to
``/behaviour_tree/pause`` and publishes the latched topics of the ROS graph (docs/reference.md) after each tick that
changed something.
"""

import dataclasses
import io
import struct
import time
import typing

import actionlib
import py_trees
import rospy
import yaml
from actionlib_msgs.msg import GoalStatus
from py_trees.common import Status
from std_msgs.msg import Bool, String
from std_srvs.srv import Trigger, TriggerResponse

from teleteach.bt.behaviours import SkillLeaf
from teleteach.bt.decisions import TaskKnowledge
from teleteach.bt.library import SkillEntry, SkillLibrary
from teleteach.bt.teaching import Execution, NodeRecord, TeachingTree, TreeStore
from teleteach.bt.tree import load_tree
from teleteach.bt.tree_policy import PolicyConfig, TreePolicy
from teleteach.core import datadir
from teleteach.core.parameters import from_mapping
from teleteach.core.paths import config_file, config_values
from teleteach.core.scene import load_scene
from teleteach.msg import (
    Behaviour,
    BehaviourTree,
    ExecuteSkillAction,
    ExecuteSkillGoal,
    HelpRequest,
    TreeExecution,
)
from teleteach.msg import (
    SkillLibrary as SkillLibraryMsg,
)
from teleteach.runtime.node import node_parameters, server_value
from teleteach.runtime.ros_actions import server_ready
from teleteach.srv import AddSkill, AddSkillResponse, ChangeTree, ChangeTreeResponse

REPLAY_SKILL = "ReplaySkill"
_STATUS = {
    Status.INVALID: Behaviour.INVALID,
    Status.RUNNING: Behaviour.RUNNING,
    Status.SUCCESS: Behaviour.SUCCESS,
    Status.FAILURE: Behaviour.FAILURE,
}
_TYPE = {
    "selector": Behaviour.SELECTOR,
    "sequence": Behaviour.SEQUENCE,
    "parallel": Behaviour.PARALLEL,
    "retry": Behaviour.DECORATOR,
    "timeout": Behaviour.DECORATOR,
    "inverter": Behaviour.DECORATOR,
    "pause": Behaviour.BEHAVIOUR,
    "skill": Behaviour.BEHAVIOUR,
}


RUNNING_PARAM = "~running"  # set while the node runs: found at start, the previous process crashed


class PreserializedTree(BehaviourTree):
    """A BehaviourTree message whose behaviours are already serialised (one cached bytes block per node).

    Serialising 1000 Behaviour messages field by field holds the GIL for ~10 ms; unchanged nodes keep their bytes,
    so publishing costs little more than the nodes that changed. On the wire it is a plain teleteach/BehaviourTree.
    """

    __slots__ = ("parts",)

    def __init__(self, parts: typing.List[bytes]):
        super().__init__()
        self.parts = parts

    def serialize(self, buff: typing.BinaryIO) -> None:
        """Header and array length as genpy writes them, then the cached behaviours."""
        head = io.BytesIO()
        BehaviourTree(header=self.header).serialize(head)
        buff.write(head.getvalue()[:-4])  # drop the empty array's length
        buff.write(struct.pack("<I", len(self.parts)))
        buff.write(b"".join(self.parts))


class ActionClients:
    """One actionlib client per skill server, shared by all leaves of that skill (each leaf has its own goal).

    Which node serves a skill, and whether that very node is still connected, is not in actionlib's or rospy's public
    API: it is read from rospy's connection objects (``Publisher.impl.has_connection``, ``Subscriber.impl.connections``
    and their ``callerid_pub``) and the messages' ``_connection_header``, as ``ActionClient.wait_for_server`` itself
    does. It is worth it: a respawned server is a different node that has forgotten the goal, and only the caller id
    tells it apart. test/ros/test_bt_action_internals.py pins that layout against the installed rospy.
    """

    def __init__(self, namespace: str = "skills"):
        self.namespace = rospy.resolve_name(namespace.rstrip("/"))  # relative: in the node's namespace (/skills)
        self._clients: typing.Dict[str, actionlib.ActionClient] = {}

    def get(self, server: str) -> actionlib.ActionClient:
        """The client of ``<namespace>/<server>``, created on first use."""
        if server not in self._clients:
            self._clients[server] = actionlib.ActionClient(f"{self.namespace}/{server}", ExecuteSkillAction)
        return self._clients[server]

    def missing(self) -> typing.List[str]:
        """The servers (of the clients made so far) that are not connected yet."""
        return [server for server, client in self._clients.items() if not self.ready(client)]

    ready = staticmethod(server_ready)  # whether the server is connected, without waiting

    @staticmethod
    def server_id(client: actionlib.ActionClient) -> str:
        """The node name of the server whose status the client heard last ("" before any)."""
        status = client.last_status_msg
        return "" if status is None else status._connection_header["callerid"]

    @staticmethod
    def connected_to(client: actionlib.ActionClient, server_id: str) -> bool:
        """Whether the server node still sends its goal status (the connection closes when it dies, even by SIGKILL)."""
        return any(c.callerid_pub == server_id for c in client.status_sub.impl.connections)


@dataclasses.dataclass(frozen=True)
class BehaviourTreeConfig:
    """The node's parameters: config/behaviour_tree.yaml's keys (the one place of their values and meanings)."""

    tree: str
    skills: str
    data_dir: str
    resume: bool
    tick_rate: float
    skill_namespace: str
    startup_timeout: float
    server_timeout: float
    lost_timeout: float
    clock_timeout: float
    start_paused: bool
    pause_preempt_after: float

    @classmethod
    def from_mapping(cls, values: typing.Mapping[str, typing.Any]) -> "BehaviourTreeConfig":
        """From the yaml's keys; a missing or unknown one is named."""
        return from_mapping(cls, values, "behaviour_tree's parameters (config/behaviour_tree.yaml)")

    @classmethod
    def from_yaml(cls) -> "BehaviourTreeConfig":
        """The yaml's values, as a node started without parameters has them."""
        return cls.from_mapping(yaml.safe_load(config_file("behaviour_tree.yaml").read_text()))

    @classmethod
    def from_params(cls) -> "BehaviourTreeConfig":
        """The yaml's keys, each overridden by its private parameter."""
        return cls.from_mapping(node_parameters("behaviour_tree.yaml"))


class ActionSkill(SkillLeaf):
    """A leaf that executes its skill as an action goal: sent in initialise, polled in update, cancelled on interrupt.

    A server that is not up within ``server_timeout`` seconds fails the skill with a message (never blocks a tick).
    Once the goal is out, the skill fails (so the tree asks for help instead of waiting forever) when the server's
    connection is gone for ``lost_timeout`` seconds (its process died), or when the simulated clock stood still for
    ``clock_timeout`` seconds (the simulator died: the server can neither move the robot nor time out). All
    timeouts are wall time.

    Args:
        name: unique leaf name
        entry: the library skill
        clients: the shared action clients
        config: the node's parameters, of which the three timeouts [s]: how long to wait for the server before
            failing, how long the server may be disconnected while it runs the goal, how long the ROS clock may
            stand still (simulated time only) while the goal runs
    """

    def __init__(self, name: str, entry: SkillEntry, clients: ActionClients, config: BehaviourTreeConfig):
        super().__init__(name, entry.name, entry.kind, entry.data_file)
        self.clients = clients
        self.server_timeout = config.server_timeout
        self.lost_timeout = config.lost_timeout
        self.clock_timeout = config.clock_timeout
        self.problem = entry.problem
        self.server = REPLAY_SKILL if entry.demonstrated else entry.name
        self.goal = ExecuteSkillGoal(skill=entry.name)
        if entry.demonstrated:
            self.goal.parameters = yaml.safe_dump({"data_file": entry.data_file, "kind": entry.kind})
        self.goal_handle: typing.Optional[actionlib.ClientGoalHandle] = None
        self.started_at = 0.0
        self.progress = ""
        self.goal_server_id = ""
        self.connected_at = 0.0
        self.clock_moved_at = (0.0, 0.0)  # (wall time, ROS time) when the ROS clock last advanced

    def start(self) -> None:
        """Remember when we asked; the goal leaves as soon as the server is connected (see :meth:`poll`)."""
        if self.parameters:
            self.goal.parameters = yaml.safe_dump(self.parameters)
        self.goal_handle = None
        self.progress = ""
        self.started_at = time.monotonic()

    def poll(self) -> typing.Tuple[Status, str]:
        """Send the goal once the server is up, then follow it."""
        server = f"{self.clients.namespace}/{self.server}"
        if self.problem:
            return Status.FAILURE, f"{self.skill} is unavailable: {self.problem}"
        if self.goal_handle is None:
            client = self.clients.get(self.server)
            if ActionClients.ready(client):
                self.goal_handle = client.send_goal(self.goal, feedback_cb=self._feedback)
                self.goal_server_id = ActionClients.server_id(client)
                self.connected_at = time.monotonic()
                self.clock_moved_at = (self.connected_at, rospy.get_time())
                return Status.RUNNING, f"goal sent to {server}"
            waited = time.monotonic() - self.started_at
            if waited > self.server_timeout:
                return Status.FAILURE, f"no action server {server} (waited {waited:.1f} s)"
            return Status.RUNNING, f"waiting for {server}"
        if self.goal_handle.get_comm_state() != actionlib.CommState.DONE:
            lost = self._lost(server)
            if lost:
                self.goal_handle = None
                return Status.FAILURE, lost
            return Status.RUNNING, self.progress or f"{self.skill} running"
        state = self.goal_handle.get_goal_status()
        result = self.goal_handle.get_result()
        message = (result.message if result is not None else "") or self.goal_handle.get_goal_status_text()
        if state == GoalStatus.SUCCEEDED and result is not None and result.success:
            return Status.SUCCESS, message or f"{self.skill} done"
        state_name = GoalStatus.to_string(state) if hasattr(GoalStatus, "to_string") else str(state)
        return Status.FAILURE, message or f"{self.skill} ended in state {state_name}"

    def _lost(self, server: str) -> str:
        """Why the running goal can no longer finish (server gone, clock stopped), or "" while it can."""
        now = time.monotonic()
        last = f" (last: {self.progress})" if self.progress else ""
        client = self.clients.get(self.server)
        if ActionClients.connected_to(client, self.goal_server_id):
            self.connected_at = now
        elif now - self.connected_at > self.lost_timeout:
            return f"lost the skill server {self.goal_server_id} of {server} while {self.skill} was running{last}"
        ros_time = rospy.get_time()
        if ros_time != self.clock_moved_at[1] or rospy.rostime.is_wallclock():
            self.clock_moved_at = (now, ros_time)
        elif now - self.clock_moved_at[0] > self.clock_timeout:
            stopped = now - self.clock_moved_at[0]
            return (
                f"the simulated clock (/clock) stopped {stopped:.0f} s ago while {self.skill} was running{last}:"
                " is robot_sim running?"
            )
        return ""

    def goal_out(self) -> bool:
        """Whether a goal was sent and its server has not confirmed an end yet (succeeded, aborted, preempted)."""
        return self.goal_handle is not None and self.goal_handle.get_comm_state() != actionlib.CommState.DONE

    def finished_before_preempt(self) -> bool:
        """Whether the server reports the preempted goal as succeeded (it ended before the cancel reached it)."""
        handle = self.goal_handle
        if handle is None or handle.get_comm_state() != actionlib.CommState.DONE:
            return False
        result = handle.get_result()
        return handle.get_goal_status() == GoalStatus.SUCCEEDED and result is not None and result.success

    def cancel(self) -> None:
        """Cancel the goal if it is out."""
        if self.goal_handle is not None and self.goal_handle.get_comm_state() != actionlib.CommState.DONE:
            self.goal_handle.cancel()

    def _feedback(self, _handle: actionlib.ClientGoalHandle, feedback: typing.Any) -> None:
        self.progress = f"{self.skill}: {feedback.phase} ({100.0 * feedback.progress:.0f} %)"


class BehaviourTreeNode:
    """Ticks the teaching tree and connects it to ROS.

    Args:
        tree: the teaching tree
        config: the node's parameters: its tick rate [Hz], and how long before the first tick to wait for the skill
            servers to connect (``startup_timeout`` [s]: they start with the robot; py_trees_ros' setup timeout).
            Servers still missing then fail their skills when run.
        clients: the action clients of the skill servers

    ROS Publishers (all latched):
        * **/behaviour_tree/log/tree** (teleteach/BehaviourTree): every node with ids, type, status, message
        * **/behaviour_tree/tip** (teleteach/Behaviour): the deepest running node
        * **/behaviour_tree/ascii/tree**, **/behaviour_tree/ascii/snapshot**, **/behaviour_tree/dot/tree**
          (std_msgs/String): py_trees.display renderings (made only while somebody subscribes)
        * **/behaviour_tree/skill_library** (teleteach/SkillLibrary)
        * **/behaviour_tree/help_request** (teleteach/HelpRequest): empty node_name once answered; a remembered
          repair of the same failure in ``suggestion``; the tree policy's ``proposal`` with its ``confidence`` and
          ``why``, ``applied`` when the robot applied it alone (an undo vetoes it within ``veto_window`` seconds)
        * **/behaviour_tree/execution** (teleteach/TreeExecution): running, waiting to start, pausing (a goal still
          out), paused (the arm is free) or completed

    ROS Subscribers:
        * **/behaviour_tree/pause** (std_msgs/Bool): writes the blackboard's pause flag (once the tree was started)

    ROS Services:
        * **/change_tree** (teleteach/ChangeTree), **/behaviour_tree/add_skill** (teleteach/AddSkill)
        * **/behaviour_tree/start** (std_srvs/Trigger): the operator's start of a tree that waits for it
          (``start_paused``); an event, not the latched pause flag, so a restarted tree still waits
    """

    def __init__(self, tree: TeachingTree, config: BehaviourTreeConfig, clients: typing.Optional[ActionClients] = None):
        self.tree = tree
        self.tick_rate = config.tick_rate
        self.clients = clients
        self.startup_timeout = config.startup_timeout
        latched = {"queue_size": 1, "latch": True}
        self.log_publisher = rospy.Publisher("behaviour_tree/log/tree", BehaviourTree, **latched)
        self.tip_publisher = rospy.Publisher("behaviour_tree/tip", Behaviour, **latched)
        self.ascii_tree_publisher = rospy.Publisher("behaviour_tree/ascii/tree", String, **latched)
        self.snapshot_publisher = rospy.Publisher("behaviour_tree/ascii/snapshot", String, **latched)
        self.dot_publisher = rospy.Publisher("behaviour_tree/dot/tree", String, **latched)
        self.library_publisher = rospy.Publisher("behaviour_tree/skill_library", SkillLibraryMsg, **latched)
        self.help_publisher = rospy.Publisher("behaviour_tree/help_request", HelpRequest, **latched)
        self.execution_publisher = rospy.Publisher("behaviour_tree/execution", TreeExecution, **latched)
        self._published_execution: typing.Optional[Execution] = None
        self._published_library = -1
        self._published_help: typing.Any = ()
        self._structure_rendered = {self.ascii_tree_publisher: -1, self.dot_publisher: -1}
        self._snapshot_dirty = True
        self._messages: typing.Dict[str, typing.Tuple[NodeRecord, bytes]] = {}
        self._fresh_messages: typing.Dict[str, typing.Tuple[NodeRecord, bytes]] = {}
        rospy.Subscriber("behaviour_tree/pause", Bool, self._on_pause, queue_size=10)
        self.change_service = rospy.Service("change_tree", ChangeTree, self._on_change_tree)
        self.add_skill_service = rospy.Service("behaviour_tree/add_skill", AddSkill, self._on_add_skill)
        self.start_service = rospy.Service("behaviour_tree/start", Trigger, self._on_start)

    @classmethod
    def from_params(cls) -> "BehaviourTreeNode":
        """Build from the private parameters (defaults: config/behaviour_tree.yaml; see launch/bt.launch).

        A node that finds ``~running`` set on the master is a restart after a crash (roslaunch's respawn): it
        resumes what was taught, whatever ``~resume`` says. A clean shutdown clears the flag.
        """
        config = BehaviourTreeConfig.from_params()
        library = SkillLibrary.load(config.skills or config_file("skills.yaml"))
        spec = load_tree(config.tree or config_file("tree.yaml"), library)
        data_root = datadir.data_dir(config.data_dir)
        # a tree in a namespace (one of two robots on a master) keeps its own files: trees/<namespace>/
        store = TreeStore(data_root / "trees" / rospy.get_namespace().strip("/"))
        if _claim_running_flag() or config.resume:
            spec, library = _resumed(store, spec, library)
        clients = ActionClients(config.skill_namespace)
        for server in [entry.name for entry in library if not entry.demonstrated] + [REPLAY_SKILL]:
            clients.get(server)  # connect early: the first goal of each skill leaves without waiting

        def make_leaf(name: str, entry: SkillEntry) -> ActionSkill:
            return ActionSkill(name, entry, clients, config)

        repairs, problems = store.restore_repairs()
        if problems:
            rospy.logwarn("behaviour_tree: the remembered repairs could not all be loaded: %s", problems)
        tree = TeachingTree(
            spec,
            library,
            make_leaf,
            store=store,
            data_root=data_root,
            repairs=repairs,
            policy=_restored_policy(store),
            task=TaskKnowledge(load_scene(), config_values("skills_motion.yaml", "skills")),
            start_paused=config.start_paused,
            preempt_after=config.pause_preempt_after,
            clock=rospy.get_time,  # in simulation the simulated: the veto window counts from the request's stamp
        )
        if not tree.started:
            rospy.loginfo(
                "behaviour_tree: started paused: nothing runs until the operator starts the tree (GUI START: handle"
                " centred, click; or rosservice call /behaviour_tree/start)"
            )
        return cls(tree, config, clients)

    def spin(self) -> None:
        """Tick at the tick rate (wall time) until shutdown, publishing whatever changed.

        Wall time, not ROS time: when the simulator dies its clock stops, and the tree must still tick to notice
        (its leaves fail, the operator is asked for help).
        """
        rospy.on_shutdown(self._stop_skills)
        self.publish(changed=True)
        self._wait_for_skill_servers()
        period = 1.0 / self.tick_rate
        next_tick = time.monotonic()
        while not rospy.is_shutdown():
            try:
                self.publish(changed=self.tree.tick())
            except Exception:  # Ctrl-C closed the topics, or stopped the skills, in the middle of this tick
                if rospy.is_shutdown():
                    break
                raise
            next_tick = max(next_tick + period, time.monotonic())
            time.sleep(max(0.0, next_tick - time.monotonic()))
        if self.tree.store is not None:
            self.tree.store.flush()

    def _stop_skills(self) -> None:
        """Cancel the running skill's goal: rospy runs this first on shutdown, while the cancel topic is still open."""
        with self.tree.lock:
            self.tree.tree.interrupt()

    def _wait_for_skill_servers(self) -> None:
        """Hold the first tick until every skill server is connected, for at most ``startup_timeout`` (wall time).

        Edits, pause and add_skill are served meanwhile; the tree just does not start before the robot is up.
        """
        if self.clients is None or self.startup_timeout <= 0.0:
            return
        deadline = time.monotonic() + self.startup_timeout
        missing = self.clients.missing()
        if missing:
            servers = ", ".join(missing)
            rospy.loginfo("behaviour_tree: waiting up to %.0f s for skill servers %s", self.startup_timeout, servers)
        published = self.tree.revision
        while missing and time.monotonic() < deadline and not rospy.is_shutdown():
            time.sleep(0.1)
            self.publish(changed=self.tree.revision != published)
            published = self.tree.revision
            missing = self.clients.missing()
        if missing:
            rospy.logwarn("behaviour_tree: starting without %s; their skills fail when run", ", ".join(missing))

    def publish(self, changed: bool) -> None:
        """Publish the topics whose content changed (heavy renderings only for subscribers)."""
        revision = self.tree.revision
        if changed:
            self._publish_tree_log()
        if self._snapshot_dirty and self.snapshot_publisher.get_num_connections() > 0:
            self.snapshot_publisher.publish(String(data=self._render_snapshot()))
            self._snapshot_dirty = False
        self._publish_structure(revision)
        if self.tree.library_revision != self._published_library:
            self._publish_library()
        execution = self.tree.execution_state()
        if execution != self._published_execution:
            self._publish_execution(execution)
        help_request = self.tree.help_request
        if help_request != self._published_help:
            self._publish_help(help_request)

    def _publish_tree_log(self) -> None:
        """Publish every node and the tip after a tick that changed them, and mark the snapshot as stale."""
        records, tip = self.tree.records()
        self._fresh_messages = {}
        stamp = rospy.Time.now()
        message = PreserializedTree([self._bytes_of(record) for record in records])
        message.header.stamp = stamp
        self._messages = self._fresh_messages
        self.log_publisher.publish(message)
        self.tip_publisher.publish(_behaviour(tip) if tip is not None else Behaviour())
        self._snapshot_dirty = True

    def _publish_structure(self, revision: int) -> None:
        """Render the ascii and dot trees of ``revision`` only for subscribers that lack it: rendering is slow."""
        tree = self.tree
        for publisher, render in (
            (self.ascii_tree_publisher, lambda: py_trees.display.ascii_tree(tree.root)),
            (self.dot_publisher, lambda: py_trees.display.dot_tree(tree.root).to_string()),
        ):
            if self._structure_rendered[publisher] != revision and publisher.get_num_connections() > 0:
                with tree.lock:
                    text = render()
                publisher.publish(String(data=text))
                self._structure_rendered[publisher] = revision

    def _publish_library(self) -> None:
        """Publish the skill library, so the GUI and the skill servers know the skills the tree has now."""
        self._published_library = self.tree.library_revision
        entries = self.tree.library_entries()
        library = SkillLibraryMsg(
            names=[entry.name for entry in entries],
            kinds=[entry.kind for entry in entries],
            data_files=[entry.data_file for entry in entries],
            problems=[entry.problem for entry in entries],
        )
        library.header.stamp = rospy.Time.now()
        self.library_publisher.publish(library)

    def _publish_execution(self, execution: Execution) -> None:
        """Publish whether the tree runs, waits, pauses or is done, so the operator knows when the arm is free."""
        self._published_execution = execution
        state = TreeExecution(state=int(execution.state), skill=execution.skill, message=execution.message)
        state.header.stamp = rospy.Time.now()
        self.execution_publisher.publish(state)

    def _publish_help(self, help_request: typing.Any) -> None:
        """Publish the failure the operator is asked to repair (empty once answered), and log it."""
        if help_request is None and getattr(self._published_help, "veto_window", 0.0) > 0.0:
            rospy.loginfo("behaviour_tree: no veto within the window: the tree goes on with its proposal applied")
        self._published_help = help_request
        message = HelpRequest()
        message.header.stamp = rospy.Time.now()
        if help_request is not None:
            message.node_name, message.reason = help_request.node_name, help_request.reason
            message.suggestion = [request.describe() for request in help_request.suggestion]
            message.proposal = [request.describe() for request in help_request.proposal]
            message.confidence, message.why = help_request.confidence, help_request.why
            message.applied, message.veto_window = help_request.applied, help_request.veto_window
            rospy.logwarn("behaviour_tree: '%s' failed (%s); %s", message.node_name, message.reason, _decision(message))
        self.help_publisher.publish(message)

    def _bytes_of(self, record: NodeRecord) -> bytes:
        """The serialised Behaviour of a record, reused while the record is the same object (unchanged node)."""
        cached = self._messages.get(record.own_id)
        if cached is None or cached[0] is not record:
            buffer = io.BytesIO()
            _behaviour(record).serialize(buffer)
            cached = (record, buffer.getvalue())
        self._fresh_messages[record.own_id] = cached
        return cached[1]

    def _render_snapshot(self) -> str:
        tree = self.tree
        with tree.lock:
            return py_trees.display.ascii_tree(
                tree.root,
                show_status=True,
                visited=tree.snapshot_visitor.visited,
                previously_visited=tree.snapshot_visitor.previously_visited,
            )

    def _on_pause(self, message: Bool) -> None:
        self.tree.set_pause(bool(message.data))

    def _on_start(self, _request) -> TriggerResponse:
        success, message = self.tree.start()
        rospy.loginfo("behaviour_tree: /behaviour_tree/start: %s", message)
        return TriggerResponse(success=success, message=message)

    def _on_change_tree(self, request: ChangeTree._request_class) -> ChangeTreeResponse:
        result = self.tree.change(
            request.node_name, request.operation, request.index, request.parent, request.node_type, request.parameter
        )
        log = rospy.loginfo if result.success else rospy.logwarn
        log("behaviour_tree: /change_tree %s %s: %s", request.operation, request.node_name, result.message)
        return ChangeTreeResponse(success=result.success, message=result.message, new_node_name=result.new_node_name)

    def _on_add_skill(self, request: AddSkill._request_class) -> AddSkillResponse:
        success, message = self.tree.add_skill(request.name, request.kind, request.data_file)
        (rospy.loginfo if success else rospy.logwarn)("behaviour_tree: add_skill %s: %s", request.name, message)
        return AddSkillResponse(success=success, message=message)


def _decision(message: HelpRequest) -> str:
    """What the tree does about a failure, in words for the log."""
    proposal = "; ".join(message.proposal)
    if message.applied and message.veto_window > 0.0:
        return (
            f"applied its proposal alone ({proposal}: {message.why}); paused for {message.veto_window:g} s, a"
            " /change_tree undo vetoes it"
        )
    if message.applied:
        return f"its applied proposal ({proposal}) stays; the operator took over, paused until they resume"
    said = ["paused, asking the operator"]
    if message.suggestion:
        said.append(f"it suggests the remembered repair: {', '.join(message.suggestion)}")
    if message.proposal:
        said.append(f"it proposes {proposal} ({message.confidence:.0%}: {message.why})")
    return "; ".join(said)


def _restored_policy(store: TreeStore) -> TreePolicy:
    """The tree policy saved in ``store`` (its parameters: config/tree_policy.yaml, or the node's private ones)."""
    policy, problems = store.restore_policy(PolicyConfig(**node_parameters("tree_policy.yaml")))
    if problems:
        rospy.logwarn("behaviour_tree: the tree policy was set aside, the tree asks as without one: %s", problems)
    elif len(policy):
        rospy.loginfo("behaviour_tree: the tree policy resumed with %d demonstrations", len(policy))
    return policy


def _behaviour(record: NodeRecord) -> Behaviour:
    return Behaviour(
        name=record.name,
        class_name=record.class_name,
        own_id=record.own_id,
        parent_id=record.parent_id,
        tip_id=record.tip_id,
        child_ids=list(record.child_ids),
        type=_TYPE[record.kind],
        status=_STATUS[record.status],
        message=record.message,
        is_active=record.is_active,
    )


def _claim_running_flag() -> bool:
    """Set ``~running`` for this process (cleared on shutdown); True if it was set already: a crashed node's restart."""
    restarted = server_value(RUNNING_PARAM, False)
    if restarted:
        rospy.logwarn("behaviour_tree: the previous behaviour_tree died without stopping: resuming what it saved")
    rospy.set_param(RUNNING_PARAM, True)
    rospy.on_shutdown(_clear_running_flag)
    return restarted


def _resumed(store: TreeStore, spec, library: SkillLibrary):
    """The tree and library saved in ``store`` (else the given ones), logging what could not be resumed."""
    spec, library, problems = store.restore(spec, library)
    if problems:
        rospy.logwarn("behaviour_tree: could not resume everything saved in %s: %s", store.directory, problems)
    else:
        rospy.loginfo("behaviour_tree: resumed the tree and library saved in %s", store.directory)
    unavailable = [f"{entry.name} ({entry.problem})" for entry in library if not entry.available]
    if unavailable:
        rospy.logwarn("behaviour_tree: unavailable skills (shown, not run): %s", "; ".join(unavailable))
    return spec, library


def _clear_running_flag() -> None:
    """A clean stop: the next start is a new session, not a restart after a crash."""
    try:
        rospy.delete_param(RUNNING_PARAM)
    except (KeyError, OSError, rospy.ROSException):
        pass  # the master is gone already: nothing to clear
