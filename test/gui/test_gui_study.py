"""A user study in the real GUI: the study node's ROS layer (in this process) tells the window where the session
stands; a participant (the device stand-in) reads the instructions, starts at the centre, does the task in the tabs
against the real behaviour tree (with one wrong selection), and answers the questionnaire with the device.
Screenshots of every screen go to test-artifacts/ (look at them as a participant would)."""

import pathlib
import time

import pytest
from conftest import ROOT, pump, pump_until

from teleteach.core.active_tab import Tab

pytestmark = pytest.mark.gui
EXAMPLE = ROOT / "config" / "studies" / "example.yaml"


def button_x(index, count=23):
    return -0.1 + (index + 0.5) * 0.2 / count


@pytest.fixture
def study_node(ros_master):
    """The study node's ROS layer in this process, for the example study's participant P01."""
    from teleteach.study.ordering import session_plan
    from teleteach.study.ros import StudyRos
    from teleteach.study.schema import load_study
    from teleteach.study.trial import StudyFlow

    study = load_study(EXAMPLE)
    flow = StudyFlow(study, "P01", trials=8)
    ros = StudyRos(flow)
    yield study, session_plan(study, "P01"), flow, ros
    ros.close()  # later tests' windows must not hear this study's latched state


def test_a_participant_goes_through_a_trial_and_the_questionnaire(
    qapp, bt_node, make_window, device, study_node, artifacts_dir: pathlib.Path
):
    import rospy

    from teleteach.core.study_phase import Phase
    from teleteach.srv import StudyInput
    from teleteach.study.metrics import TrialMetrics
    from teleteach.study.scripted import slider_x

    study, plan, flow, ros = study_node
    task = study.task(plan[0].task)
    metrics = TrialMetrics(task.intended, contact_threshold=10.0)
    ros.begin_trial(task.goal, None, metrics)
    window = make_window()
    page = window.study_page
    flow.instructions(plan[0])
    ros.publish()
    pump_until(qapp, lambda: window.pages.currentWidget() is page, 10, "the study's page")
    pump_until(qapp, lambda: page.title.text() == task.title, 5, "the task's title")
    assert "Take PlaceItem out of its plan" in page.body.text() and page.target.isVisible()

    # a click away from the centre does not start the trial
    device.move(x=0.05)
    pump(qapp, 0.4)
    device.click()
    pump(qapp, 0.6)
    assert flow.phase == Phase.INSTRUCTIONS and "centre" in page.message.text()
    device.move(0.0, 0.0, 0.0)
    pump(qapp, 0.4)
    window.screenshot().save(str(artifacts_dir / "study_1_instructions.png"))
    device.click()
    pump_until(qapp, lambda: flow.phase == Phase.RUNNING, 10, "the start gesture taken by the study node")
    ros.publish()
    pump_until(qapp, lambda: window.pages.currentWidget() is window.tabs, 5, "the tabs")
    assert window.study_banner.isVisible() and "Trial 1 of 8" in window.study_banner.text()

    def judge_until(predicate, timeout, what):
        end = time.monotonic() + timeout
        while time.monotonic() < end and not predicate():
            flow.update(time.monotonic(), ros.judgement())
            ros.publish()
            pump(qapp, 0.1)
        assert predicate(), what

    # the task: HIGH-LEVEL, first the wrong node (MoveBase), back to START, then PlaceItem and remove
    device.move(x=-0.05)
    pump(qapp, 0.4)
    device.click()
    pump_until(qapp, lambda: window._tab == Tab.HIGH_LEVEL, 10, "HIGH-LEVEL")
    pump_until(qapp, lambda: len(window.high_level.flow.choices) == 23, 10, "the 23 buttons")
    for index in (3, None, 4):
        if index is None:  # the gripper opened fully: back to START, in again
            device.set_gripper(0.5)
            pump_until(qapp, lambda: window._tab == Tab.START, 10, "START")
            device.set_gripper(0.25)
            device.move(x=-0.05)
            pump(qapp, 0.4)
            device.click()
            pump_until(qapp, lambda: window._tab == Tab.HIGH_LEVEL, 10, "HIGH-LEVEL again")
            continue
        device.move(x=button_x(index))
        pump(qapp, 0.5)
        device.click()
        pump(qapp, 0.5)
    window.screenshot().save(str(artifacts_dir / "study_2_running.png"))
    device.move(x=button_x(4), y=-0.075)
    pump(qapp, 0.5)
    device.click()
    judge_until(lambda: flow.phase == Phase.DONE, 15, "the tree without PlaceItem")
    success, task_time, status = flow.outcome
    assert success and status == "PlaceItem removed" and task_time > 1.0
    choices = [(s.tab, s.step, s.choice) for s in metrics.selections]
    assert choices == [
        ("START", "mode", "HIGH_LEVEL"),
        ("HIGH_LEVEL", "node", "MoveBase"),
        ("START", "mode", "HIGH_LEVEL"),
        ("HIGH_LEVEL", "node", "PlaceItem"),
        ("HIGH_LEVEL", "operation", "remove"),
    ]
    assert metrics.wrong_selections == 1
    pump_until(qapp, lambda: window.pages.currentWidget() is page, 5, "the end of the trial")
    pump_until(qapp, lambda: page.title.text().startswith("Done in"), 5, "'Done in'")
    window.screenshot().save(str(artifacts_dir / "study_3_done.png"))

    # the questionnaire, answered with device X and clicks; one answer corrected with the back gesture
    ros.end_trial()
    flow.questionnaire(plan[4])
    ros.publish()
    items = study.questionnaire
    pump_until(qapp, lambda: page.title.text().startswith("Mental Demand"), 10, "the first item")
    meant = {item.name: item.value(position) for item, position in zip(items, (3, 12, 20, 0, 9, 15, 5))}
    proxy = rospy.ServiceProxy("study/input", StudyInput)
    # Expect answers that do not fit refused with the reason, nothing taken
    answer = proxy("questionnaire", [item.name for item in items], [50.0] * len(items))
    assert not answer.success and "in_control: 50.0 is not on its scale" in answer.message
    assert flow.answers is None
    for number, item in enumerate(items):
        device.move(x=slider_x(item, 100.0 if number == 1 else meant[item.name], 0.1))
        pump(qapp, 0.4)
        if number in (2, len(items) - 1):  # a NASA-TLX subscale, the Likert item
            window.screenshot().save(str(artifacts_dir / f"study_4_questionnaire_{item.name}.png"))
        device.click()
        pump(qapp, 0.4)
        if number == 1:  # physical demand was meant lower: back, and again
            device.move(x=0.0, z=-0.07)
            pump(qapp, 0.4)
            device.click()
            pump(qapp, 0.4)
            assert page.title.text().startswith("Physical Demand")
            device.move(x=slider_x(item, meant[item.name], 0.1))
            pump(qapp, 0.4)
            device.click()
            pump(qapp, 0.4)
    device.move(0.0, 0.0, 0.0)
    pump_until(qapp, lambda: page.title.text() == "Your answers", 5, "the summary")
    window.screenshot().save(str(artifacts_dir / "study_5_review.png"))
    device.click()
    pump_until(qapp, lambda: flow.answers is not None, 10, "the answers taken by the study node")
    assert flow.answers == meant
    pump_until(qapp, lambda: page.title.text() == "Thank you", 5, "thank you")
    flow.finish()
    ros.publish()
    pump(qapp, 0.5)
    window.screenshot().save(str(artifacts_dir / "study_6_finished.png"))


def test_a_selection_heard_after_the_goal_was_met_counts_when_it_was_made_before(qapp, study_node):
    import rospy

    from teleteach.msg import Behaviour, BehaviourTree, Selection
    from teleteach.study.metrics import TrialMetrics

    study, plan, flow, ros = study_node
    task = study.task(plan[0].task)
    assert task.goal.tree.absent == ("PlaceItem",)
    metrics = TrialMetrics(task.intended, contact_threshold=10.0)
    ros.begin_trial(task.goal, None, metrics)
    flow.instructions(plan[0])
    assert flow.start(time.monotonic())[0]
    trees = rospy.Publisher("behaviour_tree/log/tree", BehaviourTree, queue_size=1, latch=True)
    selections = rospy.Publisher("teleteach/selection", Selection, queue_size=10)
    pump_until(qapp, lambda: selections.get_num_connections() > 0, 10, "the study node to hear selections")

    def selection(step, choice, stamp):
        message = Selection(tab="HIGH_LEVEL", step=step, choice=choice)
        message.header.stamp = rospy.Time.from_sec(stamp)
        selections.publish(message)

    selection("node", "PlaceItem", 99.0)
    pump_until(qapp, lambda: len(metrics.selections) == 1, 10, "the node's selection")
    # The edit's tree (stamped 100 s) is judged before the operation's selection (stamped 99.5 s) arrives
    tree = BehaviourTree()
    tree.header.stamp = rospy.Time.from_sec(100.0)
    tree.behaviours = [
        Behaviour(own_id="1", name="BehaviorExecution", child_ids=["2"]),
        Behaviour(own_id="2", name="PickItem"),
    ]
    trees.publish(tree)
    pump_until(qapp, lambda: ros.trees_heard > 0, 10, "the tree")
    assert flow.update(time.monotonic(), ros.judgement())
    selection("operation", "remove", 99.5)  # made before the tree changed: part of the trial
    selection("node", "Idle", 100.5)  # made after the goal was met: not part of it
    pump(qapp, 1.0)
    # Expect the trial's record to end with the selection that did the task, at the trial's end, and nothing after
    assert [(s.step, s.choice) for s in metrics.selections] == [("node", "PlaceItem"), ("operation", "remove")]
    assert metrics.selections[-1].time == pytest.approx(flow.outcome[1])
    ros.end_trial()
    trees.unregister()
    selections.unregister()
