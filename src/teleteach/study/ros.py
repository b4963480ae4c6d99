"""The study node's ROS side: the session's state for the GUI, the participant's input, the world for the goals.

The node tells the GUI where the session stands, takes the participant's input, and watches the world to judge each
trial's goal and measure it.

ROS Publishers (relative names; the node runs in the root namespace):
    study/state (teleteach/StudyState, latched): the phase, the task, the live status, the questionnaire's items.
    behaviour_tree/pause (std_msgs/Bool, latched): the tree waits while a task's instructions show.

ROS Services:
    study/input (teleteach/StudyInput): the start gesture and the questionnaire's answers (refused, with the reason,
        outside their phase or when they do not fit).

ROS Subscribers:
    behaviour_tree/log/tree (teleteach/BehaviourTree), eigenvalues (geometry_msgs/Vector3Stamped), teleteach/true_scene
    (visualization_msgs/MarkerArray: the simulated world as it is): what the goals judge; teleteach/selection
    (teleteach/Selection), behaviour_tree/help_request (teleteach/HelpRequest), force_torque_ext
    (geometry_msgs/WrenchStamped): what the trial measures while it runs. A selection heard after the goal was judged
    met still counts when it was stamped no later than the newest world message that judgement saw: the GUI sends the
    selection that completes a task before the edit it makes, but on another connection, so it may arrive after the
    tree that shows the edit (the trial's record would lose the very selection that did the task).
"""

import threading
import time
from typing import Any, Callable, Dict, Iterable, List, Optional

import rosgraph.masterapi
import rospy
from geometry_msgs.msg import Vector3Stamped, WrenchStamped
from std_msgs.msg import Bool
from visualization_msgs.msg import MarkerArray

from teleteach.core.observed import TRUE_SCENE_TOPIC, product_poses
from teleteach.core.scene import Scene
from teleteach.core.study_phase import Phase
from teleteach.msg import BehaviourTree, HelpRequest, Selection, StudyState
from teleteach.runtime.node import server_value
from teleteach.srv import StudyInput, StudyInputResponse
from teleteach.study.goals import Goal, GoalJudge, Judgement, TreeView
from teleteach.study.metrics import TrialMetrics
from teleteach.study.trial import StudyFlow, StudyView

STATE_TOPIC = "study/state"
INPUT_SERVICE = "study/input"


def tree_view(message: BehaviourTree) -> TreeView:
    """Names and each composite's children of a /behaviour_tree/log/tree message."""
    by_id = {behaviour.own_id: behaviour.name for behaviour in message.behaviours}
    children = {
        behaviour.name: tuple(by_id[child] for child in behaviour.child_ids if child in by_id)
        for behaviour in message.behaviours
        if behaviour.child_ids
    }
    return TreeView(tuple(behaviour.name for behaviour in message.behaviours), children)


def state_message(view: StudyView) -> StudyState:
    """teleteach/StudyState of a :class:`StudyView`."""
    message = StudyState()
    message.header.stamp = rospy.Time.now()
    for field in ("study", "participant", "condition", "condition_label", "task", "title", "instructions"):
        setattr(message, field, getattr(view, field))
    message.phase = int(view.phase)
    message.trial, message.trials = view.trial, view.trials
    message.elapsed, message.timeout = float(view.elapsed), float(view.timeout)
    message.status, message.success = view.status, view.success
    items = view.items
    message.item_names = [item.name for item in items]
    message.item_titles = [item.title for item in items]
    message.item_questions = [item.question for item in items]
    message.item_low = [item.low for item in items]
    message.item_high = [item.high for item in items]
    message.item_points = [item.points for item in items]
    message.item_minimum = [item.minimum for item in items]
    message.item_maximum = [item.maximum for item in items]
    return message


class StudyRos:
    """Publishers, the input service and the world's subscribers of one study node (rospy initialised).

    Times are ``clock()`` seconds (monotonic wall time): a trial's system restarts the simulated clock.
    """

    def __init__(self, flow: StudyFlow, clock: Callable[[], float] = time.monotonic):
        self.flow = flow
        self.clock = clock
        self._lock = threading.Lock()
        self._judge: Optional[GoalJudge] = None
        self._metrics: Optional[TrialMetrics] = None
        self._trees_heard = 0
        self._heard_until = 0.0  # [s] the newest stamp (the trial's clock) of what the judge was given
        self._judged_until = 0.0  # [s] the same, at the last judgement
        self._state = rospy.Publisher(STATE_TOPIC, StudyState, queue_size=1, latch=True)
        self._pause = rospy.Publisher("behaviour_tree/pause", Bool, queue_size=1, latch=True)
        self._service = rospy.Service(INPUT_SERVICE, StudyInput, self._on_input)
        self._subscribers = [
            rospy.Subscriber("behaviour_tree/log/tree", BehaviourTree, self._on_tree, queue_size=5),
            rospy.Subscriber("eigenvalues", Vector3Stamped, self._on_eigenvalues, queue_size=100),
            rospy.Subscriber(TRUE_SCENE_TOPIC, MarkerArray, self._on_scene, queue_size=1),  # judged from the truth
            rospy.Subscriber("teleteach/selection", Selection, self._on_selection, queue_size=50),
            rospy.Subscriber("behaviour_tree/help_request", HelpRequest, self._on_help, queue_size=10),
            rospy.Subscriber("force_torque_ext", WrenchStamped, self._on_wrench, queue_size=100),
        ]

    def close(self) -> None:
        """Unadvertise and unsubscribe: a latched state must not reach a GUI that starts later."""
        for subscriber in self._subscribers:
            subscriber.unregister()
        self._state.unregister()
        self._pause.unregister()
        self._service.shutdown("study node closed")

    # a trial ------------------------------------------------------------------------------------------------
    def begin_trial(self, goal: Goal, scene: Optional[Scene], metrics: TrialMetrics) -> None:
        """Judge ``goal`` and measure into ``metrics`` from now on (what an earlier trial's system said is gone)."""
        with self._lock:
            self._judge = GoalJudge(goal, scene)
            self._metrics = metrics
            self._trees_heard = 0
            self._heard_until = self._judged_until = 0.0

    def end_trial(self) -> None:
        """Stop judging and measuring."""
        with self._lock:
            self._judge = self._metrics = None

    @property
    def trees_heard(self) -> int:
        """Tree messages since the trial began (its behaviour tree is up once one came)."""
        with self._lock:
            return self._trees_heard

    def judgement(self) -> Judgement:
        """The goal's judgement now."""
        with self._lock:
            if self._judge is None:
                return Judgement(False, "")
            self._judged_until = self._heard_until
            return self._judge.judgement(self.clock())

    def publish(self) -> None:
        """study/state as the flow says now."""
        self._state.publish(state_message(self.flow.view(self.clock())))

    def pause_tree(self, paused: bool) -> None:
        """Pause or resume the behaviour tree (latched: a tree that starts later hears it too)."""
        self._pause.publish(Bool(paused))

    # callbacks ----------------------------------------------------------------------------------------------
    def _on_input(self, request) -> StudyInputResponse:
        if request.kind == "start":
            success, message = self.flow.start(self.clock())
        elif request.kind == "questionnaire":
            success, message = self.flow.answer(list(request.names), list(request.values))
        else:
            success, message = False, f"unknown input kind {request.kind!r} (start | questionnaire)"
        if not success:
            rospy.logwarn(f"study: input refused: {message}")
        self.publish()
        return StudyInputResponse(success, message)

    def _since_start(self) -> Optional[float]:
        """[s] since the running trial started, or None when no trial runs (nothing is measured then)."""
        started = self.flow.started
        if started is None or self.flow.phase != Phase.RUNNING:
            return None
        return self.clock() - started

    def _made_before_the_end(self, stamp: float) -> Optional[float]:
        """A trial's end [s since its start] for a selection stamped before its goal was judged met; else None."""
        if self.flow.phase != Phase.DONE:
            return None
        with self._lock:
            judged_until = self._judged_until
        return self.flow.outcome[1] if 0.0 < stamp <= judged_until else None

    def _on_tree(self, message: BehaviourTree) -> None:
        view = tree_view(message)
        with self._lock:
            self._trees_heard += 1
            if self._judge is not None:
                self._judge.tree(view)
                self._heard_until = max(self._heard_until, message.header.stamp.to_sec())

    def _on_eigenvalues(self, message: Vector3Stamped) -> None:
        values = (message.vector.x, message.vector.y, message.vector.z)
        since = self._since_start()
        with self._lock:
            if self._judge is not None:
                self._judge.stiffness(self.clock(), values)
                self._heard_until = max(self._heard_until, message.header.stamp.to_sec())
            if self._metrics is not None and since is not None:
                self._metrics.eigenvalues(since, values)

    def _on_scene(self, message: MarkerArray) -> None:
        poses = product_poses(message.markers)
        with self._lock:
            if self._judge is not None:
                self._judge.scene_products(self.clock(), poses)
                stamps = [marker.header.stamp.to_sec() for marker in message.markers]
                self._heard_until = max([self._heard_until, *stamps])

    def _on_selection(self, message: Selection) -> None:
        since = self._since_start()
        if since is None:
            since = self._made_before_the_end(message.header.stamp.to_sec())
        with self._lock:
            if self._metrics is not None and since is not None:
                self._metrics.selection(since, message.tab, message.step, message.choice)

    def _on_help(self, message: HelpRequest) -> None:
        since = self._since_start()
        with self._lock:
            if self._metrics is not None and since is not None:
                self._metrics.help_request(since, message.node_name, message.reason)

    def _on_wrench(self, message: WrenchStamped) -> None:
        if self._since_start() is None:
            return
        force, torque = message.wrench.force, message.wrench.torque
        with self._lock:
            if self._metrics is not None:
                self._metrics.wrench((force.x, force.y, force.z), (torque.x, torque.y, torque.z))


def gui_listens() -> bool:
    """Whether the teaching GUI (in this node's namespace) subscribes to study/state."""
    _, subscribers, _ = rosgraph.masterapi.Master(rospy.get_name()).getSystemState()
    return rospy.resolve_name("teaching_gui") in dict(subscribers).get(rospy.resolve_name(STATE_TOPIC), [])


def not_ready(trees_heard: int) -> List[str]:
    """What of a trial's system is not up yet: the behaviour tree (heard), the GUI, the device (advertised)."""
    publishers, _, _ = rosgraph.masterapi.Master(rospy.get_name()).getSystemState()
    device = bool(dict(publishers).get(rospy.resolve_name("sigma7/pose")))
    parts = (("the behaviour tree", trees_heard > 0), ("the GUI", gui_listens()), ("the device", device))
    return [what for what, ready in parts if not ready]


def parameters_seen(names: Iterable[str]) -> Dict[str, Any]:
    """The values of ``<node>/<parameter>`` names on the parameter server now (what each node read at its start)."""
    return {name: server_value("/" + name, None) for name in names}


def clear_parameters(keep: Iterable[str]) -> List[str]:
    """Delete every top-level parameter namespace not in ``keep`` (what a finished trial's nodes left); returns them.

    A node that died without cleaning up leaves flags behind (e.g. behaviour_tree's ``~running``, which would make
    the next trial's tree resume the last one's).
    """
    kept = set(keep)
    names = {name.split("/")[1] for name in rospy.get_param_names() if name.count("/") >= 1}
    removed = []
    for name in sorted(names - kept):
        try:
            rospy.delete_param("/" + name)
            removed.append(name)
        except KeyError:
            pass
    return removed
