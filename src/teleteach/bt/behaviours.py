"""The behaviours of the teaching tree: pause condition, skill leaves that ask for help, edit-proof composites.

py_trees' own composites almost fit; two details of theirs would undo what teaching needs:

- a Selector invalidates its lower-priority branches when a higher one succeeds, so pausing (PauseCondition
  succeeding under the Root fallback) would cancel the running skill and restart the sequence afterwards:
  :class:`PausableSelector` *suspends* them instead, and they resume where they were when the pause ends;
- a Sequence with memory whose remembered child is removed restarts from its first child:
  :class:`EditableSequence` succeeds instead when the removed child was its last one.

:class:`SkillLeaf` holds the life cycle of a leaf that runs a skill elsewhere (start in ``initialise()``, poll in
``update()``, cancel in ``terminate()``), and turns a failure into a help request instead of a failed tree.
"""

import abc
import itertools
import typing

import py_trees
from py_trees.common import Status

from teleteach.bt.library import CONDITION

PAUSE_KEY = "pause"


class PauseCondition(py_trees.behaviour.Behaviour):
    """SUCCESS while the tree must stay paused, FAILURE otherwise (thesis Appendix B.2).

    Under the Root fallback its success keeps BehaviorExecution from being ticked.

    Blackboard Variables:
        * **pause** (:obj:`bool`)[r]: true while the operator (or a help request) pauses the tree
    """

    def __init__(self, name: str = "PauseCondition"):
        super().__init__(name)
        self.blackboard = self.attach_blackboard_client(name=name)
        self.blackboard.register_key(PAUSE_KEY, access=py_trees.common.Access.READ)

    def update(self) -> Status:
        """Read the pause flag."""
        paused = self.blackboard.exists(PAUSE_KEY) and bool(self.blackboard.get(PAUSE_KEY))
        self.feedback_message = "paused" if paused else "not paused"
        return Status.SUCCESS if paused else Status.FAILURE


class SkillLeaf(py_trees.behaviour.Behaviour, abc.ABC):
    """A leaf that runs one skill somewhere else and asks the operator for help when it fails.

    Subclasses say how to :meth:`start`, :meth:`poll` and :meth:`cancel` the skill. When the skill fails and
    ``on_failure`` is set, the leaf stays RUNNING and ``awaiting_help``: ``on_failure(leaf, reason)`` pauses the
    tree; the next tick after the pause retries the skill (unless the operator removed the leaf meanwhile). A
    failure that the tree above handles (:func:`failure_handled_above`), or of a condition, is returned as FAILURE.

    A pause suspends the running leaf with its goal out (:class:`PausableSelector`); the tree may :meth:`preempt`
    it so that the arm is free, and the first tick after the pause starts the skill again.

    Args:
        name: unique name of the leaf in the tree
        skill: the skill it runs (the library name, e.g. "PlaceItem" for the leaf "PlaceItem_2")
        kind: "predefined", "condition" or the kind of a demonstrated skill (stiffness, shared_control, dmp)
        data_file: the recorded skill file of a demonstrated skill, empty for predefined ones
    """

    def __init__(self, name: str, skill: str, kind: str = "predefined", data_file: str = ""):
        super().__init__(name)
        self.skill = skill
        self.kind = kind
        self.data_file = data_file
        self.parameters: typing.Dict[str, str] = {}
        self.awaiting_help = False
        self.goal_active = False
        self.preempted = False
        self.on_failure: typing.Optional[typing.Callable[[SkillLeaf, str], None]] = None

    @abc.abstractmethod
    def start(self) -> None:
        """Ask for the skill to be executed (non-blocking)."""

    @abc.abstractmethod
    def poll(self) -> typing.Tuple[Status, str]:
        """Return the skill's status (RUNNING, SUCCESS or FAILURE) and a message saying why (non-blocking)."""

    @abc.abstractmethod
    def cancel(self) -> None:
        """Abort the skill that :meth:`start` asked for."""

    def goal_out(self) -> bool:
        """Whether the skill's goal may still move the robot (subclasses that can ask the server say exactly)."""
        return self.goal_active

    def finished_before_preempt(self) -> bool:
        """Whether a preempted goal had succeeded before the cancel reached it (then it is not run again)."""
        return False

    def preempt(self) -> None:
        """Cancel the goal of a suspended leaf; the first tick after the pause starts the skill again."""
        if self.goal_active:
            self.cancel()
            self.feedback_message = f"preempted {self.skill} (paused): it starts again when the tree resumes"
        self.goal_active = False
        self.preempted = True

    def initialise(self) -> None:
        """Start the skill."""
        self.awaiting_help = False
        self.preempted = False
        self.feedback_message = f"starting {self.skill}"
        self.goal_active = True
        self.start()

    def update(self) -> Status:
        """Poll the skill; on failure ask for help (if someone listens) instead of failing."""
        if self.preempted and self.finished_before_preempt():  # the cancel came too late: the skill is done
            self.preempted = False
            self.goal_active = False
            return Status.SUCCESS
        if self.awaiting_help or self.preempted:  # first tick after a help request's pause, or a preempting one
            self.awaiting_help = self.preempted = False
            self.goal_active = True
            self.start()
        status, message = self.poll()
        self.feedback_message = message
        if status == Status.RUNNING:
            return status
        self.goal_active = False
        if status == Status.FAILURE and self.asks_for_help():
            self.awaiting_help = True
            self.feedback_message = f"failed: {message} (waiting for the operator)"
            self.on_failure(self, message)
            return Status.RUNNING
        return status

    def asks_for_help(self) -> bool:
        """Whether a failure pauses the tree for the operator: not a condition's (an answer), nor one handled above."""
        return self.on_failure is not None and self.kind != CONDITION and not failure_handled_above(self)

    def terminate(self, new_status: Status) -> None:
        """Cancel the skill when the leaf is interrupted while its goal is out."""
        if new_status == Status.INVALID and self.goal_active:
            self.cancel()
            self.feedback_message = f"cancelled {self.skill}"
        self.goal_active = False
        if new_status == Status.INVALID:
            self.awaiting_help = self.preempted = False


def failure_handled_above(node: py_trees.behaviour.Behaviour) -> bool:
    """Whether an ancestor turns this node's failure into something other than a failed tree.

    A retry with attempts left runs it again, an inverter makes it a success, a selector tries its next child: the
    operator is asked only when none of them is there (or a retry's last attempt failed).
    """
    child, parent = node, node.parent
    while parent is not None:
        if isinstance(parent, py_trees.decorators.Retry) and parent.failures + 1 < parent.num_failures:
            return True
        if isinstance(parent, py_trees.decorators.Inverter):
            return True
        if isinstance(parent, py_trees.composites.Selector) and parent.children[-1] is not child:
            return True
        child, parent = parent, parent.parent
    return False


class EditableSequence(py_trees.composites.Sequence):
    """py_trees' Sequence, plus: with memory, removing the remembered (failed) last child completes it.

    The memory of py_trees' Sequence is the identity of its current child, so inserting or removing siblings
    keeps it on the running child; only removing the current child itself needs help (the editor moves the
    memory to the next sibling, or clears it when there is none, which this class reads as "done").
    """

    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        """Tick as py_trees does, unless an edit removed the remembered child and nothing follows it."""
        if self.memory and self.status == Status.RUNNING and self.current_child is None:
            self.stop(Status.SUCCESS)
            yield self
            return
        yield from super().tick()


class PausableSelector(py_trees.composites.Selector):
    """py_trees' Selector, except that a succeeding PauseCondition suspends lower priorities instead of stopping them.

    A suspended branch keeps its status and memory (the running skill keeps its goal, nothing is cancelled) and
    continues from where it was when the PauseCondition fails again. Any other child preempts as in py_trees.
    The tick below is py_trees 2.6's Selector.tick with only that exception added.
    """

    def tick(self) -> typing.Iterator[py_trees.behaviour.Behaviour]:
        """Tick the children by priority (see the class docstring for the pause exception)."""
        if self.status != Status.RUNNING:
            self.current_child = self.children[0] if self.children else None
            self.initialise()
        if not self.children:
            self.current_child = None
            self.stop(Status.FAILURE)
            yield self
            return
        if self.memory and self.current_child is not None:
            index = self.children.index(self.current_child)
            for child in itertools.islice(self.children, None, index):
                if child.status != Status.INVALID:
                    child.stop(Status.INVALID)
        else:
            index = 0
        previous = self.current_child
        for child in itertools.islice(self.children, index, None):
            for node in child.tick():
                yield node
                if node is child and node.status in (Status.RUNNING, Status.SUCCESS):
                    self.current_child = child
                    if previous is None or previous != self.current_child:
                        self._preempt_lower_priorities(child)
                    if node.status == Status.SUCCESS:
                        self.stop(node.status)
                    else:
                        self.status = node.status
                    yield self
                    return
        self.stop(Status.FAILURE)
        self.current_child = self.children[-1]
        yield self

    def _preempt_lower_priorities(self, winner: py_trees.behaviour.Behaviour) -> None:
        if isinstance(winner, PauseCondition):
            return  # suspend, do not stop: the branches resume after the pause
        lower = self.children[self.children.index(winner) + 1 :]
        for child in lower:
            if child.status != Status.INVALID:
                child.stop(Status.INVALID)
