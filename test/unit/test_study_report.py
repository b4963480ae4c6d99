"""study_report: the numbers of a study folder, checked against independent computations of the same data."""

import csv
import dataclasses
import json
import pathlib
import textwrap

import numpy as np
import pytest
from scipy import stats

from teleteach.core.questionnaire import TLX_NAMES
from teleteach.study.ordering import QUESTIONNAIRE
from teleteach.study.report import (
    Comparison,
    Report,
    ReportError,
    StudyData,
    analyse,
    compare,
    describe,
    draw_figures,
    make_report,
    markdown,
    rank_biserial,
)
from teleteach.study.schema import load_study
from teleteach.study.storage import ParticipantStore

ROOT = pathlib.Path(__file__).resolve().parents[2]
STUDY = load_study(ROOT / "config" / "studies" / "example.yaml")
PARTICIPANTS = ("P01", "P02", "P03", "P04", "P05", "P06")


def made_up_time(participant, step):
    """Guided trials faster by 1-3 s, later repetitions faster (a learning effect), one timeout."""
    number = int(participant[1:])
    base = 12.0 + number - 2.0 * (step.repetition - 1)
    return base - (1.0 + 0.4 * number if step.condition == "guided" else 0.0)


def fill(root, participants=PARTICIPANTS, stop_after=None):
    for participant in participants:
        store = ParticipantStore(STUDY, participant, root)
        store.open(resume=False)
        for index, step in enumerate(store.plan):
            if stop_after is not None and index >= stop_after:
                break
            if step.kind == QUESTIONNAIRE:
                number = int(participant[1:])
                answers = {name: 5.0 * ((number + offset) % 21) for offset, name in enumerate(TLX_NAMES)}
                if step.condition == "unguided":
                    answers = {name: min(100.0, value + 15.0) for name, value in answers.items()}
                answers["in_control"] = 6.0 if step.condition == "guided" else 3.0
                store.save_questionnaire(
                    step, {"participant": participant, "condition": step.condition, "answers": answers}
                )
                continue
            store.begin_trial(step)
            timed_out = participant == "P03" and step.key == "02_guided_remove_place_item_2"
            store.finish_trial(
                step,
                {
                    "participant": participant,
                    "condition": step.condition,
                    "task": step.task,
                    "repetition": step.repetition,
                    "trial": step.trial,
                    "success": not timed_out,
                    "task_time_s": 40.0 if timed_out else made_up_time(participant, step),
                    "wrong_selections": (1 if step.condition == "unguided" and int(participant[1:]) % 2 else 0),
                    "undo_count": 0,
                    "help_requests": 0,
                    "peak_force_n": 2.0,
                    "contacts": 0,
                },
            )
        store.close()
    return root / "studies" / STUDY.name


def read_csv(path):
    with open(path) as stream:
        return list(csv.DictReader(stream))


def test_the_report_s_numbers_are_those_of_the_trials(tmp_path):
    folder = fill(tmp_path)
    report = make_report(folder)
    trials = read_csv(report.folder / "trials.csv")
    assert len(trials) == 6 * 8
    # Expect the times written by fill(), not the report's own trials.csv (a time misread would be in both)
    written = {
        (participant, step.task, step.condition, step.repetition): made_up_time(participant, step)
        for participant in PARTICIPANTS
        for step in ParticipantStore(STUDY, participant).plan
        if step.kind != QUESTIONNAIRE
    }
    written[("P03", "remove_place_item", "guided", 2)] = 40.0  # the timeout
    assert len(written) == 6 * 8
    assert {
        (row["participant"], row["task"], row["condition"], int(row["repetition"])): float(row["task_time_s"])
        for row in trials
    } == pytest.approx(written)
    guided_remove = [
        made_up_time(participant, step)
        for participant in PARTICIPANTS
        for step in _steps(participant, "guided", "remove_place_item")
        if (participant, step.key) != ("P03", "02_guided_remove_place_item_2")
    ]
    summary = next(row for row in report.summary if (row["condition"], row["task"]) == ("guided", "remove_place_item"))
    # Expect 12 trials, 11 successes (P03's timeout left out of the times), mean / sd / median of those 11
    assert (summary["trials"], summary["successes"], len(guided_remove)) == (12, 11, 11)
    assert summary["task_time_s_mean"] == pytest.approx(np.mean(guided_remove))
    assert summary["task_time_s_sd"] == pytest.approx(np.std(guided_remove, ddof=1))
    assert summary["task_time_s_median"] == pytest.approx(np.median(guided_remove))
    unguided = next(row for row in report.summary if (row["condition"], row["task"]) == ("unguided", "stiffen_y"))
    assert unguided["wrong_selections_mean"] == pytest.approx(0.5)
    tlx = read_csv(report.folder / "tlx.csv")
    assert len(tlx) == 12
    first = next(row for row in tlx if (row["participant"], row["condition"]) == ("P01", "guided"))
    assert float(first["raw_tlx"]) == pytest.approx(np.mean([float(first[name]) for name in TLX_NAMES]))
    assert len(read_csv(report.folder / "questionnaires.csv")) == 12 * 7
    assert report.folder == folder / "report" and len(report.tlx) == 12
    # Expect each CSV's columns: the answers one per line, the TLX with the study's own items after the subscales,
    # the summary with every figure of report.summary
    answers = read_csv(report.folder / "questionnaires.csv")
    assert list(answers[0]) == ["participant", "condition", "item", "value"]
    conditions = {"guided", "unguided"}
    assert {(row["participant"], row["condition"]) for row in answers} == {
        (p, c) for p in PARTICIPANTS for c in conditions
    }
    assert list(tlx[0])[: 3 + len(TLX_NAMES)] == ["participant", "condition", "raw_tlx", *TLX_NAMES]
    assert list(tlx[0])[3 + len(TLX_NAMES) :] == sorted({row["item"] for row in answers} - set(TLX_NAMES))
    header = (report.folder / "tlx.csv").read_text().splitlines()[0]
    assert header == ",".join(["participant", "condition", "raw_tlx", *TLX_NAMES, "in_control"])
    in_control = {
        (row["participant"], row["condition"]): row["value"] for row in answers if row["item"] == "in_control"
    }
    assert in_control[("P01", "guided")] == "6" and in_control[("P04", "unguided")] == "3"
    assert list(read_csv(report.folder / "summary.csv")[0]) == list(report.summary[0])
    again = make_report(folder)  # a report made again replaces the first
    assert again.folder == report.folder and (again.folder / "report.md").is_file()
    nested = make_report(folder, tmp_path / "a" / "b")  # an output folder is created with its parents
    assert (nested.folder / "report.md").is_file()
    markdown = (report.folder / "report.md").read_text()
    assert markdown.startswith(f"# Study {folder.name}\n")
    assert "6 participants (6 complete: P01, P02, P03, P04, P05, P06), 48 trials, 12 questionnaires" in markdown
    assert "| guided | remove_place_item | 12 | 11 |" in markdown
    assert "Conditions: guided, unguided; tasks: remove_place_item, stiffen_y." in markdown
    for figure in ("task_time.png", "wrong_selections.png", "tlx.png", "learning_curves.png"):
        assert (report.folder / figure).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_paired_comparison_is_scipy_s_wilcoxon_on_the_participants_means(tmp_path):
    report = make_report(fill(tmp_path))
    comparison = next(c for c in report.comparisons if (c.measure, c.task) == ("task_time_s", "stiffen_y"))
    # independent: each participant's mean over the two repetitions, per condition
    guided = [np.mean([made_up_time(p, step) for step in _steps(p, "guided", "stiffen_y")]) for p in PARTICIPANTS]
    unguided = [np.mean([made_up_time(p, step) for step in _steps(p, "unguided", "stiffen_y")]) for p in PARTICIPANTS]
    expected = stats.wilcoxon(guided, unguided)
    assert comparison.n == 6 and comparison.p_value == pytest.approx(expected.pvalue)
    assert comparison.statistic == pytest.approx(expected.statistic)
    assert comparison.effect_size_r == pytest.approx(-1.0)  # every participant faster with guidance
    assert comparison.median_difference == pytest.approx(np.median(np.subtract(guided, unguided)))
    tlx = next(c for c in report.comparisons if c.measure == "raw_tlx")
    assert tlx.n == 6 and tlx.effect_size_r < 0
    errors = next(c for c in report.comparisons if (c.measure, c.task) == ("wrong_selections", "stiffen_y"))
    assert errors.p_value is not None and errors.effect_size_r == pytest.approx(-1.0)
    assert "normal approximation" in errors.note  # zeros: scipy's approximation, said in the table
    assert comparison.note == ""  # no ties, no zeros: exact
    rows = read_csv(report.folder / "comparisons.csv")
    assert len(rows) == len(report.comparisons) == 2 * 2 + 2  # 2 tasks x 2 measures, raw TLX, in_control


def _steps(participant, condition, task):
    store = ParticipantStore(STUDY, participant)
    return [step for step in store.plan if (step.condition, step.task) == (condition, task)]


def test_the_rank_biserial_correlation_by_hand():
    # |d| ranks 1, 2, 3, 4: positive ranks 1 + 2 + 3 = 6, negative 4 -> (6 - 4) / 10; zeros are dropped
    assert rank_biserial([0.5, 1.0, 0.0, 2.0, -3.0]) == pytest.approx(0.2)
    assert rank_biserial([0.0, 0.0]) == 0.0
    # ties share their rank: |d| 1, 1, 2 -> ranks 1.5, 1.5, 3: (1.5 + 3 - 1.5) / 6
    assert rank_biserial([1.0, -1.0, 2.0]) == pytest.approx(0.5)
    assert rank_biserial([2.0, 0.5]) == 1.0 and rank_biserial([-2.0, -0.5]) == -1.0


def test_a_description_by_hand_leaves_out_what_is_missing_and_says_none_where_undefined():
    # 1, 2, 6: mean 3, sd sqrt((4 + 1 + 9) / 2) = sqrt(7) (n - 1), median 2
    assert describe([1.0, None, 2.0, float("nan"), 6.0]) == pytest.approx(
        {"n": 3, "mean": 3.0, "sd": np.sqrt(7.0), "median": 2.0}
    )
    assert describe([1.0, 2.0]) == pytest.approx({"n": 2, "mean": 1.5, "sd": np.sqrt(0.5), "median": 1.5})
    assert describe([5.0]) == {"n": 1, "mean": 5.0, "sd": None, "median": 5.0}
    assert describe([None]) == {"n": 0, "mean": None, "sd": None, "median": None}


def test_the_wilcoxon_comparison_by_hand():
    pairs = {"P1": (3, 1), "P2": (5, 2), "P4": (2, 6), "P5": (7, 1), "P6": (1, 2), "P7": (9, 3)}
    result = compare("task_time_s", "remove", "guided", "unguided", pairs)
    assert (result.measure, result.task, result.first, result.second) == ("task_time_s", "remove", "guided", "unguided")
    # medians of 1 2 3 5 7 9, of 1 1 2 2 3 6 and of the differences -4 -1 2 3 6 6
    assert (result.n, result.median_first, result.median_second, result.median_difference) == (6, 4.0, 2.0, 2.5)
    # |d| ranks: 2 -> 2, 3 -> 3, 4 -> 4, 6 -> 5.5, 1 -> 1, 6 -> 5.5: W+ = 16, W- = 5; exact two-sided p: 10 of the
    # 64 sign patterns have W <= 5, so p = 2 * 10 / 64; r = (16 - 5) / 21
    assert result.statistic == 5.0 and result.p_value == pytest.approx(20 / 64)
    assert result.effect_size_r == pytest.approx(11 / 21) and result.note == ""
    one = compare("task_time_s", "remove", "guided", "unguided", {"P1": (1, 1), "P2": (2, 2), "P3": (3, 4)})
    assert (one.n, one.median_first, one.median_second, one.median_difference) == (3, 2.0, 2.0, 0.0)
    assert one.statistic is None and one.p_value is None and one.effect_size_r is None
    assert one.note == "no test: 1 participant(s) with a difference (of 3 paired)"
    assert (one.measure, one.task, one.first, one.second) == ("task_time_s", "remove", "guided", "unguided")
    # a zero difference: scipy's normal approximation, both of its warnings in the note; d = 3, -4, 6, -1, 6 without
    # the zero: |d| ranks 2, 3, 4.5, 1, 4.5, so W- = 3 + 1
    zero = compare("task_time_s", "remove", "guided", "unguided", {**pairs, "P1": (3, 3)})
    assert zero.statistic == 4.0 and zero.note == (
        "Exact p-value calculation does not work if there are zeros. Switching to normal approximation.; "
        "Sample size too small for normal approximation."
    )
    two = compare("task_time_s", "remove", "guided", "unguided", {"P1": (1, 2), "P2": (2, 4)})
    assert two.p_value == pytest.approx(0.5) and two.effect_size_r == -1.0  # W = 0 of n = 2: p = 2 * 1 / 4
    none = compare("task_time_s", "remove", "guided", "unguided", {})
    assert (none.n, none.median_first, none.median_second, none.median_difference) == (0, None, None, None)


def test_too_few_pairs_are_said_not_tested_and_incomplete_participants_are_named(tmp_path):
    folder = fill(tmp_path, participants=("P01", "P02"), stop_after=5)  # one condition each: no pairs
    report = make_report(folder, tmp_path / "out")
    assert all(comparison.p_value is None for comparison in report.comparisons)
    note = next(c for c in report.comparisons if (c.measure, c.task) == ("task_time_s", "remove_place_item")).note
    assert note == "no test: 0 participant(s) with a difference (of 0 paired)"
    # Expect: an undefined value is an empty cell, lines end in a bare newline
    written = (tmp_path / "out" / "comparisons.csv").read_bytes()
    assert b"\r" not in written
    assert {row["p_value"] for row in read_csv(tmp_path / "out" / "comparisons.csv")} == {""}
    markdown = (tmp_path / "out" / "report.md").read_text()
    assert "Incomplete: P01 (5 of 10 steps), P02 (5 of 10 steps)" in markdown


def test_a_folder_without_a_study_is_one_error(tmp_path):
    with pytest.raises(ReportError, match="is not a study folder"):
        make_report(tmp_path / "nothing")
    with pytest.raises(ReportError, match=r"holds no participant \(no \*/plan.json\)"):
        make_report(tmp_path)


def test_the_markdown_report_by_hand():
    tlx = {name: 50.0 for name in TLX_NAMES}
    data = StudyData(
        name="demo",
        folder=pathlib.Path("/study"),
        trials=[{}, {}, {}],
        questionnaires=[{"answers": {**tlx, "in_control": 4}}],
        participants={"P01": (2, 2), "P02": (1, 2)},
        conditions=["guided", "unguided"],
        tasks=["remove"],
    )
    summary = {
        "condition": "guided",
        "task": "remove",
        "trials": 3,
        "successes": 2,
        "task_time_s_mean": 12.345,
        "task_time_s_sd": None,
        "task_time_s_median": 12.0,
        "wrong_selections_mean": 0.333,
        "wrong_selections_sd": 0.4567,
        "wrong_selections_median": 0.0,
        "undo_count_mean": 0.333,
        "help_requests_mean": 0.5,
        "peak_force_n_mean": 7.06,
    }
    tlx_row = {
        "condition": "guided",
        "participants": 1,
        "raw_tlx_mean": 41.66,
        "raw_tlx_sd": 3.26,
        "raw_tlx_median": 41.66,
        **{f"{name}_mean": float(index) for index, name in enumerate(TLX_NAMES)},
        "in_control_mean": 4.0,
        "in_control_sd": 0.5,
        "in_control_median": 4.0,
    }
    tested = Comparison("task_time_s", "remove", "guided", "unguided", 6, 4.0, 2.0, 2.5, 5.0, 0.3125, 0.5238, "")
    approximate = dataclasses.replace(tested, measure="wrong_selections", note="normal approximation")
    untested = Comparison(
        "raw_tlx", "all", "guided", "unguided", 1, 40.0, 45.0, -5.0, None, None, None, "no test: 1 participant(s)"
    )
    report = Report(
        data,
        [summary],
        [],
        [tlx_row],
        [tested, approximate, untested],
        pathlib.Path("/out"),
        {"task_time": pathlib.Path("/out/task_time.png")},
    )
    subscales = " | ".join(TLX_NAMES)
    assert markdown(report) == textwrap.dedent(
        f"""\
        # Study demo

        2 participants (1 complete: P01), 3 trials, 1 questionnaires. Conditions: guided, unguided; tasks: remove.
        Incomplete: P02 (1 of 2 steps); their finished trials are included, comparisons use the participants with \
data in both conditions.

        ## Per condition and task

        | condition | task | trials | successes | task time mean [s] | sd | median | wrong selections mean | sd | \
median | undo mean | help requests mean | peak force mean [N] |
        |---|---|---|---|---|---|---|---|---|---|---|---|---|
        | guided | remove | 3 | 2 | 12.3 | - | 12.0 | 0.33 | 0.46 | 0.0 | 0.33 | 0.50 | 7.1 |

        Task time over successful trials; the other columns over all trials.

        ## NASA-TLX (raw) per condition

        | condition | participants | raw TLX mean | sd | median | {subscales} |
        |---|---|---|---|---|---|---|---|---|---|---|
        | guided | 1 | 41.7 | 3.3 | 41.7 | 0.0 | 1.0 | 2.0 | 3.0 | 4.0 | 5.0 |

        Subscale columns: means (0-100; performance: 0 perfect, 100 failure).

        ## Other questionnaire items per condition

        | item | condition | participants | mean | sd | median |
        |---|---|---|---|---|---|
        | in_control | guided | 1 | 4.00 | 0.50 | 4.0 |

        ## Paired comparisons (Wilcoxon signed-rank, two-sided)

        | measure | task | conditions | n | medians | median difference | W | p | effect size r |
        |---|---|---|---|---|---|---|---|---|
        | task_time_s | remove | guided vs unguided | 6 | 4.00 vs 2.00 | 2.50 | 5.0 | 0.312 | 0.52 |
        | wrong_selections | remove | guided vs unguided | 6 | 4.00 vs 2.00 | 2.50 | 5.0 | 0.312 (normal \
approximation) | 0.52 |
        | raw_tlx | all | guided vs unguided | 1 | 40.00 vs 45.00 | -5.00 | - | - | - (no test: 1 participant(s)) |

        Each participant's mean under each condition (task time: successful trials) is one pair; zero differences are \
dropped. Effect size: matched-pairs rank-biserial correlation (positive: higher under the first condition).

        ## Figures and files

        - `task_time.png`
        - `trials.csv`
        - `questionnaires.csv`
        - `tlx.csv`
        - `summary.csv`
        - `comparisons.csv`
        """
    )


def test_the_analysis_by_hand():
    def trial(participant, condition, task, success, time, wrong):
        return {
            "participant": participant,
            "condition": condition,
            "task": task,
            "success": success,
            "task_time_s": time,
            "wrong_selections": wrong,
            "undo_count": 0,
            "help_requests": 1 if not success else 0,
            "peak_force_n": 5.0,
        }

    def answers(participant, condition, tlx, in_control):
        values = {name: tlx for name in TLX_NAMES} if tlx is not None else {}
        return {"participant": participant, "condition": condition, "answers": {**values, "in_control": in_control}}

    data = StudyData(
        name="demo",
        folder=pathlib.Path("/study"),
        trials=[
            trial("P1", "guided", "remove", True, 10.0, 1),
            trial("P1", "unguided", "remove", True, 14.0, 2),
            trial("P2", "guided", "remove", False, 30.0, 3),
            trial("P2", "unguided", "remove", True, 12.0, 0),
            trial("P1", "guided", "stiffen", True, 20.0, 0),
            trial("P1", "unguided", "stiffen", True, 25.0, 0),
        ],
        questionnaires=[
            answers("P1", "guided", 20.0, 5),
            answers("P1", "unguided", 40.0, 3),
            answers("P2", "guided", None, 4),  # the TLX left out: no raw TLX
            answers("P2", "unguided", 60.0, 2),
        ],
        participants={"P1": (4, 4), "P2": (2, 4)},
        conditions=["guided", "unguided"],
        tasks=["remove", "stiffen"],
    )
    summary, tlx, tlx_summary, comparisons = analyse(data)
    measures = ("task_time_s", "wrong_selections", "undo_count", "help_requests", "peak_force_n")
    statistics = [f"{measure}_{statistic}" for measure in measures for statistic in ("mean", "sd", "median")]
    assert [sorted(entry) for entry in summary] == [
        sorted(["condition", "task", "trials", "successes", *statistics])
    ] * 4
    guided_remove = summary[0]
    assert (guided_remove["condition"], guided_remove["task"], guided_remove["trials"]) == ("guided", "remove", 2)
    # task time over the successful trial only; the other measures over both
    assert (guided_remove["successes"], guided_remove["task_time_s_mean"], guided_remove["task_time_s_sd"]) == (
        1,
        10.0,
        None,
    )
    assert (guided_remove["wrong_selections_mean"], guided_remove["help_requests_mean"]) == (2.0, 0.5)
    assert [row["raw_tlx"] for row in tlx] == [20.0, 40.0, None, 60.0]
    items = [
        f"{item}_{statistic}"
        for item in ("raw_tlx", *TLX_NAMES, "in_control")
        for statistic in ("mean", "sd", "median")
    ]
    assert [sorted(entry) for entry in tlx_summary] == [sorted(["condition", "participants", *items])] * 2
    assert [
        (row["condition"], row["participants"], row["in_control_mean"], row["raw_tlx_mean"]) for row in tlx_summary
    ] == [
        ("guided", 2, 4.5, 20.0),
        ("unguided", 2, 2.5, 50.0),
    ]
    assert [(c.measure, c.task, c.first, c.second, c.n, c.median_first, c.median_second) for c in comparisons] == [
        ("task_time_s", "remove", "guided", "unguided", 1, 10.0, 14.0),  # P2's guided trial failed: no pair
        ("wrong_selections", "remove", "guided", "unguided", 2, 2.0, 1.0),
        ("task_time_s", "stiffen", "guided", "unguided", 1, 20.0, 25.0),
        ("wrong_selections", "stiffen", "guided", "unguided", 1, 0.0, 0.0),
        ("raw_tlx", "(all)", "guided", "unguided", 1, 20.0, 40.0),
        ("in_control", "(all)", "guided", "unguided", 2, 4.5, 2.5),
    ]


def figure_trial(participant, condition, task, repetition, success, time, wrong):
    return {
        "participant": participant,
        "condition": condition,
        "task": task,
        "repetition": repetition,
        "success": success,
        "task_time_s": time,
        "wrong_selections": wrong,
    }


FIGURE_STUDY = StudyData(
    name="demo",
    folder=pathlib.Path("/study"),
    trials=[
        figure_trial("P1", "guided", "remove", 2, True, 8.0, 0),  # out of order: the curves sort by repetition
        figure_trial("P1", "guided", "remove", 1, True, 10.0, 1),
        figure_trial("P2", "guided", "remove", 1, False, 30.0, 3),
        figure_trial("P2", "guided", "remove", 2, True, 14.0, 0),
        figure_trial("P1", "unguided", "remove", 1, True, 14.0, 2),
        figure_trial("P1", "unguided", "remove", 2, True, 11.0, 1),
        figure_trial("P2", "unguided", "remove", 1, True, 12.0, 0),
        figure_trial("P2", "unguided", "remove", 2, True, 9.0, 0),
        figure_trial("P1", "guided", "stiffen", 1, False, 40.0, 2),  # no guided stiffen trial succeeded
        figure_trial("P1", "unguided", "stiffen", 1, True, 25.0, 0),
    ],
    questionnaires=[],
    participants={"P1": (5, 5), "P2": (4, 4)},
    conditions=["guided", "unguided"],
    tasks=["remove", "stiffen"],
)
FIGURE_TLX = [
    {"participant": "P1", "condition": "guided", "raw_tlx": 20.0},
    {"participant": "P2", "condition": "guided", "raw_tlx": None},  # the TLX left out
    {"participant": "P1", "condition": "unguided", "raw_tlx": 40.0},
    {"participant": "P2", "condition": "unguided", "raw_tlx": 60.0},
]


def drawn_values(axis):
    """Per box of a box plot, the values drawn over it, each within its box's half width of the box's position."""
    values = []
    for position, points in enumerate(axis.collections, start=1):
        offsets = np.asarray(points.get_offsets()).reshape(-1, 2)
        assert np.all(np.abs(offsets[:, 0] - position) <= 0.08)
        values.append(sorted(offsets[:, 1].tolist()))
    return values


def medians(axis):
    """The box plot's medians: its two-point horizontal lines as wide as a box (caps are half as wide, boxes closed)."""
    return [
        float(line.get_ydata()[0])
        for line in axis.get_lines()
        if len(line.get_xdata()) == 2
        and np.isclose(np.ptp(line.get_xdata()), 0.5)
        and np.array_equal(line.get_ydata()[:1], line.get_ydata()[1:], equal_nan=True)
    ]


def test_the_figures_show_each_condition_s_values_by_hand():
    figures = draw_figures(FIGURE_STUDY, FIGURE_TLX)
    assert list(figures) == ["task_time", "wrong_selections", "tlx", "learning_curves"]
    times = figures["task_time"]
    assert times._suptitle.get_text() == "demo: task time per condition (successful trials)"
    remove, stiffen = times.axes
    assert [axis.get_title() for axis in times.axes] == ["remove", "stiffen"]
    assert {axis.get_ylabel() for axis in times.axes} == {"Task time [s]"}
    # successful trials only: P2's failed guided trial (30 s) is not drawn
    assert drawn_values(remove) == [[8.0, 10.0, 14.0], [9.0, 11.0, 12.0, 14.0]]
    assert medians(remove) == [10.0, 11.5]
    assert [label.get_text() for label in remove.get_xticklabels()] == ["guided\n(n=3)", "unguided\n(n=4)"]
    # a condition without a successful trial: an empty box, said n=0
    assert drawn_values(stiffen) == [[], [25.0]]
    assert np.isnan(medians(stiffen)[0]) and medians(stiffen)[1] == 25.0
    assert [label.get_text() for label in stiffen.get_xticklabels()] == ["guided\n(n=0)", "unguided\n(n=1)"]
    # the values are drawn over the boxes, once: the box plots draw no outliers of their own
    assert min(points.get_zorder() for points in remove.collections) > max(line.get_zorder() for line in remove.lines)
    for axis in (remove, stiffen):
        assert {line.get_marker() for line in axis.get_lines()} <= {"", "None"}  # no marker
    wrong = figures["wrong_selections"]
    assert wrong._suptitle.get_text() == "demo: wrong selections per condition"
    assert {axis.get_ylabel() for axis in wrong.axes} == {"Wrong selections [per trial]"}
    assert [axis.get_title() for axis in wrong.axes] == ["remove", "stiffen"]
    assert drawn_values(wrong.axes[0]) == [[0.0, 0.0, 1.0, 3.0], [0.0, 0.0, 1.0, 2.0]]  # all trials, failed too
    assert drawn_values(wrong.axes[1]) == [[2.0], [0.0]]
    (tlx,) = figures["tlx"].axes
    assert (tlx.get_title(), tlx.get_ylabel(), tlx.get_ylim()) == (
        "demo: workload per condition",
        "raw NASA-TLX (0-100)",
        (0.0, 100.0),
    )
    assert drawn_values(tlx) == [[20.0], [40.0, 60.0]] and medians(tlx) == [20.0, 50.0]
    assert [label.get_text() for label in tlx.get_xticklabels()] == ["guided\n(n=1)", "unguided\n(n=2)"]


def test_the_learning_curves_by_hand():
    curves = draw_figures(FIGURE_STUDY, FIGURE_TLX)["learning_curves"]
    assert curves._suptitle.get_text() == "demo: learning curves (thin: participants, thick: mean)"
    remove, stiffen = curves.axes

    def drawn(axis):
        return [(line.get_label(), list(line.get_xdata()), list(line.get_ydata())) for line in axis.get_lines()]

    # per condition its mean over the successful trials of each repetition, then each participant's own times
    assert drawn(remove) == [
        ("guided", [1, 2], [10.0, 11.0]),
        ("_child1", [1, 2], [10.0, 8.0]),
        ("_child2", [2], [14.0]),
        ("unguided", [1, 2], [13.0, 10.0]),
        ("_child4", [1, 2], [14.0, 11.0]),
        ("_child5", [1, 2], [12.0, 9.0]),
    ]
    assert drawn(stiffen) == [("unguided", [1], [25.0]), ("_child1", [1], [25.0])]  # no guided curve: none succeeded
    means = [line for line in remove.get_lines() if not line.get_label().startswith("_")]
    participants = [line for line in remove.get_lines() if line.get_label().startswith("_")]
    assert [line.get_marker() for line in means] == ["o", "o"] and {line.get_marker() for line in participants} == {"."}
    assert min(line.get_linewidth() for line in means) > max(line.get_linewidth() for line in participants)
    assert all(line.get_alpha() < 1.0 for line in participants) and all(line.get_alpha() is None for line in means)
    assert [line.get_color() for line in participants] == [means[0].get_color()] * 2 + [means[1].get_color()] * 2
    assert means[0].get_color() != means[1].get_color()
    assert [text.get_text() for text in remove.get_legend().get_texts()] == ["guided", "unguided"]
    assert [text.get_text() for text in stiffen.get_legend().get_texts()] == ["unguided"]
    for axis, task, repetitions in ((remove, "remove", [1, 2]), (stiffen, "stiffen", [1])):
        assert (axis.get_title(), axis.get_xlabel(), axis.get_ylabel()) == (
            task,
            "trial of the task (under one condition)",
            "task time [s]",
        )
        assert axis.get_ylim()[0] == 0.0 and list(axis.get_xticks()) == repetitions


def test_a_report_made_twice_draws_the_same_figures(tmp_path):
    folder = fill(tmp_path, participants=("P01", "P02"))
    first = {name: path.read_bytes() for name, path in make_report(folder, tmp_path / "first").figures.items()}
    second = {name: path.read_bytes() for name, path in make_report(folder, tmp_path / "second").figures.items()}
    assert first == second and set(first) == {"task_time", "wrong_selections", "tlx", "learning_curves"}


def write_study(folder, steps, trials):
    """A participant's study folder written by hand: its plan's steps and its trials' results."""
    participant = folder / "P01"
    participant.mkdir(parents=True)
    (participant / "plan.json").write_text(json.dumps({"steps": steps}))
    for index, trial in enumerate(trials):
        (participant / "trials" / f"{index:02d}").mkdir(parents=True)
        (participant / "trials" / f"{index:02d}" / "result.json").write_text(json.dumps(trial))
    return folder


def test_a_study_of_one_condition_and_task_and_one_of_questionnaires_only_are_reported(tmp_path):
    trial = {
        "participant": "P01",
        "condition": "guided",
        "task": "remove",
        "repetition": 1,
        "trial": 1,
        "success": True,
        "task_time_s": 9.5,
        "wrong_selections": 0,
        "undo_count": 0,
        "help_requests": 0,
        "peak_force_n": 1.0,
        "contacts": 0,
    }
    one = make_report(write_study(tmp_path / "one", [{"condition": "guided", "task": "remove"}], [trial]))
    (row,) = read_csv(one.folder / "summary.csv")
    assert list(row) == list(one.summary[0])
    assert (row["condition"], row["task"], row["trials"], row["task_time_s_mean"]) == ("guided", "remove", "1", "9.5")
    none = make_report(write_study(tmp_path / "none", [{"condition": "guided", "task": ""}], []))
    assert (none.folder / "summary.csv").read_text() == "condition,task\n"
    assert "1 participants (0 complete: none), 0 trials" in (none.folder / "report.md").read_text()
    assert list(none.figures) == ["tlx"]  # questionnaires only: no task to draw
