"""The tables of figures in the docs, rendered from the stored results in bench/results/ (issue 51, item 2).

A figure copied into the docs by hand drifts from the result it came from. Each table stands in the markdown between
``<!-- results:NAME -->`` and ``<!-- /results -->``; this renders it from the JSON of the bench that measured it, with
the run's commit and command, and writes it there. ``--check`` writes nothing: it names the tables that differ from
what the stored results render (test/unit/test_docs_figures.py fails on them) and every stored result older than the
last change to what its bench measures (bench/measures.yaml, the bench's own script, the config files it read).

    source build/env.sh && python bench/render_docs.py [--check]
"""

import argparse
import dataclasses
import hashlib
import json
import math
import pathlib
import re
import subprocess
import sys
import textwrap
from typing import Callable

import yaml

from teleteach.core.rotations import rpy_rotation
from teleteach.run.ablation import all_cells

ROOT = pathlib.Path(__file__).resolve().parents[1]
RESULTS = ROOT / "bench" / "results"
MEASURES = ROOT / "bench" / "measures.yaml"
DOCS = (ROOT / "docs" / "benchmarks.md", ROOT / "README.md")
BLOCK = re.compile(r"(<!-- results:(\w+) -->\n)(.*?)(<!-- /results -->)", re.DOTALL)
ABLATION_CELLS = {
    "constant_high": "constant high",
    "constant_low": "constant low",
    "taught_isotropic": "isotropic, the taught volume",
    "taught_anisotropic": "taught",
}


@dataclasses.dataclass(frozen=True)
class Figure:
    """A table of the docs: the bench that measured it, its stored results, and how it reads them."""

    bench: str
    results: tuple
    render: Callable[[dict], list]


@dataclasses.dataclass(frozen=True)
class Measured:
    """One stored result and what it measured: the files whose change after its commit makes it older than the code."""

    label: str
    provenance: dict
    paths: tuple


def load(name: str) -> dict:
    return json.loads((RESULTS / name).read_text())


def table(header, rows) -> list:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]


def goal_lines(goals) -> list:
    """The bench's goals, one line each, with what it measured where it says."""
    lines = []
    for goal in goals:
        measured = f": {goal['measured']}" if "measured" in goal else ""
        lines.append(f"- {'met' if goal['met'] else '**not met**'}: {goal['goal']}{measured}")
    return lines


def run_line(name: str, record: dict) -> str:
    """Where a result came from, in one line: file, command, commit, date, wall time, cores."""
    provenance = record["provenance"]
    dirty = " (the tree dirty)" if provenance["dirty"] else ""
    command = " ".join(provenance["command"])
    return (
        f"`bench/results/{name}`: `{command}` at {provenance['commit'][:7]}{dirty}, {provenance['date'][:10]}, "
        f"{provenance['wall_s']:.0f} s on {provenance['machine']['cores']} cores."
    )


def stiffness_label(values) -> str:
    return "(" + ", ".join(f"{value:.0f}" for value in values) + ")"


def wiping_ablation(results: dict) -> list:
    result = results["wiping_ablation.json"]
    rows = []
    for cell, label in ABLATION_CELLS.items():
        figures = result["cells"][cell]
        rows.append(
            [
                f"{label} {stiffness_label(result['settings']['cells'][cell])}",
                f"{figures['kept_contact']} / {figures['trials']}",
                f"{figures['median_force_mean_n']:.1f} N",
                f"{figures['median_force_spread_n']:.2f} N",
                f"{figures['median_peak_force_n']:.1f} N",
                f"{1e3 * figures['median_tracking_rms_m']:.1f} mm",
                f"{figures['median_F_x']:.2e}".replace("e-0", "e-"),
            ]
        )
    header = ["cell", "kept contact >= 95 %", "median force", "median spread", "median peak", "tracking (RMS)", "F_x"]
    return [*table(header, rows), "", *goal_lines(result["goals"])]


def wiping_shared_control(results: dict) -> list:
    result = results["wiping_shared_control.json"]
    rows = []
    for pattern, figures in result["summary"].items():
        rows.append(
            [
                f"{pattern}, {figures['trials']} wipes",
                f"{figures['direct_violations']} in {figures['direct_trials_violating']} wipes",
                figures["shared_violations"],
                f"{figures['shared_over_direct_F_x_median']:.2f}x "
                f"(lower in {figures['shared_F_x_lower_in']} of {figures['trials']})",
                f"{100 * figures['misidentified_cycles'] / figures['cycles']:.1f} % of {figures['cycles']}",
                f"{figures['solve_p99_ms']:.1f} ms",
                figures["over_cycle"],
            ]
        )
    edge = result["moving_edge"]
    rows.append(
        [
            f"IV-D's moving edge, {edge['trials']} wipes",
            f"{edge['direct_violations']} in {edge['direct_trials_violating']} wipes",
            f"{edge['shared_violations']} (the true boundary: {edge['shared_boundary_violations']})",
            "",
            "",
            f"{edge['solve_p99_ms']:.1f} ms",
            edge["over_cycle"],
        ]
    )
    header = [
        "operators",
        "cycles outside, direct",
        "cycles outside, shared",
        "F_x shared / direct (paired median)",
        "misidentified cycles",
        "solve p99 (worst wipe)",
        "cycles over 20 ms",
    ]
    return [*table(header, rows), "", *goal_lines(result["goals"])]


def pose_change(taught: dict, pose: dict) -> str:
    """How far a board pose is from the taught one: its centre's move and its rotation."""
    moved = math.dist(taught["center"], pose["center"])
    turned = rpy_rotation(taught["rpy"]).inv() * rpy_rotation(pose["rpy"])
    return f"{100 * moved:.0f} cm, {math.degrees(turned.magnitude()):.1f} deg"


def wiping_skill(results: dict) -> list:
    result = results["wiping_skill.json"]
    poses = result["settings"]["poses"]
    rows = []
    for pose, figures in result["cells"].items():
        rows.append(
            [
                f"{pose} ({pose_change(poses['taught'], poses[pose])})",
                f"{figures['kept_contact']} / {figures['trials']}",
                f"{figures['covered_goal']} / {figures['trials']}",
                f"{100 * figures['median_coverage_of_demonstration']:.0f} % "
                f"(least {100 * figures['least_coverage_of_demonstration']:.0f} %)",
                f"{figures['median_force_mean_n']:.1f} +- {figures['median_force_spread_n']:.1f} N",
            ]
        )
    header = [
        "board pose (from the taught one)",
        "kept contact >= 95 %",
        "wiped >= 90 % of the demonstration's area",
        "share of it wiped, median",
        "force",
    ]
    demonstration = result["demonstration"]
    clutch_rows = []
    for name, figures in result["clutch"].items():
        force, spread = figures["median_force_n"], figures["median_spread_n"]
        low, high = figures["travel_ratio_range"]
        clutch_rows.append(
            [
                name.removeprefix("clutch_"),
                f"{100 * figures['median_kept_share']:.0f} % (least {100 * figures['least_kept_share']:.0f} %)",
                f"{figures['median_travel_ratio']:.2f}x ({low:.2f}-{high:.2f}x)",
                f"{figures['kept_contact']} / {figures['trials']}",
                " / ".join(f"{force[phase]:.1f} +- {spread[phase]:.1f}" for phase in ("before", "clutch", "after"))
                + " N",
            ]
        )
    clutch_header = [
        f"clutch, {next(iter(result['clutch'].values()))['trials']} held-out operators each",
        "pattern kept, median of the clutched cycles",
        "travel vs the operator's own",
        "contact >= 95 % through it",
        "force before / during / after",
    ]
    return [
        f"The demonstration: in contact {100 * demonstration['contact_fraction']:.0f} % of its cycles, "
        f"{100 * demonstration['covered_fraction']:.0f} % of the marked area covered.",
        "",
        *table(header, rows),
        "",
        *goal_lines([result["goal"]]),
        "",
        *table(clutch_header, clutch_rows),
    ]


def load_range(condition: dict) -> str:
    low, high = (round(value) for value in condition["load_average"])
    return f"load {low}" if low == high else f"load {low}-{high}"


WIPING_RATE_CONDITIONS = {"as_is": "as is", "busy_2": "2 busy loops"}


def wiping_rate(results: dict) -> list:
    rows = []
    for name, option in (("wiping_rate_realtime_0.json", "`--realtime-priority 0`"), ("wiping_rate.json", "(default)")):
        result = results[name]
        for condition, label in WIPING_RATE_CONDITIONS.items():
            figures = result["conditions"][condition]
            solve = figures["solve_ms_in_contact"]
            rows.append(
                [
                    option,
                    result["settings"]["scheduling"]["shared_control"],
                    f"{label} ({load_range(figures)})",
                    f"{100 * figures['contact_fraction']:.0f} %",
                    f"**{figures['contact_late']} of {figures['contact_cycles']} "
                    f"({100 * figures['contact_late_fraction']:.2f} %)**",
                    f"{solve['p50']:.2f} / {solve['p99']:.2f} / {solve['max']:.1f} ms",
                    figures["gaps_over_40_ms_in_contact"],
                    f"{figures['real_time_factor']:.2f}",
                ]
            )
    header = [
        "`python bench/wiping_rate.py ...`",
        "node's scheduling",
        "condition",
        "in contact",
        "late cycles in contact",
        "solve p50 / p99 / max",
        "state gaps > 40 ms",
        "RTF",
    ]
    return table(header, rows)


def mutation(results: dict) -> list:
    rows = []
    for module, figures in results["mutation.json"].items():
        timeout = f" (+{figures['timeout']} timed out)" if figures["timeout"] else ""
        provenance = figures["provenance"]
        rows.append(
            [
                module,
                ", ".join(pathlib.Path(test).stem for test in figures["tests"]),
                figures["mutants"],
                f"{figures['killed']}{timeout}",
                figures["survived"],
                figures["equivalent_excluded"],
                f"{100 * figures['score']:.1f} %",
                f"{figures['seconds'] / 60:.1f} min",
                f"{provenance['commit'][:7]}{' (dirty)' if provenance['dirty'] else ''}, {provenance['date'][:10]}",
            ]
        )
    header = ["module", "tests", "mutants", "killed", "survived", "equivalent set aside", "score", "time", "run at"]
    return table(header, rows)


def teleop_assistance(results: dict) -> list:
    """Per gap, the assistance off and on over the same seeds: touches, peak force on the neighbours, success."""
    result = next(iter(results.values()))
    rows = []
    for gap, figures in result["gaps"].items():
        off, on = figures["off"], figures["on"]
        rows.append(
            [
                f"{gap} ({1e3 * result['settings']['clearance_m'][gap]:.0f} mm)",
                f"{off['touched_neighbours']} / {on['touched_neighbours']} of {off['trials']}",
                f"{off['mean_peak_neighbour_force_n']:.2f} -> {on['mean_peak_neighbour_force_n']:.2f} N",
                f"{off['median_peak_neighbour_force_n']:.2f} / {on['median_peak_neighbour_force_n']:.2f} N",
                " / ".join(f"{round(row['success_rate'] * row['trials'])} of {row['trials']}" for row in (off, on)),
            ]
        )
    header = [
        "gap (clearance per side)",
        "touched a neighbour, off / on",
        "mean peak neighbour force, off -> on",
        "median, off / on",
        "success, off / on",
    ]
    return [*table(header, rows), "", f"- {result['goal']}"]


def failure(trial: dict) -> str:
    """A failed placement trial: its seed, how far from the gap's true centre the product ended, and a neighbour's move
    when it moved one more than a millimetre."""
    moved = trial["neighbour_max_move_m"]
    pushed = f", a neighbour moved {1e3 * moved:.1f} mm" if moved > 1e-3 else ""
    return f"{trial['seed']} ({1e3 * trial['distance_m']:.1f} mm off{pushed})"


def placements(result: dict) -> list:
    """Per gap, a placing skill replayed N times: success with its Wilson interval, the skill's own verdict, the median
    peak contact force with its bootstrap interval, the largest neighbour move, and the trials that failed."""
    taught_at = result["settings"].get("taught_at", "gap_1")
    rows = []
    for gap, figures in result["gaps"].items():
        low, high = (100 * value for value in figures["success_interval"])
        force_low, force_high = figures["median_peak_force_interval"]
        failed = [trial for trial in result["trials"][gap] if not trial["success"]]
        here = ", taught here" if gap == taught_at else ""
        rows.append(
            [
                f"{gap} ({1e3 * result['settings']['clearance_m'][gap]:.0f} mm{here})",
                f"{round(figures['success_rate'] * figures['trials'])} of {figures['trials']} ({low:.0f}-{high:.0f} %)",
                f"{100 * figures['skill_success_rate']:.0f} % ({figures['verdicts_disagree']} unlike the world)",
                f"{figures['median_peak_force_n']:.1f} N ({force_low:.1f}-{force_high:.1f} N)",
                f"{1e3 * figures['neighbour_max_move_m']:.1f} mm",
                ", ".join(failure(trial) for trial in failed) or "none",
            ]
        )
    header = [
        "gap (clearance per side)",
        "placed, from the true world (Wilson 95 %)",
        "the skill says placed",
        "median peak contact force (95 %)",
        "largest neighbour move",
        "failed: seed (off the gap's true centre; a neighbour moved)",
    ]
    return table(header, rows)


def skill_reuse(results: dict) -> list:
    """The skill taught at gap_1 replayed at gap_1 and the held-out gaps, and the goal line."""
    result = results["skill_reuse.json"]
    seeds = result["settings"]["seeds"]
    return [
        f"The skill `{pathlib.Path(result['settings']['skill_file']).name}`, {result['settings']['trials']} trials per "
        f"gap, seeds {seeds[0]}-{seeds[-1]}:",
        "",
        *placements(result),
        "",
        f"- {result['goal']}",
    ]


def taught_placement(results: dict) -> list:
    """The placement taught by teleoperation (one trial), its skill replayed at gap_1 and held-out gaps; the goal."""
    result = results["taught_placement.json"]
    taught, settings = result["taught"], result["settings"]
    seeds = settings["seeds"]
    return [
        f"Taught at gap_1 by teleoperation (seed {settings['teach_seed']}): "
        f"{'placed' if taught['success'] else '**not placed**'}, "
        f"{1e3 * taught['lateral_m']:+.1f} mm across, peak force on the neighbours "
        f"{taught['peak_neighbour_force_n']:.1f} N, {taught['sim_s']:.1f} s of operator time, the skill "
        f"{taught['skill_duration_s']:.1f} s long. Reused: {settings['trials']} trials per gap, seeds "
        f"{seeds[0]}-{seeds[-1]}:",
        "",
        *placements(result),
        "",
        f"- {result['goal']}",
    ]


def stiffness_cell(name: str, result: dict) -> str:
    """A cell of the stiffness ablation by its insertion stiffness [N/m]: along / across the gap, or vertical."""
    if name in result["profile_insertion_stiffness"]:
        along, across = result["profile_insertion_stiffness"][name]
        return f"{name.replace('_', ' ')} ({along:.0f} / {across:.0f})"
    kind, *values = name.split("_")
    if kind == "vertical":
        return f"taught, vertical {values[0]}"
    return f"sweep ({values[0]} / {values[1]})"


def stiffness_ablation(name: str) -> Callable[[dict], list]:
    """The renderer of one stored stiffness ablation: per cell its success, the skill's verdict, the median peak force
    and the largest neighbour move; the goals; the compliant-against-stiff contrast across the gap."""

    def render(results: dict) -> list:
        result = results[name]
        settings = result["settings"]
        rows = []
        for cell, figures in all_cells(result).items():
            low, high = (100 * value for value in figures["success_interval"])
            force_low, force_high = figures["median_peak_force_interval"]
            rows.append(
                [
                    stiffness_cell(cell, result),
                    f"{round(figures['success_rate'] * figures['trials'])} of {figures['trials']} "
                    f"({low:.0f}-{high:.0f} %)",
                    f"{100 * figures['skill_success_rate']:.0f} %",
                    f"{figures['median_peak_force_n']:.1f} N ({force_low:.1f}-{force_high:.1f} N)",
                    f"{1e3 * figures['neighbour_max_move_m']:.1f} mm",
                ]
            )
        header = [
            "cell (insertion stiffness along / across the gap, N/m)",
            "placed, from the true world (Wilson 95 %)",
            "the skill says placed",
            "median peak contact force (95 %)",
            "largest neighbour move",
        ]
        contrasts = [
            f"- {row['compliant']} against {row['stiff']}: {row['touched']} of {row['trials']} trials moved a "
            f"neighbour; the compliant one moved it less in {row['compliant_moved_less']} (sign test p = "
            f"{row['sign_test_p']:.3f})"
            for row in result["across_contrast"]
        ]
        seeds = settings["seeds"]
        return [
            f"{settings['trials']} trials per cell at {settings['gap']} ({1e3 * settings['clearance_m']:.0f} mm "
            f"clearance per side), seeds {seeds[0]}-{seeds[-1]}, uncertainty "
            f"`{pathlib.Path(settings['uncertainty_file']).name}`:",
            "",
            *table(header, rows),
            "",
            *(f"- {line}" for line in result["goals"]),
            *contrasts,
        ]

    return render


def ray_workers(results: dict) -> list:
    """Trials per minute with one and two Ray workers, in the order run, and the ratio of each pair."""
    runs = results["ray_workers.json"]["runs"]
    rows = [
        [
            run["workers"],
            run["worker_niceness"],
            run["beside"] or "other sessions' work only",
            f"{run['load_start']:.1f} -> {run['load_end']:.1f}",
            run["trials"],
            f"{run['wall_s']:.0f} s",
            f"{run['trials_per_minute']:.1f}",
        ]
        for run in runs
    ]
    header = [
        "workers",
        "Ray's worker niceness",
        "beside it",
        "load average (1 min), start -> end",
        "trials",
        "wall, connecting included",
        "trials per minute",
    ]
    pairs = [(runs[index], runs[index + 1]) for index in range(0, len(runs) - 1, 2)]
    ratios = [
        max(pair, key=lambda run: run["workers"])["trials_per_minute"]
        / min(pair, key=lambda run: run["workers"])["trials_per_minute"]
        for pair in pairs
    ]
    ratio_line = "2 : 1 worker, each pair of runs in turn: " + ", ".join(f"{ratio:.2f}x" for ratio in ratios)
    return [*table(header, rows), "", ratio_line]


def suite_time(results: dict) -> list:
    """The full suite's tiers (the tests' own times), what ran alone and beside, the wall time and its floor."""
    result = results["suite_time.json"]
    tiers = sorted(result["tiers"].items(), key=lambda item: -item[1]["seconds"])
    rows = [[tier, figures["tests"], f"{figures['seconds']:.0f} s"] for tier, figures in tiers]
    rows.append(["all", result["tests"], f"{result['tests_total_s']:.0f} s"])
    lines = [
        f"- pytest's wall time {result['wall_s']:.0f} s on {result['workers']} workers, "
        f"{100 * result['busy_fraction']:.0f} % of their time busy; {len(result['failed'])} failed",
        f"- alone (`ALONE`): {result['alone_s']:.0f} s; beside them (`LIGHT`): {result['light_s']:.0f} s",
        f"- the least wall time any schedule of these tests allows: {result['least_wall_s']:.0f} s",
    ]
    return [*table(["tier", "tests", "their own time"], rows), "", *lines, *goal_lines([result["goal"]])]


def tree_policy(results: dict) -> list:
    """The tree policy's held-out figures with their Wilson intervals, beside the repair memory's, and what decides."""
    held_out = results["tree_policy.json"]["held_out"]
    counts = held_out["counts"]

    def rate(name: str, of: str) -> str:
        figure = held_out[name]
        low, high = (100 * value for value in figure["interval"])
        return f"{100 * figure['rate']:.0f} % ({low:.0f}-{high:.0f} %) {of}"

    rows = [
        ["the proposal is the operator's edit", rate("proposal_accuracy", f"of {counts['proposals']}"), ">= 90 %"],
        ["right when it acts without asking", rate("accuracy_when_acting", f"of {counts['acted']}"), ">= 97 %"],
        ["acts without asking", rate("acts", f"of {counts['proposals']}"), ""],
        ["the repair memory's suggestion is the edit", rate("memory_accuracy", f"of {counts['proposals']}"), ""],
        ["asks where no demonstration had the failure", rate("asks_when_novel", f"of {counts['novel']}"), ""],
    ]
    deciding = ", ".join(f"{name} {weight:.2f}" for name, weight in held_out["deciding_features"][:6])
    return [
        *table(["held out (95 % interval)", "measured", "goal"], rows),
        "",
        f"- model {held_out['model']} (chosen on the development part), act_confidence {held_out['act_confidence']}, "
        f"novelty_margin {held_out['novelty_margin']}, {counts['demonstrations']} demonstrations, gaps "
        f"{', '.join(held_out['gaps'])}",
        f"- what decides (permutation importance: accuracy lost on the demonstrations when a feature is shuffled): "
        f"{deciding}",
    ]


def mutation_scores(results: dict) -> list:
    """The README's line: the modules with their score, the best first, those of equal score together."""
    by_score = {}
    for module, figures in results["mutation.json"].items():
        by_score.setdefault(figures["score"], []).append(module.removesuffix(".py"))
    parts = [f"{', '.join(modules)} {100 * score:.1f} %" for score, modules in sorted(by_score.items(), reverse=True)]
    return textwrap.wrap(", ".join(parts), 120, break_on_hyphens=False)


FIGURES = {
    "wiping_ablation": Figure("wiping_ablation", ("wiping_ablation.json",), wiping_ablation),
    "wiping_shared_control": Figure("wiping_shared_control", ("wiping_shared_control.json",), wiping_shared_control),
    "wiping_skill": Figure("wiping_skill", ("wiping_skill.json",), wiping_skill),
    "wiping_rate": Figure("wiping_rate", ("wiping_rate_realtime_0.json", "wiping_rate.json"), wiping_rate),
    "mutation": Figure("mutation", ("mutation.json",), mutation),
    "mutation_scores": Figure("mutation", ("mutation.json",), mutation_scores),
    "ray_workers": Figure("ray_workers", ("ray_workers.json",), ray_workers),
    "suite_time": Figure("suite_time", ("suite_time.json",), suite_time),
    "tree_policy": Figure("tree_policy", ("tree_policy.json",), tree_policy),
    "skill_reuse": Figure("skill_reuse", ("skill_reuse.json",), skill_reuse),
    "taught_placement": Figure("taught_placement", ("taught_placement.json",), taught_placement),
    "stiffness_ablation_vertical": Figure(
        "stiffness_ablation",
        ("stiffness_ablation_vertical.json",),
        stiffness_ablation("stiffness_ablation_vertical.json"),
    ),
    "teleop_assistance_exact_perception": Figure(
        "teleop_assistance", ("teleop_assistance_exact_perception.json",), teleop_assistance
    ),
}


def render(name: str) -> str:
    """The markdown between a block's markers: the table (and goals) from the stored results, then where each came
    from (mutation's rows say it themselves: each module is run apart)."""
    figure = FIGURES[name]
    results = {result: load(result) for result in figure.results}
    lines = figure.render(results)
    runs = [run_line(result, record) for result, record in results.items() if "provenance" in record]
    if runs:
        lines += [line for run in runs for line in ("", f"From {run}")]
    return "\n".join(lines) + "\n"


def rendered(text: str, source: str = "the text") -> str:
    """``text`` with every results block rendered anew; an unknown name is refused."""

    def block(match):
        name = match.group(2)
        if name not in FIGURES:
            raise KeyError(f"{source}: <!-- results:{name} --> names no figure of bench/render_docs.py")
        return match.group(1) + render(name) + match.group(4)

    return BLOCK.sub(block, text)


def differing(paths=DOCS) -> dict:
    """{doc: [names of the blocks whose text differs from what the stored results render]}; docs without any left
    out."""
    found = {}
    for path in paths:
        text = path.read_text()
        for match in BLOCK.finditer(text):
            if match.group(2) not in FIGURES or render(match.group(2)) != match.group(3):
                found.setdefault(path, []).append(match.group(2))
    return found


def git(*arguments: str) -> str:
    return subprocess.run(["git", *arguments], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()


def measured_results(measures=None) -> list:
    """Every stored result behind a figure, with the paths its bench measures."""
    measures = yaml.safe_load(MEASURES.read_text()) if measures is None else measures
    found = []
    stored = dict.fromkeys((figure.bench, name) for figure in FIGURES.values() for name in figure.results)
    for bench, name in stored:
        record = load(name)
        if bench == "mutation":
            for module, entry in record.items():  # what a module's score measures: the module and its tests
                paths = (f"src/teleteach/{module}", *entry["tests"])
                measured = {**entry["provenance"], "config_sha256": {}} if "provenance" in entry else {}
                found.append(Measured(f"{name}: {module}", measured, paths))
            continue
        script = f"bench/{bench}.py"
        paths = (*([script] if (ROOT / script).exists() else []), *measures[bench])
        found.append(Measured(name, record.get("provenance", {}), paths))
    return found


def config_path(name: str) -> pathlib.Path:
    candidates = (ROOT / "config" / name, ROOT / "bench" / name, ROOT / "bench" / "data" / name)
    return next((path for path in candidates if path.exists()), ROOT / name)


def older_than_the_code(measured: Measured, log=git) -> list:
    """Why a stored result may not hold for the code as it is: run on a dirty tree, code it measures changed by a
    later commit, a config file it read changed since. Empty when none."""
    provenance = measured.provenance
    if not provenance:
        return ["no provenance: the commit it was measured at is unknown"]
    reasons = ["run with uncommitted changes"] if provenance["dirty"] else []
    commit = provenance["commit"]
    try:
        changes = log("log", "--format=%h %ad %s", "--date=short", f"{commit}..HEAD", "--", *measured.paths)
    except subprocess.CalledProcessError:
        return [*reasons, f"its commit {commit[:7]} is not in this checkout's history"]
    if changes:
        lines = changes.splitlines()
        reasons.append(f"{len(lines)} later commit(s) changed what it measures, the last: {lines[0][:100]}")
    for name, digest in provenance.get("config_sha256", {}).items():
        path = config_path(name)
        if not path.exists() or hashlib.sha256(path.read_bytes()).hexdigest() != digest:
            last = log("log", "-1", "--format=%h %ad %s", "--date=short", "--", str(path.relative_to(ROOT)))
            reasons.append(f"{name} differs from the one it read" + (f", last changed by {last[:80]}" if last else ""))
    return reasons


def staleness_report(measures=None) -> str:
    """One line per stored result older than the code it measures, and why."""
    lines = []
    for measured in measured_results(measures):
        reasons = older_than_the_code(measured)
        if reasons:
            lines.append(f"{measured.label} ({measured.provenance.get('commit', '?')[:7]}): {'; '.join(reasons)}")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="write nothing: say what differs and what is stale")
    options = parser.parse_args()
    if options.check:
        different = differing()
        for path, names in different.items():
            print(f"{path.relative_to(ROOT)}: differs from the stored results: {', '.join(names)}")
        print("stored results older than the code they measure:\n" + (staleness_report() or "none"))
        return 1 if different else 0
    for path in DOCS:
        text = path.read_text()
        new = rendered(text, str(path.relative_to(ROOT)))
        if new != text:
            path.write_text(new)
            print(f"rendered {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
