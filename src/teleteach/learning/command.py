"""The ``learn_skill`` command: learn a DMP skill from a skill file or a bag, reproduce it, save, plot, add.

Everything the node does lives here, so that it runs (and is tested) without a ROS master; only ``--add`` talks to
ROS, through the ``/behaviour_tree/add_skill`` service.

A session bag is learned one demonstration at a time (teleteach.learning.bag: each LOW-LEVEL recording, never the
time between recordings or a skill the tree replayed): each one becomes a skill of its own, ``<name>_<number>`` when
there are several, or only the one ``--demonstration N`` names. Nothing is written unless every one was learned.

Each skill's lines say what part of the session (or which skill file) it was learned from, and :func:`advice` says
what its numbers mean for an operator who has not read Appendix C: few samples, a large maximum error, a long
demonstration, each with what to change when it is worth changing.
"""

import argparse
import dataclasses
import pathlib
import re
import sys
from typing import Callable, Dict, List, Optional, Sequence

import numpy as np

from teleteach.control.stiffness import translational_stiffness
from teleteach.core import skill_file
from teleteach.core.datadir import data_dir
from teleteach.core.rotations import rpy_rotation
from teleteach.learning import bag
from teleteach.learning.plot import write_figure_c1
from teleteach.learning.preprocess import LearningError
from teleteach.learning.skill import LearnedSkill, LearningParameters, learn, learn_skill, principal_axes_like_base

ADD_SKILL_SERVICE = "behaviour_tree/add_skill"


def parser() -> argparse.ArgumentParser:
    """The command line of ``learn_skill``."""
    defaults = LearningParameters.from_yaml()
    result = argparse.ArgumentParser(
        prog="learn_skill",
        description="Learn a geometry-aware DMP stiffness skill from a taught skill (.npz) or from each demonstration "
        "(LOW-LEVEL recording) of a session bag (.bag), reproduce it (optionally with a new duration and goal "
        "stiffness), save it as a skill of kind 'dmp' in the data directory's skills/, write a Fig. C.1-like PNG, and "
        "optionally add it to the running BT library.",
    )
    result.add_argument("source", help="skill file (.npz), session bag (.bag), or the name of a skill in skills/")
    result.add_argument("--name", default="", help="name of the learned skill (default: <source name>_dmp)")
    result.add_argument(
        "--demonstration",
        type=int,
        metavar="N",
        help="learn only the session bag's N-th demonstration (LOW-LEVEL recording, from 1; default: each one, "
        "named <name>_<N> when there are several)",
    )
    result.add_argument("--duration", type=float, default=None, help="duration of the reproduction [s]")
    result.add_argument(
        "--goal-stiffness",
        type=float,
        nargs=3,
        metavar=("KX", "KY", "KZ"),
        help="principal stiffnesses of the goal [N/m] (default: the demonstrated goal)",
    )
    result.add_argument(
        "--goal-rotation",
        type=float,
        nargs=3,
        metavar=("ROLL", "PITCH", "YAW"),
        help="orientation of the goal's principal axes, R = Rz Ry Rx [deg] (default: the demonstrated goal's axes)",
    )
    result.add_argument("--data-dir", default="", help="data directory (default: teleteach.core.datadir.data_dir())")
    result.add_argument("--output", default="", help="skill file to write (default: <data dir>/skills/<name>.npz)")
    result.add_argument("--plot", default="", help="PNG to write (default: next to the skill file, .png)")
    result.add_argument("--force", action="store_true", help="overwrite an existing skill file")
    result.add_argument("--add", action="store_true", help=f"add the skill to the running BT ({ADD_SKILL_SERVICE})")
    result.add_argument("--timeout", type=float, default=3.0, help="seconds to wait for the service with --add")
    result.add_argument("--rate", type=float, default=defaults.rate, help="resampling/reproduction rate [Hz]")
    result.add_argument("--smoothing", type=float, default=defaults.smoothing, help="smoothing std on SPD [s]")
    result.add_argument(
        "--basis-per-second", type=float, default=defaults.basis_per_second, help="basis functions per second"
    )
    result.add_argument("--alpha-z", type=float, default=defaults.alpha_z, help="DMP spring gain alpha_z")
    return result


def _source_path(source: str, skills: pathlib.Path) -> pathlib.Path:
    path = pathlib.Path(source).expanduser()
    if path.suffix in (".npz", ".bag") or path.exists():
        return path
    return skills / f"{source}.npz"


def _default_name(path: pathlib.Path) -> str:
    stem = re.sub(r"\W", "_", path.stem)
    stem = stem if stem and not stem[0].isdigit() else f"skill_{stem}"
    return f"{stem}_dmp"


def goal_stiffness(learned_goal, principal: Optional[Sequence[float]], rotation: Optional[Sequence[float]]):
    """The goal stiffness asked for on the command line, or None to keep the demonstrated goal."""
    if principal is None and rotation is None:
        return None
    if principal is not None and not all(np.isfinite(value) and value > 0 for value in principal):
        raise LearningError(f"--goal-stiffness needs three finite values > 0 N/m, got {list(principal)}")
    if rotation is not None and not all(np.isfinite(value) for value in rotation):
        raise LearningError(f"--goal-rotation needs three finite angles, got {list(rotation)}")
    axes = principal_axes_like_base(learned_goal)
    if rotation is not None:
        roll, pitch, yaw = rotation
        axes = rpy_rotation(np.radians([roll, pitch, yaw]))
    if principal is None:
        principal = np.diag(axes.as_matrix().T @ learned_goal @ axes.as_matrix())
    return translational_stiffness(principal, axes)


def add_to_library(name: str, path: pathlib.Path, timeout: float) -> str:
    """Call ``/behaviour_tree/add_skill`` (kind "dmp"); return its message or raise :class:`LearningError`."""
    import rosgraph
    import rospy

    from teleteach.srv import AddSkill

    service = rospy.resolve_name(
        ADD_SKILL_SERVICE
    )  # in ROS_NAMESPACE (or __ns:=): /behaviour_tree/add_skill at the root
    if not rosgraph.is_master_online():
        raise LearningError(f"--add: no ROS master is running, so {service} is absent (skill saved: {path})")
    try:
        rospy.wait_for_service(service, timeout=timeout)
        response = rospy.ServiceProxy(service, AddSkill)(name=name, kind="dmp", data_file=str(path))
    except rospy.ROSException:
        raise LearningError(
            f"--add: service {service} is not available (is the behaviour_tree node running?); skill saved: {path}"
        ) from None
    except rospy.ServiceException as error:
        raise LearningError(f"--add: {service} failed: {error} (skill saved: {path})") from None
    if not response.success:
        raise LearningError(f"--add: the behaviour tree refused the skill: {response.message} (skill saved: {path})")
    return response.message


@dataclasses.dataclass
class Source:
    """What one skill is learned from: a skill file, a whole bag, or one recording of a session bag."""

    what: str  # for the output: "<file>", "demonstration 2 of <bag>, 18.6-31.1 s into the bag", ...
    session: Optional[bag.SessionBag] = None
    recording: Optional[bag.Recording] = None  # None: all of the session's bag
    demonstrated: Optional[skill_file.Skill] = None

    def learn(self, name: str, parameters: LearningParameters) -> LearnedSkill:
        """The DMPs of this source. Raises :class:`LearningError`."""
        if self.demonstrated is not None:
            learned = learn_skill(self.demonstrated, name, parameters)
            learned.source["file"] = self.what
            return learned
        origin = {"bag": str(self.session.path), "found_by": self.session.found_by}
        if self.recording is not None:
            origin.update(
                demonstration=self.recording.number,
                demonstrations=len(self.session.recordings),
                start=self.recording.start,  # [s] into the bag
                end=self.recording.end,
            )
        times, stiffness, poses = self.session.demonstration(self.recording)
        return learn(times, stiffness, poses, name, parameters, source=origin)


def sources(path: pathlib.Path, number: Optional[int], report: Callable[[str], None]) -> List[Source]:
    """What to learn from ``path``: a skill file, or a session bag's demonstrations (only the ``number``-th if given).

    Lists a session bag's demonstrations. Raises :class:`LearningError`, also for a session bag with no
    demonstration.
    """
    if path.suffix != ".bag":
        if number is not None:
            raise LearningError(f"--demonstration picks a demonstration of a session bag; {path} is not a .bag")
        try:
            demonstrated = skill_file.load(path)
        except skill_file.SkillFileError as error:
            raise LearningError(str(error)) from None
        return [Source(f"{path}, {skill_origin(demonstrated)}", demonstrated=demonstrated)]
    session = bag.read_session_bag(path)
    if session.recordings is None:
        found = [Source(f"all of {path} ({session.found_by})", session)]
    else:
        found = [
            Source(f"demonstration {recording.number} of {path}, {recording.span}", session, recording)
            for recording in session.recordings
        ]
    if not found:
        raise LearningError(
            f"bag {path} holds no demonstration to learn from: no LOW-LEVEL recording, by {session.found_by}"
        )
    if number is not None and not 1 <= number <= len(found):
        raise LearningError(f"--demonstration {number}: bag {path} holds demonstrations 1 to {len(found)}")
    if session.recordings:
        plural = "s" if len(found) > 1 else ""
        report(f"{path} holds {len(found)} demonstration{plural} (LOW-LEVEL recording{plural}), by {session.found_by}:")
        for recording in session.recordings:
            report(f"  {recording}")
    return found if number is None else [found[number - 1]]


def skill_origin(skill: skill_file.Skill) -> str:
    """Where a skill file's samples come from, in words: all of the recording it holds, and along what."""
    along = skill.provenance.get("trajectory")
    return f"all of its {skill.kind} recording" + (f" along {along}" if along else "")


def files(arguments: argparse.Namespace, root: pathlib.Path, name: str, number: Optional[int]):
    """(skill file, plot) of the skill ``name``; ``number``: which of several, appended to --output's and --plot's."""

    def numbered(path: pathlib.Path) -> pathlib.Path:
        return path if number is None else path.with_name(f"{path.stem}_{number}{path.suffix}")

    output = root / "skills" / f"{name}.npz"
    if arguments.output:
        output = pathlib.Path(arguments.output).expanduser()
        output = numbered(output if output.suffix == ".npz" else output.with_name(output.name + ".npz"))
    plot = numbered(pathlib.Path(arguments.plot).expanduser()) if arguments.plot else output.with_suffix(".png")
    return output, plot


def run(arguments: argparse.Namespace, report: Callable[[str], None]) -> None:
    """Do what the arguments ask, calling ``report`` with each result line. Raises :class:`LearningError`."""
    root = data_dir(arguments.data_dir or None)
    source = _source_path(arguments.source, root / "skills")
    name = arguments.name or _default_name(source)
    if not name.isidentifier():
        raise LearningError(f"skill name {name!r} must be an identifier (letters, digits, _)")
    try:
        parameters = LearningParameters.from_yaml(
            rate=arguments.rate,
            smoothing=arguments.smoothing,
            basis_per_second=arguments.basis_per_second,
            alpha_z=arguments.alpha_z,
        )
        parameters.dmp_parameters(1.0)
    except ValueError as error:
        raise LearningError(str(error)) from None
    found = sources(source, arguments.demonstration, report)
    several = len(found) > 1
    planned = []  # every skill is learned before any file is written
    for index, origin in enumerate(found, 1):
        skill_name = f"{name}_{index}" if several else name
        output, plot = files(arguments, root, skill_name, index if several else None)
        if output.exists() and not arguments.force:
            raise LearningError(f"{output} exists; choose another --name or pass --force to overwrite it")
        planned.append((skill_name, output, plot, origin))
    learned = []
    for skill_name, output, plot, origin in planned:
        try:
            learned.append((*reproduced(arguments, skill_name, origin, parameters), output, plot, origin))
        except LearningError as error:
            raise LearningError(f"{origin.what}: {error}" if origin.recording else str(error)) from None
    for skill, result, reproduction, output, plot, origin in learned:
        saved = skill_file.save(skill, output)
        demo = result.demonstration
        write_figure_c1(
            plot, demo.sample_time, demo.samples, reproduction.time, reproduction.stiffness, title=skill.name
        )
        for line in learned_lines(skill, result, origin, parameters):
            report(line)
        report(f"saved {saved} (kind dmp, {skill.time.size} samples, {skill.duration:.1f} s)")
        report(f"plot {plot}")
    if source.suffix == ".bag":
        report(f"the session's figures (tree edits, stiffness, rotation): rosrun teleteach report {source}")
    if arguments.add:
        for skill, _, _, output, _, _ in learned:
            report(f"added to the BT library: {add_to_library(skill.name, output, arguments.timeout)}")


def learned_lines(
    skill: skill_file.Skill, result: LearnedSkill, origin: Source, parameters: LearningParameters
) -> List[str]:
    """What was learned from which part of the session, how well, and the advice on its numbers."""
    demo, error = result.demonstration, skill.provenance["reproduction_error"]
    samples = demo.samples.shape[0]
    return [
        f"learned {skill.name} from {origin.what} ({samples} stiffness samples, {demo.duration:.1f} s) in "
        f"{result.learning_time:.3f} s with N = {result.stiffness.parameters.basis_count} basis functions",
        f"reproduction error (same duration and goal): {describe_error(error)}",
        *(f"advice: {line}" for line in advice(samples, demo.duration, error, parameters)),
    ]


def reproduced(arguments: argparse.Namespace, name: str, origin: Source, parameters: LearningParameters):
    """(skill, learned DMPs, reproduction) of one source, with the duration and goal the arguments ask for."""
    learned = origin.learn(name, parameters)
    goal = goal_stiffness(learned.stiffness.goal, arguments.goal_stiffness, arguments.goal_rotation)
    reproduction = learned.reproduce(arguments.duration, goal)
    same = arguments.duration is None and goal is None
    skill = learned.to_skill(reproduction, name, learned.error(reproduction) if same else None)
    skill.provenance["goal_stiffness"] = None if goal is None else goal.tolist()
    demonstrated = origin.demonstrated
    taught_path = {}  # the demonstrations and spread of a path taught in TELEOP: the replay's confidence
    if demonstrated is not None:
        taught_path = {key: value for key, value in demonstrated.provenance.items() if key.startswith("path_")}
    if "path_spread_time" in taught_path:  # a reproduction of another duration stretches the path's timing with it
        stretch = skill.duration / learned.demonstration.duration
        taught_path["path_spread_time"] = [stretch * value for value in taught_path["path_spread_time"]]
    skill.provenance.update(taught_path)
    return skill, learned, reproduction


SPREAD_WORTH_COMPARING = 0.05  # a demonstration varying less (affine-invariant, ~5 %) is constant for the error's sake


def describe_error(error: Dict[str, float]) -> str:
    """The reproduction error as a share of the stiffness, and of the demonstration's variation when it varies."""
    mean, largest = 100 * error["mean_of_stiffness"], 100 * error["max_of_stiffness"]
    text = f"mean {mean:.2f} %, max {largest:.2f} % of the stiffness"
    if error["spread"] < SPREAD_WORTH_COMPARING:
        return f"{text} (the demonstration is constant)"
    return f"{text}; mean {100 * error['mean_relative']:.1f} % of the demonstration's variation"


HELD_SAMPLES_PER_SECOND = 1.0
"""Fewer stiffness samples per second than this: the ellipsoid was held between a few changes."""
STEP_ERROR = 0.25
"""[share of the stiffness] A largest error above this, with a mean under :data:`POOR_MEAN_ERROR`: a rounded step."""
POOR_MEAN_ERROR = 0.05
"""[share of the stiffness] A mean error above this is a fit worth improving."""
LONG_DEMONSTRATION = 30.0
"""[s] A demonstration longer than this outlasted the placing trajectories (12-15 s): the replay lasts as long."""


def advice(samples: int, duration: float, error: Dict[str, float], parameters: LearningParameters) -> List[str]:
    """What a learned skill's numbers mean, and what to change when one is worth changing (one line each).

    Args:
        samples: the demonstration's stiffness samples (the GUI's, recovered from the recording)
        duration: [s] the demonstration's
        error: :func:`teleteach.learning.skill.reproduction_error` of the same-duration reproduction
        parameters: the learning parameters used
    """
    per_second = parameters.basis_per_second
    lines = []
    if samples < HELD_SAMPLES_PER_SECOND * duration:
        lines.append(
            f"{samples} stiffness samples in {duration:.1f} s: a sample is a change of the ellipsoid (or the end of a "
            "hold), so few samples mean the stiffness was held most of the time; the skill holds it too"
        )
    mean, largest = error["mean_of_stiffness"], error["max_of_stiffness"]
    if mean > POOR_MEAN_ERROR:
        lines.append(
            f"mean error {100 * mean:.1f} % of the stiffness: the DMP does not follow this demonstration closely; "
            f"try --basis-per-second {2 * per_second:g} (now {per_second:g}) or less --smoothing "
            f"(now {parameters.smoothing:g} s)"
        )
    elif largest > STEP_ERROR:
        lines.append(
            f"max error {100 * largest:.0f} % is where the stiffness stepped: {per_second:g} basis functions per "
            f"second round a step over about {1.0 / per_second:.2f} s, and the mean, {100 * mean:.1f} %, is what a "
            f"replay follows; --basis-per-second {2 * per_second:g} rounds steps less"
        )
    if duration > LONG_DEMONSTRATION:
        lines.append(
            f"the demonstration lasted {duration:.1f} s: a recording runs from one double click to the next, also "
            "after the trajectory ended, and a replay lasts as long; --duration S replays it in S seconds"
        )
    return lines


def main(argv: Sequence[str]) -> int:
    """Entry point of the node: parse, run, print; a one-line error and exit code 2 on bad input."""
    arguments = parser().parse_args(list(argv))
    try:
        run(arguments, lambda line: print(f"learn_skill: {line}", flush=True))
    except (LearningError, OSError) as error:
        print(f"learn_skill: error: {error}", file=sys.stderr)
        return 2
    return 0
