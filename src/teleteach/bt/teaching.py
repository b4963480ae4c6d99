"""The tree the operator teaches: ticking, pausing, online edits, the skill library, help requests and persistence.

Everything here runs without ROS (the ROS layer in :mod:`teleteach.bt.ros` only wires topics and services to it).
One re-entrant lock serialises ticks with edits, so an edit always lands between two ticks.

Help requests (thesis requirement 6b): when a skill fails, its leaf does not fail the tree; the tree pauses
(blackboard ``pause``), :attr:`TeachingTree.help_request` names the leaf and the reason, and nothing runs until the
operator unpauses. What happens then depends on the operator's edits while paused:

- nothing changed: the failed skill is retried;
- the failed leaf was removed: its parent continues with the node now at its place (a replacement inserted at
  that index, the next sibling, or - if it was the last child - the parent is done);
- a node was inserted right in front of the failed leaf: that node runs first, then the failed skill is retried.

The edits that answered a help request are remembered (:mod:`teleteach.bt.repairs`): the next help request for the
same node and reason suggests them, and ``repair`` applies them as one edit. With a tree policy
(:mod:`teleteach.bt.tree_policy`) the failure is also described as a situation and the policy asked
(:mod:`teleteach.bt.decisions` says who acts): confident, the tree applies the proposal itself right after the tick
(never during one), stays paused for the veto window and then goes on by itself, unless the operator edits or pauses
it first; an undo of the proposal is a veto (the tree is restored and asks). Unsure, the help request carries the
proposal, and ``repair`` applies it when no repair is remembered. The operator's answer (their accepted edits, a
confirmed proposal included) becomes a demonstration and the policy is saved.

Pausing and the arm (:meth:`TeachingTree.execution_state`): a pause suspends the running skill with its goal out, so
that it finishes what it was doing (the thesis: the tree pauses after its running skill); after ``preempt_after``
seconds of pause a goal still out is cancelled, and the skill starts again when the tree resumes. Only once no goal
is out (PAUSED) may another controller take the arm. A tree built with ``start_paused`` waits (WAITING) until the
operator starts it (:meth:`TeachingTree.start`): on a real robot nothing moves before the operator says so. The same
start runs a tree that is done (COMPLETED) again from its first node.
"""

import datetime
import enum
import math
import os
import pathlib
import threading
import time
import typing

import py_trees
import yaml
from py_trees.common import Status

from teleteach.bt.behaviours import PAUSE_KEY, SkillLeaf
from teleteach.bt.decisions import VETOED, TaskKnowledge, advise
from teleteach.bt.editor import ChangeResult, EditRequest, TreeEditor
from teleteach.bt.library import LibraryError, SkillEntry, SkillLibrary
from teleteach.bt.repairs import RepairError, RepairMemory
from teleteach.bt.situations import Situation, describe
from teleteach.bt.tree import LeafFactory, TreeSpec, TreeSpecError, create_root, dump_live_yaml, load_tree, node_type
from teleteach.bt.tree import describe as describe_tree
from teleteach.bt.tree_policy import PolicyConfig, TreePolicy, policy_yaml
from teleteach.core.datadir import temporary_beside

TREE_FILE = "current_tree.yaml"
LIBRARY_FILE = "skill_library.yaml"
REPAIRS_FILE = "repairs.yaml"
POLICY_FILE = "tree_policy.yaml"
PREVIOUS = "previous"  # current_tree.yaml -> current_tree.previous.yaml: the version before the last save
CORRUPT = "corrupt"  # current_tree.yaml -> current_tree.corrupt-<time>.yaml: a file that could not be loaded


class HelpRequest(typing.NamedTuple):
    """The robot asks the operator for a contingency plan (or says what it did itself: ``applied``)."""

    node_name: str
    reason: str
    suggestion: typing.Tuple[EditRequest, ...] = ()  # how the operator repaired the same failure before
    proposal: typing.Tuple[EditRequest, ...] = ()  # the tree policy's edits (teleteach.bt.decisions)
    confidence: float = 0.0  # the policy's confidence in its proposal (0..1)
    why: str = ""  # the policy's reason, or why it does not know, or that it was refused or vetoed, in words
    applied: bool = False  # the robot applied the proposal itself
    veto_window: float = 0.0  # [s] while > 0, an undo vetoes the applied proposal (0: no window open)

    @property
    def repair(self) -> typing.Tuple[EditRequest, ...]:
        """What /change_tree's ``repair`` applies: the remembered repair, else the policy's proposal."""
        return self.suggestion or self.proposal


class ExecutionState(enum.IntEnum):
    """What the tree does with the robot (the constants of teleteach/TreeExecution)."""

    RUNNING = 0  # ticking its skills
    WAITING = 1  # started paused: nothing ran yet
    PAUSING = 2  # paused, a skill's goal still out
    PAUSED = 3  # paused, no goal out: the arm is free
    COMPLETED = 4  # the execution composite succeeded


class Execution(typing.NamedTuple):
    """The tree's :class:`ExecutionState`, the skill whose goal is out (PAUSING) and a line for the operator."""

    state: ExecutionState
    skill: str
    message: str


class NodeRecord(typing.NamedTuple):
    """One node as the log/tree topic reports it (py_trees_msgs/Behaviour fields)."""

    name: str
    class_name: str
    own_id: str
    parent_id: str
    tip_id: str
    child_ids: typing.Tuple[str, ...]
    kind: str  # selector | sequence | parallel | pause | skill
    status: Status
    message: str
    is_active: bool


class VisitedNodes(py_trees.visitors.SnapshotVisitor):
    """py_trees' SnapshotVisitor that also keeps the visited behaviours, so change detection costs O(visited).

    ``active`` is this tick's visited behaviours as a set of the objects themselves: membership tests by identity
    are several times cheaper than by py_trees' UUID ids, which hash in Python.
    """

    def __init__(self) -> None:
        super().__init__()
        self.nodes: typing.Dict[typing.Any, py_trees.behaviour.Behaviour] = {}
        self.previous_nodes: typing.Dict[typing.Any, py_trees.behaviour.Behaviour] = {}
        self.active: typing.Set[py_trees.behaviour.Behaviour] = set()

    def initialise(self) -> None:
        """Shift this tick's nodes to the previous ones."""
        super().initialise()
        self.previous_nodes = self.nodes
        self.nodes = {}
        self.active = set()

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        """Record the status (py_trees) and the node."""
        super().run(behaviour)
        self.nodes[behaviour.id] = behaviour
        self.active.add(behaviour)


class TickedNodesTree(py_trees.trees.BehaviourTree):
    """py_trees' BehaviourTree without the walk over every node after each tick when no visitor asks for it.

    py_trees walks the whole tree after every tick for its "full" visitors; teleteach's visitor only wants the ticked
    nodes, and that walk is most of a tick of a 1000-leaf tree (whose sequence ticks a single leaf).
    """

    def tick(
        self,
        pre_tick_handler: typing.Optional[typing.Callable[[py_trees.trees.BehaviourTree], None]] = None,
        post_tick_handler: typing.Optional[typing.Callable[[py_trees.trees.BehaviourTree], None]] = None,
    ) -> None:
        """Tick once: py_trees' handlers and visitors, in py_trees' order."""
        if any(visitor.full for visitor in self.visitors):
            super().tick(pre_tick_handler, post_tick_handler)
            return
        for handler in ([pre_tick_handler] if pre_tick_handler else []) + self.pre_tick_handlers:
            handler(self)
        for visitor in self.visitors:
            visitor.initialise()
        for node in self.root.tick():
            for visitor in self.visitors:
                node.visit(visitor)
        for visitor in self.visitors:
            visitor.finalise()
        for handler in self.post_tick_handlers + ([post_tick_handler] if post_tick_handler else []):
            handler(self)
        self.count += 1


class Restored(typing.NamedTuple):
    """What :meth:`TreeStore.restore` resumed from, and what it had to set aside ("" when everything loaded)."""

    tree: TreeSpec
    library: SkillLibrary
    problems: str


class TreeStore:
    """The saved tree and library in ``<data dir>/trees/``, replaced atomically after every successful change.

    A save is a write to a temporary file renamed over the old one before the edit is answered, so a process that
    dies (even by SIGKILL) right after leaves either the old or the new file, whole. The version it replaces stays
    as ``*.previous.yaml``: if a saved file cannot be loaded (edited by hand, disk trouble), :meth:`restore` sets it
    aside as ``*.corrupt-<time>.yaml`` for the user and resumes from the previous version. The fsync that makes the file
    survive a power loss too costs 5-25 ms on a busy disk, so a background thread does it just after, off the
    path of /change_tree, at most every ``flush_delay`` seconds: a burst of edits shares one fsync instead of
    keeping the disk's journal busy under the renames of the next edits.
    """

    flush_delay = 0.05  # [s]

    def __init__(self, directory: typing.Union[str, pathlib.Path]):
        self.directory = pathlib.Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.tree_path = self.directory / TREE_FILE
        self.library_path = self.directory / LIBRARY_FILE
        self.repairs_path = self.directory / REPAIRS_FILE
        self.policy_path = self.directory / POLICY_FILE
        self._unflushed: typing.Set[pathlib.Path] = set()
        self._flush_lock = threading.Lock()
        self._flush_wanted = threading.Event()
        threading.Thread(target=self._flush_loop, name="TreeStore.fsync", daemon=True).start()

    def save_tree(self, text: str) -> None:
        """Replace the saved tree."""
        self._replace(self.tree_path, text)

    def save_library(self, library: SkillLibrary) -> None:
        """Replace the saved library."""
        self._replace(self.library_path, yaml.safe_dump(library.to_dict(), sort_keys=False))

    def save_repairs(self, repairs: RepairMemory) -> None:
        """Replace the saved repair memory."""
        self._replace(self.repairs_path, yaml.safe_dump(repairs.to_dict(), sort_keys=False))

    def restore_repairs(self) -> typing.Tuple[RepairMemory, str]:
        """The saved repair memory (empty if none), and what had to be set aside ("" when it loaded)."""
        problems: typing.List[str] = []
        repairs = self._load_or_set_aside(self.repairs_path, _load_repairs, problems)
        return repairs or RepairMemory(), "; ".join(problems)

    def save_policy(self, policy: TreePolicy) -> None:
        """Replace the saved tree policy (its demonstrations)."""
        self._replace(self.policy_path, policy_yaml(policy))

    def restore_policy(self, config: PolicyConfig) -> typing.Tuple[TreePolicy, str]:
        """The saved tree policy (one without demonstrations if none), and what had to be set aside ("" if nothing).

        A corrupt file, or one saved under another feature set, is set aside: the tree then asks as it would without.
        """
        problems: typing.List[str] = []
        policy = self._load_or_set_aside(self.policy_path, lambda path: _load_policy(path, config), problems)
        return policy if policy is not None else TreePolicy(config), "; ".join(problems)

    def flush(self) -> None:
        """Make what was saved durable (fsync); the background thread calls it after each save."""
        with self._flush_lock:
            paths, self._unflushed = self._unflushed, set()
            for path in paths:
                try:
                    with open(path, "rb") as stream:
                        os.fsync(stream.fileno())
                except FileNotFoundError:
                    continue  # a previous version that was never made
            if paths:
                directory = os.open(self.directory, os.O_RDONLY)
                try:
                    os.fsync(directory)
                finally:
                    os.close(directory)

    def _replace(self, path: pathlib.Path, text: str) -> None:
        """Write ``path`` atomically; the file it replaces becomes the previous version (``path`` never vanishes)."""
        handle, temporary = temporary_beside(path)
        link = f"{temporary}.previous"
        try:
            with os.fdopen(handle, "w", encoding="utf-8") as stream:
                stream.write(text)
            try:
                os.link(path, link)
                os.replace(link, previous_path(path))
            except FileNotFoundError:
                pass  # nothing saved yet (or it was set aside as corrupt): the previous version stays
            os.replace(temporary, path)
        except BaseException:
            pathlib.Path(temporary).unlink(missing_ok=True)
            pathlib.Path(link).unlink(missing_ok=True)
            raise
        with self._flush_lock:
            self._unflushed.update((path, previous_path(path)))
        self._flush_wanted.set()

    def _flush_loop(self) -> None:
        while True:
            self._flush_wanted.wait()
            time.sleep(self.flush_delay)
            self._flush_wanted.clear()
            try:
                self.flush()
            except OSError:
                continue  # the next save tries again; the renamed file is already in place

    def restore(self, default_tree: TreeSpec, library: SkillLibrary) -> Restored:
        """The saved tree and library (saved demonstrated skills join ``library``), or the defaults if none saved.

        A saved file that does not load is set aside and its previous version used (else the default tree, or no
        demonstrated skills); ``problems`` says what happened, in one line. Demonstrated skills whose file is missing
        or bad load as unavailable.
        """
        problems: typing.List[str] = []
        saved = self._load_or_set_aside(self.library_path, SkillLibrary.load, problems)
        if saved is not None:
            library = SkillLibrary([*library, *(entry for entry in saved if entry.name not in library)])
        library = library.with_checked_files()
        tree = self._load_or_set_aside(self.tree_path, lambda path: load_tree(path, library), problems)
        if tree is None:
            tree = default_tree
            if problems and problems[-1].startswith("tree"):
                problems[-1] += "; starting from the default tree"
        return Restored(tree, library, "; ".join(problems))

    def _load_or_set_aside(
        self, path: pathlib.Path, load: typing.Callable[[pathlib.Path], typing.Any], problems: typing.List[str]
    ) -> typing.Any:
        """``load(path)``, else ``load`` of its previous version, else None; each file that fails is set aside."""
        names = {self.tree_path: "tree", self.library_path: "library", self.policy_path: "tree policy"}
        what = names.get(path, "repairs")
        failures = []
        for candidate in (path, previous_path(path)):
            if not candidate.is_file():
                continue
            try:
                value = load(candidate)
            except (LibraryError, TreeSpecError, RepairError, OSError, UnicodeDecodeError, yaml.YAMLError) as error:
                reason = " ".join(str(error).split())  # yaml errors span lines: the log says it in one
                reason = reason if str(candidate) in reason else f"{candidate}: {reason}"
                failures.append(f"{reason} (moved to {set_aside(candidate).name})")
                continue
            if failures:
                problems.append(f"{what}: {'; '.join(failures)}; resumed from {candidate.name}")
            return value
        if failures:
            problems.append(f"{what}: {'; '.join(failures)}")
        return None


def _load_repairs(path: pathlib.Path) -> RepairMemory:
    return RepairMemory.from_dict(yaml.safe_load(path.read_text()), source=str(path))


def _load_policy(path: pathlib.Path, config: PolicyConfig) -> TreePolicy:
    return TreePolicy.from_dict(yaml.safe_load(path.read_text()), config, source=str(path))


def previous_path(path: pathlib.Path) -> pathlib.Path:
    """Where the version before the last save of ``path`` is kept."""
    return path.with_name(f"{path.stem}.{PREVIOUS}{path.suffix}")


def set_aside(path: pathlib.Path) -> pathlib.Path:
    """Rename a file that could not be loaded to a new name (never over another file); return the new path."""
    stamp = datetime.datetime.now().strftime("%Y%m%dT%H%M%S")
    stem = path.stem.replace(f".{PREVIOUS}", "")
    for number in range(1000):
        suffix = f"-{number}" if number else ""
        target = path.with_name(f"{stem}.{CORRUPT}-{stamp}{suffix}{path.suffix}")
        try:
            os.link(path, target)  # fails if the target exists: nothing is overwritten
        except FileExistsError:
            continue
        path.unlink()
        return target
    raise OSError(f"cannot set {path} aside: 1000 files named {stem}.{CORRUPT}-{stamp}-* exist")


class TeachingTree:
    """A py_trees tree that an operator edits while it runs.

    Args:
        spec: the tree to build
        library: the skills leaves may run
        make_leaf: builds the leaf of a skill (ROS action clients in the node, scripted leaves in tests)
        store: where to save the tree and library after each change (None: nowhere)
        data_root: the data directory, for relative skill file paths
        repairs: the repairs remembered so far (saved in ``store`` when one is added)
        policy: the tree policy asked at each help request (None: only the remembered repairs are suggested)
        task: what the tree knows of the task, to describe a failure's product, gap and base (None: left out)
        start_paused: wait, paused, for :meth:`start` before running anything
        preempt_after: [s] of pause after which a skill goal still out is cancelled (inf: never)
        clock: [s] the time ``preempt_after`` and the veto window are measured on (the node's: ROS time)

    Blackboard Variables:
        * **pause** (:obj:`bool`)[w]: written by :meth:`set_pause` and by help requests
    """

    def __init__(
        self,
        spec: TreeSpec,
        library: SkillLibrary,
        make_leaf: LeafFactory,
        store: typing.Optional[TreeStore] = None,
        data_root: typing.Optional[pathlib.Path] = None,
        repairs: typing.Optional[RepairMemory] = None,
        policy: typing.Optional[TreePolicy] = None,
        task: typing.Optional[TaskKnowledge] = None,
        start_paused: bool = False,
        preempt_after: float = math.inf,
        clock: typing.Callable[[], float] = time.monotonic,
    ):
        self.lock = threading.RLock()
        self.started = not start_paused
        self.preempt_after = preempt_after
        self._clock = clock
        self._paused_at = clock() if start_paused else math.inf
        self.repairs = repairs or RepairMemory()
        self.policy = policy
        self.task = task
        self._situation: typing.Optional[Situation] = None  # the open help request's, as the policy sees it
        self._acting = False  # the open help request's proposal is to be applied after this tick
        self._veto_deadline = math.inf  # [s] on ``clock``: until then an undo vetoes the applied proposal
        self._operator_answered = False  # the operator edited the tree since the help request
        self._answer: typing.List[typing.Tuple[EditRequest, ...]] = []  # the open help request's edits, by change
        self._undone_answer: typing.List[typing.Tuple[EditRequest, ...]] = []
        self.library = library
        self.store = store
        self.data_root = data_root or pathlib.Path.cwd()
        self._make_leaf = make_leaf
        self.tree = TickedNodesTree(create_root(spec.root, library, self._leaf))
        self.snapshot_visitor = VisitedNodes()
        self.tree.visitors.append(self.snapshot_visitor)
        self.editor = TreeEditor(self.tree.root, spec.execution, library, self._leaf, spec.history)
        self.blackboard = py_trees.blackboard.Client(name="TeachingTree")
        self.blackboard.register_key(PAUSE_KEY, access=py_trees.common.Access.WRITE)
        self.blackboard.set(PAUSE_KEY, start_paused)
        self.help_request: typing.Optional[HelpRequest] = None
        self.completed = False
        self.revision = 0  # bumped by every edit, library change, pause change and help request
        self.library_revision = 0
        self._signature: typing.Any = None
        self._persist_lock = threading.Lock()
        self._saved_revision = -1
        self._record_cache: typing.Dict[py_trees.behaviour.Behaviour, typing.Tuple[typing.Tuple, NodeRecord]] = {}

    @property
    def root(self) -> py_trees.behaviour.Behaviour:
        """The root behaviour."""
        return self.tree.root

    @property
    def execution(self) -> py_trees.behaviour.Behaviour:
        """The composite edited by default (BehaviorExecution)."""
        return self.editor.execution

    @property
    def paused(self) -> bool:
        """The blackboard's pause flag."""
        return bool(self.blackboard.get(PAUSE_KEY))

    def _leaf(self, name: str, entry: SkillEntry) -> SkillLeaf:
        leaf = self._make_leaf(name, entry)
        leaf.on_failure = self._request_help
        return leaf

    def _request_help(self, leaf: SkillLeaf, reason: str) -> None:
        self._ask(leaf.name, reason)

    def _ask(self, node_name: str, reason: str) -> None:
        """Pause and ask the operator, suggesting the policy's proposal or the remembered repair (or act on it)."""
        if not self.paused:
            self._paused_at = self._clock()
        self.blackboard.set(PAUSE_KEY, True)
        self._situation = self._describe(node_name, reason)
        advice = advise(self.policy, self._situation)
        remembered = self.repairs.suggestion(node_name, reason)
        self.help_request = HelpRequest(node_name, reason, remembered, advice.proposal, advice.confidence, advice.why)
        self._acting, self._veto_deadline = advice.acts, math.inf
        self._answer, self._undone_answer, self._operator_answered = [], [], False
        self.revision += 1

    def _describe(self, node_name: str, reason: str) -> typing.Optional[Situation]:
        """The failure as the policy sees it; None without a policy or a node the description cannot place."""
        if self.policy is None:
            return None
        library = [(entry.name, entry.kind) for entry in self.library]
        situation = self.task.situation if self.task is not None else describe
        try:
            return situation(describe_tree(self.root), self.execution.name, node_name, reason, library)
        except KeyError:
            return None

    def _apply_proposal(self) -> None:
        """Apply the help request's proposal as one edit and open the veto window; a refused one is only suggested."""
        self._acting, help_request = False, self.help_request
        result = self.editor.apply_requests(help_request.proposal)
        if not result.success:
            why = f"{help_request.why}; not applied, the tree refused it ({result.message}): asking the operator"
            self.help_request = help_request._replace(why=why)
            self.revision += 1
            return
        window = self.policy.config.veto_window
        self._answer.append(help_request.proposal)
        self._veto_deadline = self._clock() + window
        self.help_request = help_request._replace(applied=True, veto_window=window)
        self.revision += 1
        self._save(self.revision, self.tree_yaml())

    def _go_on_after_the_veto_window(self) -> None:
        """Nobody vetoed the applied proposal in time: close the help request and run (nothing is learned)."""
        if self._clock() >= self._veto_deadline:
            self._veto_deadline = math.inf
            self.set_pause(False)

    def _follow_the_operator(self, request: EditRequest) -> None:
        """An edit after the robot applied its proposal: the operator decides now, the tree waits for them to resume.

        An undo that leaves no edit of the answer reverted the proposal (always its first edit): a veto.
        """
        if not self.help_request.applied:
            return
        self._close_veto_window()
        if request.operation == "undo" and not self._answer:
            why = f"{VETOED} (the tree is as before): {self.help_request.why}"
            self.help_request = self.help_request._replace(applied=False, why=why)

    def _close_veto_window(self) -> None:
        """No going on by itself: the operator took over (an edit, or a pause such as entering a teaching tab)."""
        self._veto_deadline = math.inf
        if self.help_request is not None and self.help_request.veto_window > 0.0:
            self.help_request = self.help_request._replace(veto_window=0.0)
            self.revision += 1

    def _request_help_for_failed_execution(self) -> None:
        """A failure no leaf asked about reached the execution composite (e.g. a timeout decorator fired): ask."""
        failed = self.execution
        while True:
            failed_children = [child for child in failed.children if child.status == Status.FAILURE]
            if not failed_children:
                break
            failed = failed_children[-1]
        reason = failed.feedback_message or "failed"
        self._ask(
            failed.name, f"{reason}; '{self.execution.name}' failed and starts again from its first node on resume"
        )

    def set_pause(self, paused: bool) -> None:
        """Pause or resume; resuming closes an open help request, remembering its answer's edits as the repair.

        A tree that waits for its start stays paused: a resume is no start (a latched "not paused", left by a GUI
        before this tree was started again, would otherwise run the robot without the operator); see :meth:`start`.
        """
        with self.lock:
            if paused:
                self._close_veto_window()
            if paused == self.paused or not self.started:
                return
            self.blackboard.set(PAUSE_KEY, paused)
            self._paused_at = self._clock() if paused else math.inf
            if not paused:
                self._remember_answer()
                self.help_request = None
                self._veto_deadline = math.inf
            self.revision += 1

    def start(self) -> typing.Tuple[bool, str]:
        """The operator's start of a tree that waits for it (``start_paused``), or of a finished one: it runs again.

        A tree that is done runs its execution composite again from the first node (the world stays as it is), so an
        operator who was still learning the gestures can go on without a relaunch. Returns whether it was started
        now, and what happened in words.
        """
        with self.lock:
            if self.completed:
                self.execution.stop(Status.INVALID)
                self.completed = False
                self.revision += 1
                return True, f"runs again: {self.execution.name} starts from its first node"
            if self.started:
                return False, "the tree was started already"
            self.started = True
            self.blackboard.set(PAUSE_KEY, False)
            self._paused_at = math.inf
            self.revision += 1
            return True, "started: the tree runs"

    def execution_state(self) -> Execution:
        """What the tree does with the robot now (see the module docstring)."""
        with self.lock:
            if not self.started:
                return Execution(ExecutionState.WAITING, "", "started paused: waiting for the operator to start it")
            if self.completed:
                return Execution(ExecutionState.COMPLETED, "", f"done: {self.execution.name} succeeded")
            if not self.paused:
                return Execution(ExecutionState.RUNNING, "", "running")
            out = self._goals_out()
            if out:
                leaf = out[0]
                if leaf.preempted:
                    message = f"paused: {leaf.skill} preempted, waiting for its end to be confirmed"
                else:
                    message = f"paused: {leaf.skill} finishes its goal (preempted after {self.preempt_after:g} s)"
                return Execution(ExecutionState.PAUSING, leaf.skill, message)
            if self.help_request is not None and self.help_request.veto_window > 0.0:
                message = f"paused: applied its proposal for {self.help_request.node_name}; an undo vetoes it"
                return Execution(ExecutionState.PAUSED, "", message)
            if self.help_request is not None:
                return Execution(ExecutionState.PAUSED, "", f"paused: asking for help ({self.help_request.node_name})")
            return Execution(ExecutionState.PAUSED, "", "paused: no skill runs")

    def _goals_out(self) -> typing.List[SkillLeaf]:
        """The suspended leaves whose goal may still move the robot."""
        return [node for node in self.root.iterate() if isinstance(node, SkillLeaf) and node.goal_out()]

    def _preempt_overdue(self) -> None:
        """Cancel the goals still out ``preempt_after`` seconds into a pause (the skills start again on resume)."""
        if self._clock() - self._paused_at < self.preempt_after:
            return
        for leaf in self._goals_out():
            if not leaf.preempted:
                leaf.preempt()
                self.revision += 1

    def _remember_answer(self) -> None:
        """The operator's answer becomes the failure's remembered repair and a demonstration of the policy."""
        help_request, edits = self.help_request, [request for change in self._answer for request in change]
        if help_request is None or not self._operator_answered:
            return
        if self.repairs.remember(help_request.node_name, help_request.reason, edits) and self.store is not None:
            self.store.save_repairs(self.repairs)
        learned = self.policy is not None and self._situation is not None and self.policy.learn(self._situation, edits)
        if learned and self.store is not None:
            self.store.save_policy(self.policy)

    def _note_answer(self, request: EditRequest) -> None:
        """Follow the open help request's answer: its edits, less the undone ones."""
        if request.operation == "undo":
            if self._answer:
                self._undone_answer.append(self._answer.pop())
        elif request.operation == "redo":
            if self._undone_answer:
                self._answer.append(self._undone_answer.pop())
        else:
            self._answer.append(self.help_request.repair if request.operation == "repair" else (request,))
            self._undone_answer = []

    def tick(self) -> bool:
        """Tick once (unless the execution is complete); return True if anything visible changed."""
        with self.lock:
            if self.paused:
                self._preempt_overdue()
            if not self.completed:
                self.tree.tick()
                self.completed = self.execution.status == Status.SUCCESS
                if self.execution.status == Status.FAILURE and self.help_request is None:
                    self._request_help_for_failed_execution()
            if self._acting:
                self._apply_proposal()
            self._go_on_after_the_veto_window()
            touched = {**self.snapshot_visitor.previous_nodes, **self.snapshot_visitor.nodes}
            states = tuple((key, node.status, node.feedback_message) for key, node in touched.items())
            signature = (self.revision, self.completed, states)
            changed = signature != self._signature
            self._signature = signature
            return changed

    def change(
        self,
        node_name: str,
        operation: str,
        index: int = 0,
        parent: str = "",
        node_type: str = "",
        parameter: float = 0.0,
    ) -> ChangeResult:
        """Apply a /change_tree request between two ticks; save the tree (and its edit history) if it changed."""
        with self.lock:
            request = EditRequest(node_name, operation, index, parent, node_type, parameter)
            if operation == "repair" and self.help_request is not None and self.help_request.repair:
                result = self.editor.apply_requests(self.help_request.repair)
                if not result.success:
                    source = "remembered repair" if self.help_request.suggestion else "proposal"
                    result = result._replace(message=f"the {source} cannot be applied: {result.message}")
            else:
                result = self.editor.change(*request)
            if not result.success:
                return result
            if self.help_request is not None:
                self._note_answer(request)
                self._follow_the_operator(request)
                self._operator_answered = True
            self.revision += 1
            revision, text = self.revision, self.tree_yaml()
        self._save(revision, text)
        return result

    def add_skill(self, name: str, kind: str, data_file: str) -> typing.Tuple[bool, str]:
        """Validate a demonstrated skill and add it to the library (then save the library)."""
        with self.lock:
            try:
                entry = self.library.add_demonstrated(name, kind, data_file, self.data_root)
            except LibraryError as error:
                return False, str(error)
            self.revision += 1
            self.library_revision += 1
            if self.store is not None:
                self.store.save_library(self.library)
        return True, f"added {entry.kind} skill '{entry.name}' ({entry.data_file})"

    def tree_yaml(self) -> str:
        """The live tree in the yaml format of config/tree.yaml."""
        with self.lock:
            return dump_live_yaml(
                self.root,
                self.execution.name,
                "saved by teleteach behaviour_tree after an edit",
                history=self.editor.history,
            )

    def _save(self, revision: int, text: str) -> None:
        if self.store is None:
            return
        with self._persist_lock:
            if revision > self._saved_revision:  # a later edit may have been saved already
                self.store.save_tree(text)
                self._saved_revision = revision

    def records(self) -> typing.Tuple[typing.List[NodeRecord], typing.Optional[NodeRecord]]:
        """Every node (root first, depth first) as log/tree reports it, and the tip.

        Records of nodes that did not change since the last call are reused (same objects), so a 1000-leaf tree
        costs little more than the nodes that changed. Everything per node is keyed by the node object (identity
        hash): it runs under the lock that /change_tree waits for.
        """
        with self.lock:
            active = self.snapshot_visitor.active
            records: typing.List[NodeRecord] = []
            tip: typing.Optional[NodeRecord] = None
            tree_tip = self.root.tip()
            cache = self._record_cache
            fresh: typing.Dict[py_trees.behaviour.Behaviour, typing.Tuple[typing.Tuple, NodeRecord]] = {}
            stack: typing.List[typing.Tuple[py_trees.behaviour.Behaviour, str]] = [(self.root, "")]
            while stack:
                node, parent_id = stack.pop()
                is_active = node in active
                awaiting = getattr(node, "awaiting_help", False)
                children = node.children
                key = (node.status, node.feedback_message, is_active, awaiting, parent_id, len(children))
                if children:
                    key += (self.revision, node.tip())
                cached = cache.get(node)
                if cached is not None and cached[0] == key:
                    record = cached[1]
                else:
                    record = self._record(node, parent_id, is_active, awaiting)
                fresh[node] = (key, record)
                records.append(record)
                if node is tree_tip:
                    tip = record
                if children:
                    own_id = record.own_id
                    stack.extend((child, own_id) for child in reversed(children))
            self._record_cache = fresh
            return records, tip

    def _record(
        self, node: py_trees.behaviour.Behaviour, parent_id: str, is_active: bool, awaiting: bool
    ) -> NodeRecord:
        node_tip = node.tip()
        return NodeRecord(
            name=node.name,
            class_name=node.skill if isinstance(node, SkillLeaf) else type(node).__name__,
            own_id=_id_text(node),
            parent_id=parent_id,
            tip_id=_id_text(node_tip) if node_tip is not None else "",
            child_ids=tuple(_id_text(child) for child in node.children),
            kind=node_type(node),
            status=Status.FAILURE if awaiting else node.status,  # an awaiting leaf is a failed skill to the operator
            message=node.feedback_message,
            is_active=is_active,
        )

    def library_entries(self) -> typing.List[SkillEntry]:
        """The skill library, predefined first."""
        with self.lock:
            return list(self.library)


def _id_text(node: py_trees.behaviour.Behaviour) -> str:
    """``str(node.id)``, kept on the node: formatting 1000 UUIDs per published tree would cost a millisecond."""
    text = node.__dict__.get("_id_text")
    if text is None:
        text = node._id_text = str(node.id)
    return text
