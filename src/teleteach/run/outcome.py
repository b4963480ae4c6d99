"""What a thesis run achieved, computed from plain data (no ROS): tree edits, stiffness phases, product placement.

One check per experiment mirrors the thesis' results: III-B removes PlaceItem, III-C's recorded stiffness shows its
three phases (approach compliant with equal low X/Y stiffness, Y stiffened for alignment, X stiffened for insertion),
III-D turns the stiffest axis 45 degrees, III-E inserts the taught skill at the dialled index and the tree runs it,
and the products end in their gaps without pushing their neighbours. :class:`RunSummary` holds what was found.
"""

import dataclasses
import json
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
from py_trees.common import Status

from teleteach.core import placement
from teleteach.core.active_tab import Tab
from teleteach.core.scene import Scene
from teleteach.core.skill_file import Skill, SkillFileError
from teleteach.core.skill_file import load as load_skill
from teleteach.recording import report
from teleteach.recording.session import Session

# Phases of the demonstration trajectories [s from the start of the recording]: approach, alignment, insertion
PHASES = {
    "perpendicular": ((0.0, 3.0), (3.0, 5.0), (5.0, 11.0)),  # config/trajectories/perpendicular.yaml
    "angled_45": ((0.0, 3.0), (3.0, 7.0), (7.0, 12.0)),  # config/trajectories/angled_45.yaml
    # the path config/scenarios/teach_placement.yaml teaches, played 3 s (taught_path_approach) after the hand
    "teach_placement": ((0.0, 7.0), (7.0, 9.5), (9.5, 14.5)),
}


@dataclasses.dataclass
class StiffnessPhases:
    """Principal stiffness along base X and Y [N/m] per phase of a recorded perpendicular placement."""

    approach_x: float
    approach_y: float
    alignment_y: float
    insertion_x: float

    @property
    def alignment_ratio(self) -> float:
        """Y stiffness during alignment over Y stiffness during approach."""
        return self.alignment_y / self.approach_y

    @property
    def insertion_ratio(self) -> float:
        """X stiffness during insertion over X stiffness during approach."""
        return self.insertion_x / self.approach_x

    def check(self, min_ratio: float = 3.0, stiffer_insertion: bool = True) -> List[str]:
        """Problems with the three phases (empty: III-C's pattern is there; III-D's without ``stiffer_insertion``)."""
        problems = []
        if abs(self.approach_x - self.approach_y) > 0.1 * max(self.approach_x, self.approach_y):
            problems.append(f"approach X/Y stiffness not equal ({self.approach_x:.0f} vs {self.approach_y:.0f} N/m)")
        if self.alignment_ratio < min_ratio:
            problems.append(f"Y stiffness in alignment only {self.alignment_ratio:.1f}x the approach's")
        if stiffer_insertion and self.insertion_ratio < min_ratio:
            problems.append(f"X stiffness in insertion only {self.insertion_ratio:.1f}x the approach's")
        return problems


def as_taught(skill: Skill) -> Skill:
    """The skill in base_link as the operator taught it: the thesis' X and Y are the base's axes of that moment.

    A skill stored in its target's frame is turned back by the target's pose when it was taught (III-D's ellipsoid
    turned 45 degrees from the base is along the shelf, i.e. along the gap's Y, in the target's frame).
    """
    return skill if skill.target is None else skill.in_base(skill.target.transform)


def stiffness_phases(skill: Skill, trajectory: str = "perpendicular") -> StiffnessPhases:
    """Median stiffness in the approach, peak Y in alignment and peak X in insertion, from the diagonal of K.

    K is read in the skill's own frame: pass :func:`as_taught` for the base's axes.
    """
    times = skill.time - skill.time[0]
    kx, ky = skill.stiffness[:, 0, 0], skill.stiffness[:, 1, 1]
    approach_window, alignment_window, insertion_window = PHASES[trajectory]

    def window(bounds: Tuple[float, float]) -> np.ndarray:
        inside = (times >= bounds[0]) & (times < bounds[1])
        if not inside.any():
            raise ValueError(f"the recording ({times[-1]:.1f} s) has no samples in {bounds[0]:g}-{bounds[1]:g} s")
        return inside

    approach = window(approach_window)
    return StiffnessPhases(
        approach_x=float(np.median(kx[approach])),
        approach_y=float(np.median(ky[approach])),
        alignment_y=float(ky[window(alignment_window)].max()),
        insertion_x=float(kx[window(insertion_window)].max()),
    )


def alignment_axis_yaw(skill: Skill, trajectory: str = "perpendicular") -> float:
    """Direction [deg, (-90, 90]] of the stiffest horizontal axis of K at the end of the alignment phase (III-D)."""
    times = skill.time - skill.time[0]
    index = max(int(np.searchsorted(times, PHASES[trajectory][1][1])) - 1, 0)
    values, vectors = np.linalg.eigh(skill.stiffness[index][:2, :2])
    major = vectors[:, int(np.argmax(values))]
    yaw = float(np.degrees(np.arctan2(major[1], major[0])))
    return yaw - 180.0 if yaw > 90.0 else yaw + 180.0 if yaw <= -90.0 else yaw


TAUGHT_SKILL = "the taught skill"  # a placement's expected setter: the leaf of the skill taught in the run
LOW_LEVEL_TEACHING = "LOW-LEVEL teaching"  # by_skill of a product set down while the operator taught it
REST = 0.005  # [m] a product within this of its final position has come to rest there


def placements(session: Session, scene: Scene) -> List[dict]:
    """Every product that ended on a shelf, judged from the scene recorded in the bag (teleteach.core.placement).

    Each entry: product, gap (None when in none), distance_m from the nearest gap's target, upright,
    neighbours_max_move_m, and by_skill: who put it where it ended, i.e. the tree leaf running when it came to rest
    there (it stays put once let go), or LOW-LEVEL teaching when the operator's demonstration set it down (the tree
    paused); judged_from: the scene topic the judgement read (the true scene when the bag has it); base_error: where
    the last MoveBase before then stopped off its goal (x, y [m], yaw [deg], in the goal's frame), and
    perception_error: how far off perception saw the gap then (depth, across, height [m], yaw [deg]), each None when
    the bag does not say.
    """
    return [_entry(session, *found) for found in _placed(session, scene)]


def _placed(session: Session, scene: Scene) -> List[Tuple[placement.Placement, Optional[str], float]]:
    """The judged placements of the products that ended on a shelf, each with who set it down and when."""
    initial = {name: series.values[0, :3] for name, series in session.products.items()}
    final = {name: (series.values[-1, :3], series.values[-1, 3:]) for name, series in session.products.items()}
    found = []
    for result in placement.placed_products(scene, initial, final):
        series = session.products[result.product]
        away = np.flatnonzero(np.linalg.norm(series.values[:, :3] - series.values[-1, :3], axis=1) > REST)
        rest = series.times[away[-1] + 1] if away.size and away[-1] + 1 < len(series) else series.times[0]
        found.append((result, _set_down_by(session, rest), float(rest)))
    return found


def _entry(session: Session, result: placement.Placement, by_skill: Optional[str], rest: float) -> dict:
    base = session.base_error(rest)
    seen = session.gap_perception_error(result.gap or result.nearest_gap, rest)
    return {
        "product": result.product,
        "gap": result.gap,
        "distance_m": round(result.distance_m, 4),
        "upright": result.upright,
        "by_skill": by_skill,
        "neighbours_max_move_m": round(result.neighbours_max_move_m, 4),
        "judged_from": session.products_from,
        "base_error": None
        if base is None
        else {"x_m": round(base[0], 4), "y_m": round(base[1], 4), "yaw_deg": round(float(np.degrees(base[2])), 2)},
        "perception_error": None
        if seen is None
        else {
            "gap": result.gap or result.nearest_gap,
            "depth_m": round(seen[0], 4),
            "across_m": round(seen[1], 4),
            "height_m": round(seen[2], 4),
            "yaw_deg": round(float(np.degrees(seen[3])), 2),
        },
    }


def _set_down_by(session: Session, time: float) -> Optional[str]:
    """The tree leaf running at time; else LOW-LEVEL teaching while that tab was open (the tree paused); else None."""
    snapshots = [tree for tree in session.trees if tree.time <= time]
    running = [name for name in (snapshots[-1].running if snapshots else ()) if name != "PauseCondition"]
    if running:
        return running[0]
    if session.active_tab is not None and len(session.active_tab) and session.active_tab.at(time) == Tab.LOW_LEVEL:
        return LOW_LEVEL_TEACHING
    return None


def sequence_changes(sequences: Sequence[Tuple[str, ...]]) -> List[Tuple[str, ...]]:
    """The distinct consecutive values of a composite's children over time (each edit once)."""
    changes: List[Tuple[str, ...]] = []
    for children in sequences:
        if not changes or changes[-1] != tuple(children):
            changes.append(tuple(children))
    return changes


def describe_edit(before: Sequence[str], after: Sequence[str]) -> str:
    """One line: which leaves left or joined a sequence, and where, in the report's words (recording.report)."""
    removed = [name for name in before if name not in after]
    inserted = [(name, index) for index, name in enumerate(after) if name not in before]
    return report.describe_edit(removed, inserted) or "reordered"


def expected_sequences(initial: Sequence[str], removed: Optional[str], inserted: Optional[str], index: Optional[int]):
    """The children after III-B (``removed`` gone) and after III-E (``inserted`` at ``index``); None: no such edit."""
    after_removal = [name for name in initial if name != removed]
    after_insertion = list(after_removal)
    if inserted is not None and index is not None:
        after_insertion.insert(index, inserted)
    return tuple(after_removal), tuple(after_insertion)


# --- one check per experiment: each returns its problems (empty: the experiment did what the thesis shows) ---------


def check_iii_b(
    changes: Sequence[Tuple[str, ...]], after_removal: Tuple[str, ...], removed: Optional[str]
) -> List[str]:
    """III-B: the operator removed ``removed`` from the running tree (None: nothing to remove)."""
    if removed is not None and tuple(after_removal) not in [tuple(children) for children in changes[1:]]:
        return [f"the tree never was {list(after_removal)} (III-B)"]
    return []


def check_iii_c(skill_path: Optional[str], trajectory: str, stiffer_insertion: bool) -> Tuple[List[str], dict]:
    """III-C: a skill was taught, and its stiffness shows the three phases.

    Returns the problems and what was seen: ``stiffness_phases``, ``alignment_ratio``, ``insertion_ratio``,
    ``alignment_axis_yaw_deg`` (each None when there is no readable skill).
    """
    seen = {"stiffness_phases": None, "alignment_ratio": None, "insertion_ratio": None, "alignment_axis_yaw_deg": None}
    if skill_path is None:
        return ["no skill was taught (III-C)"], seen
    try:
        skill = as_taught(load_skill(skill_path))
        phases = stiffness_phases(skill, trajectory)
        yaw = alignment_axis_yaw(skill, trajectory)
    except (SkillFileError, ValueError) as error:
        return [f"taught skill unreadable: {error}"], seen
    seen.update(
        stiffness_phases=dataclasses.asdict(phases),
        alignment_ratio=phases.alignment_ratio,
        insertion_ratio=phases.insertion_ratio,
        alignment_axis_yaw_deg=yaw,
    )
    return phases.check(stiffer_insertion=stiffer_insertion), seen


def check_iii_d(yaw: Optional[float], expected_yaw: Optional[float], tolerance: float = 5.0) -> List[str]:
    """III-D: after the alignment the stiffest horizontal axis points at ``expected_yaw`` [deg] (None: not checked)."""
    if expected_yaw is None or yaw is None or abs(yaw - expected_yaw) <= tolerance:
        return []
    return [f"stiffest horizontal axis at {yaw:.0f} deg after alignment, not {expected_yaw:g}"]


def check_iii_e(
    final_children: Tuple[str, ...],
    after_insertion: Tuple[str, ...],
    taught: Optional[str],
    taught_status: Optional[Status],
    taught_message: str,
    inserted: bool,
) -> List[str]:
    """III-E: the taught skill sits where the dial put it, and the tree ran it successfully (when it was inserted)."""
    if taught is None:
        return []
    problems = []
    if tuple(final_children) != tuple(after_insertion):
        problems.append(f"final tree {list(final_children)}, expected {list(after_insertion)} (III-E)")
    if inserted and taught_status != Status.SUCCESS:
        state = taught_status.value if taught_status else "never run"
        problems.append(f"the taught skill {taught} did not succeed on the robot ({state}: {taught_message})")
    return problems


def check_taught_used(taught: Optional[str], leaf: Optional[str], status: Optional[Status], message: str) -> List[str]:
    """The tree's ``leaf`` (a PlaceTaught) succeeded placing with the ``taught`` skill (None leaf: not checked)."""
    if leaf is None or taught is None:
        return []
    if status != Status.SUCCESS or not message.startswith(f"with {taught}:"):
        state = status.value if status else "never run"
        return [f"{leaf} did not place with the taught skill {taught} ({state}: {message})"]
    return []


def check_placements(
    session: Session, scene: Scene, expected: Dict[str, Tuple[str, Optional[str]]]
) -> Tuple[List[str], List[dict]]:
    """Where the products ended (judged from the bag), against product -> (gap, by_skill or None for anyone).

    Returns the problems (the placement's own, teleteach.core.placement, and who set it down) and the summary's entries.
    """
    found = {result.product: (result, by_skill, rest) for result, by_skill, rest in _placed(session, scene)}
    problems = []
    for product, (gap, expected_by) in expected.items():
        if product not in found:
            problems.append(f"{product} did not end on the shelf (expected in {gap})")
            continue
        result, by_skill, _ = found[product]
        problems += result.problems(gap)
        if expected_by is not None and by_skill != expected_by:
            problems.append(f"{product} was set down by {by_skill}, not by {expected_by}")
    return problems, [_entry(session, *entry) for entry in found.values()]


def _uncertainty_met(entry: dict) -> str:
    """The errors a placement met, in words (empty when the bag does not say)."""
    said = []
    base = entry.get("base_error")
    if base:
        said.append(
            f"the base stood ({1000 * base['x_m']:+.1f}, {1000 * base['y_m']:+.1f}) mm, {base['yaw_deg']:+.2f} deg "
            "off its goal"
        )
    seen = entry.get("perception_error")
    if seen:
        said.append(
            f"perception saw {seen['gap']} {1000 * seen['depth_m']:+.1f} mm deep, {1000 * seen['across_m']:+.1f} mm "
            f"across, {1000 * seen['height_m']:+.1f} mm high, {seen['yaw_deg']:+.2f} deg off"
        )
    return f"; {' and '.join(said)}" if said else ""


def help_time(requests: Sequence[tuple], closed: Sequence[float]) -> Optional[float]:
    """[s] from the first help request (time, node, reason) to the last one's close: the operator's time answering.

    None without a help request, or while the last one is still open.
    """
    if not requests or len(closed) < len(requests):
        return None
    return float(closed[-1] - requests[0][0])


@dataclasses.dataclass
class RunSummary:
    """What a run did and found: written as summary.json and, in words, as summary.md."""

    folder: str
    problems: List[str]
    finished: bool
    bag: Optional[str]
    tree_initial: List[str]
    tree_changes: List[List[str]]
    tree_edits: List[str]
    tree_final: List[str]
    expected_after_iii_b: List[str]
    expected_after_iii_e: List[str]
    taught_skills: List[dict]
    taught_skill_result: Optional[dict]
    stiffness_phases: Optional[dict]
    alignment_ratio: Optional[float]
    insertion_ratio: Optional[float]
    alignment_axis_yaw_deg: Optional[float]
    placements: List[dict]
    help_requests: List[tuple]
    help_time_s: Optional[float]
    tabs: List[tuple]
    screenshots: List[str]
    screenshot_errors: List[str]
    figures: List[str]
    timings_wall_s: Dict[str, float]

    @property
    def passed(self) -> bool:
        """Every check passed."""
        return not self.problems

    def to_json(self) -> str:
        """summary.json: every field, and ``passed``."""
        return json.dumps({"passed": self.passed, **dataclasses.asdict(self)}, indent=2, default=str) + "\n"

    def to_markdown(self) -> str:
        """summary.md, also printed at the end of a run."""
        lines = [f"# Thesis run: {'PASSED' if self.passed else 'FAILED'}", "", f"Run folder: {self.folder}", ""]
        lines.append("- tree: " + ("; ".join(self.tree_edits) or "unchanged"))
        lines.append("  final BehaviorExecution: " + " -> ".join(self.tree_final))
        result = self.taught_skill_result
        if self.taught_skills:
            taught = self.taught_skills[0]
            if result is None:
                ran = "; not in the tree"
            else:
                succeeded = result["status"] == Status.SUCCESS.value
                ran = f"; run by the tree: {'succeeded' if succeeded else 'NOT successful'}"
            lines.append(f"- skill taught: {taught['name']} ({taught['file']}){ran}")
            if result:
                lines.append(f"  {result['message']}")
        else:
            lines.append("- skill taught: none")
        if self.stiffness_phases is not None:
            phases = self.stiffness_phases
            lines.append(
                f"- stiffness phases: approach X/Y {phases['approach_x']:.0f}/{phases['approach_y']:.0f} N/m, "
                f"alignment Y {phases['alignment_y']:.0f} N/m ({self.alignment_ratio:.1f}x), "
                f"insertion X {phases['insertion_x']:.0f} N/m ({self.insertion_ratio:.1f}x); stiffest horizontal "
                f"axis after alignment at {self.alignment_axis_yaw_deg:.0f} deg"
            )
        for entry in self.placements:
            where = f"in {entry['gap']}" if entry["gap"] else "in NO gap"
            upright = "upright" if entry["upright"] else "NOT upright"
            lines.append(
                f"- product {entry['product']}: on the shelf {where}, {upright}, {1000 * entry['distance_m']:.1f} mm "
                f"from the nearest gap's centre, put there by {entry['by_skill'] or 'nobody known'}; its neighbours "
                f"moved at most {1000 * entry['neighbours_max_move_m']:.1f} mm; judged from "
                f"{entry.get('judged_from') or 'nothing'}{_uncertainty_met(entry)}"
            )
        if not self.placements:
            lines.append("- products: none ended on the shelf")
        for _, node, reason in self.help_requests:
            lines.append(f"- help request: {node}: {reason}")
        if self.help_time_s is not None:
            lines.append(f"- from the first help request to the tree going on: {self.help_time_s:.0f} s (ROS time)")
        lines.append(
            f"- files: {self.bag}, report/ ({len(self.figures)} figures), screenshots: {len(self.screenshots)}, "
            "tree_before/after.yaml/.txt, skills/"
        )
        lines.extend(f"- picture missing: {error}" for error in self.screenshot_errors)
        lines.extend(f"- PROBLEM: {problem}" for problem in self.problems)
        lines.append(f"- wall time [s]: {self.timings_wall_s}")
        return "\n".join(lines) + "\n"
