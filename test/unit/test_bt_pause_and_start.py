"""Starting paused, and pausing until the arm is free: what the tree reports (teleteach/TreeExecution) and does."""

from bt_support import THESIS_SEQUENCE, SkillWorld, status_of, thesis_tree
from py_trees.common import Status

from teleteach.bt.teaching import ExecutionState
from teleteach.msg import TreeExecution


class Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def test_the_execution_states_are_the_messages_constants():
    constants = {name: getattr(TreeExecution, name) for name in ExecutionState.__members__}
    assert constants == {state.name: state.value for state in ExecutionState}


def test_a_tree_that_starts_paused_runs_nothing_until_the_operator_starts_it():
    world = SkillWorld(ticks=2)
    tree = thesis_tree(world, start_paused=True)
    for _ in range(20):
        tree.tick()
    # Expect nothing started and the tree saying it waits (not merely paused)
    assert world.events == []
    assert tree.execution_state().state == ExecutionState.WAITING
    # a resume is no start (a GUI's latched "not paused" may be older than this tree)
    tree.set_pause(True)
    tree.set_pause(False)
    for _ in range(5):
        tree.tick()
    assert world.events == [] and tree.execution_state().state == ExecutionState.WAITING
    assert tree.start() == (True, "started: the tree runs")
    tree.tick()
    # Expect the first skill to run at once after the operator's start, and a second start changing nothing
    assert world.names("start") == ["LookToShelf"]
    assert tree.execution_state().state == ExecutionState.RUNNING
    assert tree.start() == (False, "the tree was started already")
    # a later pause is a pause, not a wait
    tree.set_pause(True)
    assert tree.execution_state().state != ExecutionState.WAITING


def test_a_pause_keeps_the_goal_then_preempts_it_and_the_skill_runs_again_on_resume():
    world = SkillWorld(ticks=5)
    clock = Clock()
    tree = thesis_tree(world, preempt_after=10.0, clock=clock)
    tree.tick()
    tree.set_pause(True)
    clock.now += 9.0
    tree.tick()
    # Expect the running skill's goal still out (it finishes what it does) and the arm not free
    state = tree.execution_state()
    assert (state.state, state.skill) == (ExecutionState.PAUSING, "LookToShelf")
    assert world.names("cancel") == []
    clock.now += 1.5
    tree.tick()
    # Expect the goal cancelled after preempt_after, the arm free, no help request
    assert world.names("cancel") == ["LookToShelf"]
    assert tree.execution_state().state == ExecutionState.PAUSED
    assert tree.help_request is None
    tree.set_pause(False)
    for _ in range(200):
        if tree.completed:
            break
        tree.tick()
    # Expect LookToShelf started again, then the whole sequence, and nothing asked of the operator
    assert world.names("start")[:2] == ["LookToShelf", "LookToShelf"]
    assert world.names("succeed") == THESIS_SEQUENCE
    assert tree.help_request is None
    assert tree.execution_state().state == ExecutionState.COMPLETED


def test_a_goal_that_succeeded_before_the_cancel_reached_it_is_not_run_again():
    world = SkillWorld(ticks=5)
    clock = Clock()
    tree = thesis_tree(world, preempt_after=1.0, clock=clock)
    tree.tick()
    leaf = tree.editor.nodes["LookToShelf"]
    leaf.finished_before_preempt = lambda: True
    tree.set_pause(True)
    clock.now += 2.0
    tree.tick()
    tree.set_pause(False)
    tree.tick()
    # Expect LookToShelf taken as done and PickItem next, LookToShelf never restarted
    assert world.names("start") == ["LookToShelf", "PickItem"]
    assert status_of(tree, "LookToShelf") == Status.SUCCESS


def test_a_help_request_is_paused_with_the_arm_free():
    world = SkillWorld(ticks=1, failures={"LookToShelf": ["the shelf is not in view"]})
    tree = thesis_tree(world)
    for _ in range(5):
        tree.tick()
    state = tree.execution_state()
    assert state.state == ExecutionState.PAUSED and "LookToShelf" in state.message


def test_a_tree_that_is_done_runs_again_from_its_first_node_when_started():
    world = SkillWorld(ticks=2)
    tree = thesis_tree(world)
    for _ in range(3 * len(THESIS_SEQUENCE)):
        tree.tick()
    assert tree.execution_state().state == ExecutionState.COMPLETED
    world.events.clear()
    for _ in range(5):
        tree.tick()
    # Expect a done tree to tick nothing until it is started again
    assert world.events == []
    assert tree.start() == (True, "runs again: BehaviorExecution starts from its first node")
    tree.tick()
    # Expect the first node to run at once, and every node again in order
    assert world.names("start") == [THESIS_SEQUENCE[0]]
    assert tree.execution_state().state == ExecutionState.RUNNING
    assert tree.start() == (False, "the tree was started already")
    for _ in range(3 * len(THESIS_SEQUENCE)):
        tree.tick()
    assert world.names("succeed") == THESIS_SEQUENCE
    assert tree.execution_state().state == ExecutionState.COMPLETED
    assert status_of(tree, "BehaviorExecution") == Status.SUCCESS
