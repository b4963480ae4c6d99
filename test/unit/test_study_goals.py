"""Goals judged from the world (tree, stiffness, placement), what a trial measures, and the session's flow."""

import math
import pathlib

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.core.questionnaire import NASA_TLX, AnswerError, check_answers, raw_tlx
from teleteach.core.scene import load_scene
from teleteach.core.study_phase import Phase
from teleteach.study.goals import Goal, GoalJudge, PlacementGoal, StiffnessGoal, TreeGoal, TreeView
from teleteach.study.metrics import TrialMetrics
from teleteach.study.ordering import session_plan
from teleteach.study.schema import load_study
from teleteach.study.trial import StudyFlow

ROOT = pathlib.Path(__file__).resolve().parents[2]
TREE = TreeView(
    ("Root", "PauseCondition", "BehaviorExecution", "LookToShelf", "PickItem", "PlaceItem"),
    {"Root": ("PauseCondition", "BehaviorExecution"), "BehaviorExecution": ("LookToShelf", "PickItem", "PlaceItem")},
)
EDITED = TreeView(
    ("Root", "PauseCondition", "BehaviorExecution", "LookToShelf", "PickItem"),
    {"Root": ("PauseCondition", "BehaviorExecution"), "BehaviorExecution": ("LookToShelf", "PickItem")},
)


def test_a_tree_goal_is_met_by_the_tree_and_says_what_is_missing():
    goal = TreeGoal(absent=("PlaceItem",))
    assert goal.check(None) == (False, "no tree heard yet")
    assert goal.check(TREE) == (False, "PlaceItem is still in the tree")
    assert goal.check(EDITED) == (True, "PlaceItem removed")
    order = TreeGoal(present=("PickItem",), children={"BehaviorExecution": ("LookToShelf", "PickItem")})
    assert order.check(TREE) == (False, "BehaviorExecution: LookToShelf, PickItem, PlaceItem")
    assert order.check(EDITED) == (True, "PickItem in the tree; BehaviorExecution as asked")


def test_a_stiffness_goal_holds_for_its_time_and_an_excursion_starts_the_hold_again():
    bounds = ((50.0, 800.0), (2000.0, 3000.0), None)
    judge = GoalJudge(Goal(stiffness=StiffnessGoal(bounds, hold=1.0)))
    judge.stiffness(0.0, (500.0, 1525.0, 1525.0))
    assert judge.judgement(0.5).status == "X 500 N/m (50-800: ok), Y 1525 N/m (2000-3000: too low)"
    for time in np.arange(1.0, 1.95, 0.1):
        judge.stiffness(time, (492.0, 2705.0, 3000.0))  # Z is free
    assert not judge.judgement(1.95).met
    assert judge.judgement(2.0).met
    judge.stiffness(2.05, (900.0, 2705.0, 492.0))  # X too high for a moment
    judge.stiffness(2.1, (492.0, 2705.0, 492.0))
    judgement = judge.judgement(2.5)
    assert not judgement.met and judgement.status.endswith("held 0.4 of 1 s")
    judge.stiffness(2.2, (math.nan, 2705.0, 492.0))  # a NaN command is not a stiffness: ignored
    assert judge.judgement(3.1).met


def test_a_placement_goal_needs_the_product_upright_in_its_gap_with_the_neighbours_in_place():
    scene = load_scene()
    gap = scene.gap("gap_1")
    upright = np.array([0.0, 0.0, 0.0, 1.0])
    start = {product.name: (np.array(product.position), upright) for product in scene.products}
    judge = GoalJudge(Goal(placement=PlacementGoal("product_pick_1", "gap_1", hold=1.0)), scene)
    judge.scene_products(0.0, start)
    assert not judge.judgement(0.0).met
    placed = dict(start, product_pick_1=(np.array(gap.position), upright))
    judge.scene_products(1.0, placed)
    assert not judge.judgement(1.5).met
    assert judge.judgement(2.0).met
    assert judge.judgement(2.0).status == "product_pick_1 upright in gap_1; held 1.0 of 1 s"
    tilted = Rotation.from_euler("x", 30, degrees=True).as_quat()
    judge.scene_products(2.1, dict(placed, product_pick_1=(np.array(gap.position), tilted)))
    judgement = judge.judgement(5.0)
    assert not judgement.met and judgement.status == "product_pick_1 is not upright (tilted 30 deg)"
    with pytest.raises(ValueError, match="needs the scene"):
        GoalJudge(Goal(placement=PlacementGoal("product_pick_1", "gap_1")))


def test_every_kind_of_a_goal_must_hold_at_once():
    goal = Goal(tree=TreeGoal(absent=("PlaceItem",)), stiffness=StiffnessGoal(((50.0, 800.0), None, None), 0.5))
    judge = GoalJudge(goal)
    judge.tree(EDITED)
    judge.stiffness(0.0, (1000.0, 1.0, 1.0))
    assert not judge.judgement(1.0).met
    judge.stiffness(1.0, (500.0, 1.0, 1.0))
    assert judge.judgement(1.5).met
    judge.tree(TREE)
    assert judge.judgement(1.6).status.startswith("PlaceItem is still in the tree; X 500 N/m")


def test_a_trial_counts_wrong_selections_undos_help_requests_and_contacts():
    metrics = TrialMetrics({"mode": "HIGH_LEVEL", "node": "PlaceItem", "operation": "remove"}, contact_threshold=10.0)
    for time, tab, step, choice in (
        (1.0, "START", "mode", "HIGH_LEVEL"),
        (2.0, "HIGH_LEVEL", "node", "MoveBase"),  # wrong
        (3.0, "HIGH_LEVEL", "operation", "remove"),
        (4.0, "HIGH_LEVEL", "undo", ""),
        (5.0, "HIGH_LEVEL", "node", "PlaceItem"),
        (6.0, "HIGH_LEVEL", "operation", "insert"),  # wrong
        (7.0, "HIGH_LEVEL", "index", "3"),  # no intended index: not judged
    ):
        metrics.selection(time, tab, step, choice)
    for node, reason in (
        ("PickItem", "not on the table"),
        ("PickItem", "not on the table"),
        ("", ""),
        ("PickItem", "x"),
    ):
        metrics.help_request(1.0, node, reason)
    for force in (2.0, 12.0, 11.0, 6.0, 12.0, 4.0, 30.0, math.nan):
        metrics.wrench((force, 0.0, 0.0), (0.0, 0.0, 0.1))
    summary = metrics.summary()
    assert (summary["wrong_selections"], summary["undo_count"], summary["help_requests"]) == (2, 1, 2)
    # Expect contacts counted again only after the force fell below half the threshold (6 N did not, 4 N did)
    assert (summary["contacts"], summary["peak_force_n"], summary["peak_torque_nm"]) == (2, 30.0, 0.1)


def test_the_stiffness_profile_is_kept_with_its_times():
    metrics = TrialMetrics({}, 10.0)
    metrics.eigenvalues(0.25, (500.0, 1525.0, 1525.0))
    metrics.eigenvalues(0.5, (math.inf, 1.0, 1.0))
    metrics.eigenvalues(0.75, (492.0, 2705.0, 492.0))
    assert metrics.stiffness_csv().splitlines() == [
        "time_s,kx_n_per_m,ky_n_per_m,kz_n_per_m",
        "0.2500,500.0,1525.0,1525.0",
        "0.7500,492.0,2705.0,492.0",
    ]
    assert metrics.summary()["stiffness_final_n_per_m"] == [492.0, 2705.0, 492.0]


def test_raw_tlx_is_the_mean_of_the_six_subscales_and_answers_must_fit_their_items():
    answers = dict(zip([item.name for item in NASA_TLX], (10.0, 20.0, 30.0, 40.0, 50.0, 60.0)))
    assert raw_tlx(answers) == 35.0
    with pytest.raises(AnswerError, match="missing frustration"):
        raw_tlx({name: value for name, value in answers.items() if name != "frustration"})
    names = [item.name for item in NASA_TLX]
    assert check_answers(NASA_TLX, names, list(answers.values())) == answers
    with pytest.raises(AnswerError, match="mental_demand: 12.0 is not on its scale"):
        check_answers(NASA_TLX, names, [12.0, 20.0, 30.0, 40.0, 50.0, 60.0])
    with pytest.raises(AnswerError, match="must name the items"):
        check_answers(NASA_TLX, list(reversed(names)), list(answers.values()))


def test_the_session_flow_takes_inputs_only_in_their_phase():
    study = load_study(ROOT / "config" / "studies" / "example.yaml")
    plan = session_plan(study, "P01")
    flow = StudyFlow(study, "P01", trials=8)
    assert flow.start(0.0) == (False, "no trial waits for its start (phase PREPARING)")
    flow.instructions(plan[0])
    view = flow.view(0.0)
    assert (view.phase, view.task, view.trial, view.timeout) == (Phase.INSTRUCTIONS, "remove_place_item", 1, 40.0)
    assert flow.start(10.0) == (True, "trial 1 started")
    assert flow.start(10.5)[0] is False
    from teleteach.study.goals import Judgement

    assert not flow.update(15.0, Judgement(False, "PlaceItem is still in the tree"))
    assert flow.view(16.0).elapsed == 6.0
    assert flow.update(18.0, Judgement(True, "PlaceItem removed"))
    assert flow.outcome == (True, 8.0, "PlaceItem removed")
    assert flow.view(30.0).elapsed == 8.0  # the clock stopped at the end
    flow.instructions(plan[1])
    flow.start(100.0)
    assert flow.update(140.0, Judgement(False, "PlaceItem is still in the tree"))
    assert flow.outcome == (False, 40.0, "time is up (40 s): PlaceItem is still in the tree")
    questionnaire = plan[4]
    flow.questionnaire(questionnaire)
    names = [item.name for item in study.questionnaire]
    assert flow.answer(names, [50.0] * 7)[0] is False  # 50 is not on the 7-point item's scale
    assert flow.answers is None
    assert flow.answer(names, [50.0] * 6 + [4.0]) == (True, "7 answers taken")
    assert flow.answer(names, [50.0] * 6 + [4.0]) == (False, "the answers were already taken")
    assert flow.answers["in_control"] == 4.0
    assert len(flow.view(0.0).items) == 7
