"""A study's numbers over all its participants: per condition and task, paired comparisons, plots, CSV.

``rosrun teleteach study_report <data dir>/studies/<study>`` reads every participant's ``trials/*/result.json`` and
``questionnaires/*.json`` (:mod:`teleteach.study.storage`) and writes into ``<study dir>/report/``:

- ``report.md``: the participants, per condition and task the trials, successes and mean / sd / median of the task
  time (successful trials) and of the wrong selections (all trials), the raw TLX per condition, and the paired
  comparisons between conditions;
- ``trials.csv`` (one row per trial), ``questionnaires.csv`` (one row per answer), ``tlx.csv`` (one row per
  participant and condition), ``summary.csv``, ``comparisons.csv``: plain CSV a statistician can load;
- ``task_time.png``, ``wrong_selections.png``, ``tlx.png`` (box plots per condition) and ``learning_curves.png``
  (task time over each task's trials, per condition).

Paired comparison: for each pair of conditions, each participant's mean under each (per task for task time and
errors; the raw TLX), compared with the Wilcoxon signed-rank test (scipy.stats.wilcoxon, two-sided, zero differences
dropped), with the matched-pairs rank-biserial correlation as effect size (Kerby 2014: the share of rank sum where
the first condition is higher minus the share where it is lower, -1 .. 1). With fewer than 2 non-zero differences no
test is made and the table says why.
"""

import csv
import dataclasses
import io
import itertools
import json
import math
import pathlib
import warnings
from typing import TYPE_CHECKING, Dict, List, Optional, Sequence, Tuple

import numpy as np
from scipy import stats

from teleteach.core.datadir import atomic_write_bytes, atomic_write_text
from teleteach.core.questionnaire import TLX_NAMES, raw_tlx

if TYPE_CHECKING:
    from matplotlib.figure import Figure

TRIAL_COLUMNS = (
    "participant",
    "condition",
    "task",
    "repetition",
    "trial",
    "success",
    "task_time_s",
    "wrong_selections",
    "undo_count",
    "help_requests",
    "peak_force_n",
    "contacts",
)


class ReportError(ValueError):
    """A study folder without data to report; the message says which folder and why."""


@dataclasses.dataclass
class StudyData:
    """What a study folder holds."""

    name: str
    folder: pathlib.Path
    trials: List[dict]
    questionnaires: List[dict]
    participants: Dict[str, Tuple[int, int]]  # id -> (steps done, steps planned)
    conditions: List[str]
    tasks: List[str]


def load_study_data(folder) -> StudyData:
    """Every participant's results in ``folder`` (``<data dir>/studies/<study>``).

    Raises:
        ReportError: the folder does not exist or holds no participant.
    """
    folder = pathlib.Path(folder).expanduser()
    if not folder.is_dir():
        raise ReportError(f"{folder} is not a study folder (<data dir>/studies/<study>)")
    trials, questionnaires, participants = [], [], {}
    conditions: List[str] = []
    tasks: List[str] = []
    for plan_file in sorted(folder.glob("*/plan.json")):
        plan = json.loads(plan_file.read_text())
        participant = plan_file.parent.name
        done = 0
        for step in plan["steps"]:
            if step["condition"] not in conditions:
                conditions.append(step["condition"])
            if step["task"] and step["task"] not in tasks:
                tasks.append(step["task"])
        for result in sorted((plan_file.parent / "trials").glob("*/result.json")):
            trials.append(json.loads(result.read_text()))
            done += 1
        for answers in sorted((plan_file.parent / "questionnaires").glob("*.json")):
            questionnaires.append(json.loads(answers.read_text()))
            done += 1
        participants[participant] = (done, len(plan["steps"]))
    if not participants:
        raise ReportError(f"{folder} holds no participant (no */plan.json)")
    return StudyData(folder.name, folder, trials, questionnaires, participants, conditions, tasks)


def describe(values: Sequence[float]) -> Dict[str, Optional[float]]:
    """n, mean, sd (n - 1), median; None where undefined."""
    data = np.asarray([value for value in values if value is not None and math.isfinite(value)], dtype=float)
    n = len(data)
    return {
        "n": n,
        "mean": float(np.mean(data)) if n else None,
        "sd": float(np.std(data, ddof=1)) if n > 1 else None,
        "median": float(np.median(data)) if n else None,
    }


def rank_biserial(differences: Sequence[float]) -> float:
    """Matched-pairs rank-biserial correlation of paired differences (zeros dropped), -1 .. 1."""
    d = np.asarray([value for value in differences if value != 0.0], dtype=float)
    if not len(d):
        return 0.0
    ranks = stats.rankdata(np.abs(d))
    return float((ranks[d > 0].sum() - ranks[d < 0].sum()) / ranks.sum())


@dataclasses.dataclass
class Comparison:
    """A paired comparison of one measure between two conditions."""

    measure: str
    task: str
    first: str
    second: str
    n: int
    median_first: Optional[float]
    median_second: Optional[float]
    median_difference: Optional[float]
    statistic: Optional[float]
    p_value: Optional[float]
    effect_size_r: Optional[float]
    note: str = ""


def compare(measure: str, task: str, first: str, second: str, pairs: Dict[str, Tuple[float, float]]) -> Comparison:
    """Wilcoxon signed-rank of ``first`` against ``second`` over the participants' paired values."""
    x = np.array([pair[0] for pair in pairs.values()], dtype=float)
    y = np.array([pair[1] for pair in pairs.values()], dtype=float)
    n = len(x)
    medians = (float(np.median(x)), float(np.median(y)), float(np.median(x - y))) if n else (None, None, None)
    differences = x - y
    nonzero = int(np.count_nonzero(differences))
    if nonzero < 2:
        note = f"no test: {nonzero} participant(s) with a difference (of {n} paired)"
        return Comparison(measure, task, first, second, n, *medians, None, None, None, note)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = stats.wilcoxon(x, y, zero_method="wilcox", alternative="two-sided")
    # scipy takes the normal approximation when there are ties or zeros, and warns when n is small for it
    note = "; ".join(str(warning.message) for warning in caught)
    return Comparison(
        measure,
        task,
        first,
        second,
        n,
        *medians,
        float(result.statistic),
        float(result.pvalue),
        rank_biserial(differences),
        note,
    )


def extra_items(data: StudyData) -> List[str]:
    """The questionnaire's items beyond NASA-TLX (the study's Likert items), in the order asked."""
    names: List[str] = []
    for answers in data.questionnaires:
        names += [name for name in answers["answers"] if name not in TLX_NAMES and name not in names]
    return names


def _participant_means(rows: List[dict], key: str, condition: str, task: Optional[str]) -> Dict[str, float]:
    values: Dict[str, List[float]] = {}
    for row in rows:
        if row["condition"] == condition and (task is None or row["task"] == task) and row.get(key) is not None:
            values.setdefault(row["participant"], []).append(float(row[key]))
    return {participant: float(np.mean(items)) for participant, items in values.items()}


def _pairs(first: Dict[str, float], second: Dict[str, float]) -> Dict[str, Tuple[float, float]]:
    return {participant: (first[participant], second[participant]) for participant in first if participant in second}


@dataclasses.dataclass
class Report:
    """The aggregated numbers and where they were written."""

    data: StudyData
    summary: List[dict]
    tlx: List[dict]
    tlx_summary: List[dict]
    comparisons: List[Comparison]
    folder: pathlib.Path
    figures: Dict[str, pathlib.Path]


def analyse(data: StudyData) -> Tuple[List[dict], List[dict], List[dict], List[Comparison]]:
    """Per condition and task, per participant's TLX, per condition's TLX, and the paired comparisons."""
    summary = []
    for condition, task in itertools.product(data.conditions, data.tasks):
        rows = [row for row in data.trials if row["condition"] == condition and row["task"] == task]
        times = [row["task_time_s"] for row in rows if row["success"]]
        entry = {"condition": condition, "task": task, "trials": len(rows), "successes": len(times)}
        for key, values in (
            ("task_time_s", times),
            ("wrong_selections", [row["wrong_selections"] for row in rows]),
            ("undo_count", [row["undo_count"] for row in rows]),
            ("help_requests", [row["help_requests"] for row in rows]),
            ("peak_force_n", [row["peak_force_n"] for row in rows]),
        ):
            for statistic, value in describe(values).items():
                if statistic != "n":
                    entry[f"{key}_{statistic}"] = value
        summary.append(entry)
    tlx = []
    for answers in data.questionnaires:
        values = answers["answers"]
        row = {"participant": answers["participant"], "condition": answers["condition"]}
        row["raw_tlx"] = raw_tlx(values) if all(name in values for name in TLX_NAMES) else None
        row.update(values)
        tlx.append(row)
    tlx_summary = []
    for condition in data.conditions:
        rows = [row for row in tlx if row["condition"] == condition]
        entry = {"condition": condition, "participants": len(rows)}
        for key in ("raw_tlx", *TLX_NAMES, *extra_items(data)):
            for statistic, value in describe([row.get(key) for row in rows]).items():
                if statistic != "n":
                    entry[f"{key}_{statistic}"] = value
        tlx_summary.append(entry)
    comparisons = []
    for first, second in itertools.combinations(data.conditions, 2):
        for task in data.tasks:
            for measure in ("task_time_s", "wrong_selections"):
                rows = [row for row in data.trials if measure != "task_time_s" or row["success"]]
                pairs = _pairs(
                    _participant_means(rows, measure, first, task), _participant_means(rows, measure, second, task)
                )
                comparisons.append(compare(measure, task, first, second, pairs))
        for item in ("raw_tlx", *extra_items(data)):
            first_answers, second_answers = (_participant_means(tlx, item, name, None) for name in (first, second))
            comparisons.append(compare(item, "(all)", first, second, _pairs(first_answers, second_answers)))
    return summary, tlx, tlx_summary, comparisons


def make_report(folder, out: Optional[pathlib.Path] = None) -> Report:
    """Aggregate the study in ``folder`` and write the report into ``out`` (default ``<folder>/report``).

    Raises:
        ReportError: see :func:`load_study_data`.
    """
    data = load_study_data(folder)
    summary, tlx, tlx_summary, comparisons = analyse(data)
    out = pathlib.Path(out) if out else data.folder / "report"
    out.mkdir(parents=True, exist_ok=True)
    _write_csv(out / "trials.csv", TRIAL_COLUMNS, data.trials)
    answer_rows = [
        {"participant": row["participant"], "condition": row["condition"], "item": name, "value": value}
        for row in data.questionnaires
        for name, value in row["answers"].items()
    ]
    _write_csv(out / "questionnaires.csv", ("participant", "condition", "item", "value"), answer_rows)
    extra = sorted({key for row in tlx for key in row} - {"participant", "condition", "raw_tlx", *TLX_NAMES})
    _write_csv(out / "tlx.csv", ("participant", "condition", "raw_tlx", *TLX_NAMES, *extra), tlx)
    _write_csv(out / "summary.csv", tuple(summary[0]) if summary else ("condition", "task"), summary)
    _write_csv(
        out / "comparisons.csv",
        tuple(field.name for field in dataclasses.fields(Comparison)),
        [dataclasses.asdict(comparison) for comparison in comparisons],
    )
    figures = {name: _save(figure, out / f"{name}.png") for name, figure in draw_figures(data, tlx).items()}
    report = Report(data, summary, tlx, tlx_summary, comparisons, out, figures)
    atomic_write_text(out / "report.md", markdown(report))
    return report


def _write_csv(path: pathlib.Path, columns: Sequence[str], rows: Sequence[dict]) -> None:
    stream = io.StringIO()
    writer = csv.DictWriter(stream, fieldnames=list(columns), extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({key: _cell(row.get(key)) for key in columns})
    atomic_write_text(path, stream.getvalue())


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def _number(value: Optional[float], digits: int = 1) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def markdown(report: Report) -> str:
    """report.md: the study's overview, then one section per table, in the order a reader checks them."""
    lines = _overview(report.data)
    lines += _task_table(report.summary)
    lines += _tlx_table(report.tlx_summary)
    lines += _items_table(extra_items(report.data), report.tlx_summary)
    lines += _comparisons_table(report.comparisons)
    lines += _files_list(report.figures)
    return "\n".join(lines) + "\n"


def _overview(data: StudyData) -> List[str]:
    """The title and who took part, naming the incomplete participants, whose trials still count."""
    complete = [name for name, (done, planned) in data.participants.items() if done == planned]
    lines = [f"# Study {data.name}", ""]
    lines.append(
        f"{len(data.participants)} participants ({len(complete)} complete: {', '.join(complete) or 'none'}), "
        f"{len(data.trials)} trials, {len(data.questionnaires)} questionnaires. Conditions: "
        f"{', '.join(data.conditions)}; tasks: {', '.join(data.tasks)}."
    )
    incomplete = {name: steps for name, steps in data.participants.items() if name not in complete}
    if incomplete:
        shown = ", ".join(f"{name} ({done} of {planned} steps)" for name, (done, planned) in incomplete.items())
        lines.append(
            f"Incomplete: {shown}; their finished trials are included, comparisons use the participants with data in "
            "both conditions."
        )
    return lines


def _task_table(summary: List[dict]) -> List[str]:
    """The trials' measures per condition and task."""
    lines = ["", "## Per condition and task", ""]
    lines.append(
        "| condition | task | trials | successes | task time mean [s] | sd | median | wrong selections mean | sd | "
        "median | undo mean | help requests mean | peak force mean [N] |"
    )
    lines.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for row in summary:
        lines.append(
            f"| {row['condition']} | {row['task']} | {row['trials']} | {row['successes']} | "
            f"{_number(row['task_time_s_mean'])} | {_number(row['task_time_s_sd'])} | "
            f"{_number(row['task_time_s_median'])} | {_number(row['wrong_selections_mean'], 2)} | "
            f"{_number(row['wrong_selections_sd'], 2)} | {_number(row['wrong_selections_median'], 1)} | "
            f"{_number(row['undo_count_mean'], 2)} | {_number(row['help_requests_mean'], 2)} | "
            f"{_number(row['peak_force_n_mean'], 1)} |"
        )
    return [*lines, "", "Task time over successful trials; the other columns over all trials.", ""]


def _tlx_table(tlx_summary: List[dict]) -> List[str]:
    """The raw NASA-TLX and its subscales per condition."""
    lines = ["## NASA-TLX (raw) per condition", ""]
    lines.append("| condition | participants | raw TLX mean | sd | median | " + " | ".join(TLX_NAMES) + " |")
    lines.append("|---|---|---|---|---|" + "---|" * len(TLX_NAMES))
    for row in tlx_summary:
        subscales = " | ".join(_number(row[f"{name}_mean"]) for name in TLX_NAMES)
        lines.append(
            f"| {row['condition']} | {row['participants']} | {_number(row['raw_tlx_mean'])} | "
            f"{_number(row['raw_tlx_sd'])} | {_number(row['raw_tlx_median'])} | {subscales} |"
        )
    return [*lines, "", "Subscale columns: means (0-100; performance: 0 perfect, 100 failure).", ""]


def _items_table(items: List[str], tlx_summary: List[dict]) -> List[str]:
    """The questionnaire's items beyond the TLX per condition; nothing when it has none."""
    if not items:
        return []
    lines = ["## Other questionnaire items per condition", ""]
    lines.append("| item | condition | participants | mean | sd | median |")
    lines.append("|---|---|---|---|---|---|")
    for item in items:
        for row in tlx_summary:
            lines.append(
                f"| {item} | {row['condition']} | {row['participants']} | {_number(row[f'{item}_mean'], 2)} | "
                f"{_number(row[f'{item}_sd'], 2)} | {_number(row[f'{item}_median'], 1)} |"
            )
    lines.append("")
    return lines


def _comparisons_table(comparisons: List[Comparison]) -> List[str]:
    """The paired tests between conditions, and how their pairs were formed."""
    lines = ["## Paired comparisons (Wilcoxon signed-rank, two-sided)", ""]
    lines.append("| measure | task | conditions | n | medians | median difference | W | p | effect size r |")
    lines.append("|---|---|---|---|---|---|---|---|---|")
    for comparison in comparisons:
        tested = comparison.p_value is not None
        lines.append(
            f"| {comparison.measure} | {comparison.task} | {comparison.first} vs {comparison.second} | "
            f"{comparison.n} | {_number(comparison.median_first, 2)} vs {_number(comparison.median_second, 2)} | "
            f"{_number(comparison.median_difference, 2)} | "
            + (
                f"{_number(comparison.statistic, 1)} | {comparison.p_value:.3f}"
                + (f" ({comparison.note})" if comparison.note else "")
                + f" | {comparison.effect_size_r:.2f} |"
                if tested
                else f"- | - | - ({comparison.note}) |"
            )
        )
    return [
        *lines,
        "",
        "Each participant's mean under each condition (task time: successful trials) is one pair; zero differences "
        "are dropped. Effect size: matched-pairs rank-biserial correlation (positive: higher under the first "
        "condition).",
        "",
    ]


def _files_list(figures: Dict[str, pathlib.Path]) -> List[str]:
    """What the report's folder holds besides report.md, so a reader finds the figures and tables."""
    lines = ["## Figures and files", ""]
    lines += [f"- `{path.name}`" for path in figures.values()]
    files = ("trials.csv", "questionnaires.csv", "tlx.csv", "summary.csv", "comparisons.csv")
    return lines + [f"- `{name}`" for name in files]


def draw_figures(data: StudyData, tlx: List[dict]) -> Dict[str, "Figure"]:
    """The report's figures, each under the name of its file (``task_time`` -> ``task_time.png``).

    Box plots of the task time (successful trials) and of the wrong selections per condition, one panel per task; of
    the raw TLX per condition; and the learning curves (a study without tasks has only the TLX's). Drawn with
    matplotlib's Agg backend (no display).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figures = {}
    per_task = (
        ("task_time_s", "task_time", "Task time", "s", True),
        ("wrong_selections", "wrong_selections", "Wrong selections", "per trial", False),
    )
    for key, name, title, unit, only_success in per_task if data.tasks else ():
        figure, axes = plt.subplots(1, len(data.tasks), figsize=(4.5 * len(data.tasks), 4.2), squeeze=False)
        for axis, task in zip(axes[0], data.tasks):
            groups = [
                [
                    row[key]
                    for row in data.trials
                    if row["task"] == task and row["condition"] == condition and (row["success"] or not only_success)
                ]
                for condition in data.conditions
            ]
            _box(axis, groups, data.conditions)
            axis.set_title(task)
            axis.set_ylabel(f"{title} [{unit}]")
        which = " (successful trials)" if only_success else ""
        figure.suptitle(f"{data.name}: {title.lower()} per condition{which}")
        figure.tight_layout()
        figures[name] = figure
    figure, axis = plt.subplots(figsize=(1.8 + 1.6 * len(data.conditions), 4.2))
    scores = [
        [row["raw_tlx"] for row in tlx if row["condition"] == condition and row["raw_tlx"] is not None]
        for condition in data.conditions
    ]
    _box(axis, scores, data.conditions)
    axis.set_ylabel("raw NASA-TLX (0-100)")
    axis.set_ylim(0, 100)
    axis.set_title(f"{data.name}: workload per condition")
    figure.tight_layout()
    figures["tlx"] = figure
    if data.tasks:
        figures["learning_curves"] = _learning_curves(data, plt)
    return figures


def _box(axis, groups: List[List[float]], labels: List[str]) -> None:
    """Box plot with every value drawn over it (small studies: the points matter)."""
    positions = list(range(1, len(groups) + 1))
    axis.boxplot(groups, positions=positions, widths=0.5, showfliers=False)
    spread = np.random.default_rng(0)
    for position, group in zip(positions, groups):
        axis.scatter(position + spread.uniform(-0.08, 0.08, len(group)), group, s=18, alpha=0.7, zorder=3)
    axis.set_xticks(positions)
    axis.set_xticklabels([f"{label}\n(n={len(group)})" for label, group in zip(labels, groups)])


def _learning_curves(data: StudyData, plt) -> "Figure":
    figure, axes = plt.subplots(1, len(data.tasks), figsize=(4.5 * len(data.tasks), 4.2), squeeze=False)
    for axis, task in zip(axes[0], data.tasks):
        for condition in data.conditions:
            rows = [
                row for row in data.trials if row["task"] == task and row["condition"] == condition and row["success"]
            ]
            by_participant: Dict[str, List[Tuple[int, float]]] = {}
            for row in rows:
                by_participant.setdefault(row["participant"], []).append((row["repetition"], row["task_time_s"]))
            repetitions = sorted({row["repetition"] for row in rows})
            if not repetitions:
                continue
            means = [np.mean([row["task_time_s"] for row in rows if row["repetition"] == r]) for r in repetitions]
            (mean_line,) = axis.plot(repetitions, means, marker="o", linewidth=2.5, label=condition)
            for points in by_participant.values():
                points.sort()
                axis.plot(*zip(*points), alpha=0.3, marker=".", color=mean_line.get_color())
            axis.set_xticks(repetitions)
        axis.set_title(task)
        axis.set_ylim(bottom=0.0)
        axis.set_xlabel("trial of the task (under one condition)")
        axis.set_ylabel("task time [s]")
        axis.legend()
    figure.suptitle(f"{data.name}: learning curves (thin: participants, thick: mean)")
    figure.tight_layout()
    return figure


def _save(figure, path: pathlib.Path) -> pathlib.Path:
    import matplotlib.pyplot as plt

    stream = io.BytesIO()
    figure.savefig(stream, format="png", dpi=110)
    plt.close(figure)
    atomic_write_bytes(path, stream.getvalue())
    return path
