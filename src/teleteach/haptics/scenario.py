"""Scripted device input: a YAML file of timed keyframes, validated and interpolated (the ``scenario`` backend).

The format (documented for users in ``config/scenarios/example.yaml``)::

    description: free text (optional)
    interpolation: linear      # linear | smooth (position and gripper; orientation always uses Slerp)
    click_duration: 0.2        # [s] duration of the scripted close-and-back flick of a click (optional)
    keyframes:
      - {t: 0.0, position: [0.0, 0.0, 0.0], rpy: [0.0, 0.0, 0.0], gripper: 0.25}
      - {t: 1.5, position: [0.05, 0.0, 0.0], rpy: [0.0, 0.0, 0.3], gripper: 0.25, click: true}

``t`` [s] strictly increasing from >= 0, ``position`` [m] x y z, ``rpy`` [rad] roll pitch yaw with
R = Rz(yaw) Ry(pitch) Rx(roll), ``gripper`` [rad] >= 0 (0 closed, ~0.25 resting, >= 0.45 fully open), ``click``
(optional) starts a flick of the gripper at ``t``. Every problem is reported with the file, line, keyframe index
and field, because a scenario is written by hand.

A keyframe may also wait for the system, like a patient operator: ``wait: {tab: LOW_LEVEL, tree_running:
PickItem2, recording: true, help_request: true, study: RUNNING}`` (any of these; ``tree_running`` may be a
shell-style pattern, ``DemonstratedPlace_*``: the GUI names a taught skill after those already in the data directory;
``study`` is a user study's phase, see teleteach/StudyState) with ``timeout`` [s] (default 30). When the
scenario reaches that keyframe, the device holds it (the scenario's clock stops) until everything named holds, then
goes on (a click of that keyframe comes after the wait); when the timeout expires first, the scenario fails with a
message naming the keyframe and what it saw.
"""

import dataclasses
import fnmatch
import math
import pathlib
from typing import Any, Callable, Dict, FrozenSet, List, Optional, Tuple

import numpy as np
import yaml
from scipy.interpolate import PchipInterpolator, make_interp_spline
from scipy.spatial.transform import Slerp

from teleteach.core.active_tab import Tab
from teleteach.core.rotations import rpy_rotation
from teleteach.core.study_phase import PHASE_NAMES
from teleteach.haptics.click import ClickDetector, ClickParameters, flick_gripper_angle
from teleteach.haptics.device import DeviceBackend, DeviceSample

INTERPOLATIONS = ("linear", "smooth")
AT_END_CHOICES = ("hold", "exit")
DEFAULT_CLICK_DURATION = 0.2  # [s]
DEFAULT_WAIT_TIMEOUT = 30.0  # [s] of ROS time
TABS = tuple(tab.name for tab in Tab)  # /teleteach/active_tab 0..4
_TOP_LEVEL_FIELDS = ("description", "interpolation", "click_duration", "keyframes")
_KEYFRAME_FIELDS = ("t", "position", "rpy", "gripper", "click", "wait", "timeout")
_WAIT_FIELDS = ("tab", "tree_running", "recording", "help_request", "study")
_REQUIRED_KEYFRAME_FIELDS = ("t", "position", "rpy", "gripper")


class ScenarioError(ValueError):
    """A scenario file that cannot be played; the message names the file, line, keyframe and field."""


@dataclasses.dataclass(frozen=True)
class Wait:
    """What the system must show before a scenario goes on past a keyframe; unset fields are not checked."""

    tab: Optional[int] = None  # index in TABS
    tree_running: Optional[str] = None  # a tree node that must be RUNNING, or a pattern (fnmatch) one must match
    recording: Optional[bool] = None
    help_request: Optional[bool] = None  # whether a help request must be open
    timeout: float = DEFAULT_WAIT_TIMEOUT  # [s]
    study: Optional[str] = None  # a user study's phase (PHASE_NAMES) on study/state


@dataclasses.dataclass(frozen=True)
class SystemState:
    """What a scenario can wait for, as last seen (None: nothing heard yet)."""

    tab: Optional[int] = None
    running: FrozenSet[str] = frozenset()
    recording: Optional[bool] = None
    help_request: Optional[bool] = None
    study: Optional[str] = None


def unmet(wait: Wait, state: SystemState) -> List[str]:
    """The conditions of ``wait`` that ``state`` does not meet, each with what was seen ([] when all are met)."""
    missing = []
    if wait.tab is not None and state.tab != wait.tab:
        seen = TABS[state.tab] if state.tab is not None and 0 <= state.tab < len(TABS) else state.tab
        missing.append(f"tab {TABS[wait.tab]} (seen {seen})")
    if wait.tree_running is not None and not fnmatch.filter(state.running, wait.tree_running):
        running = ", ".join(sorted(state.running)) or "nothing"
        missing.append(f"tree_running {wait.tree_running} (running: {running})")
    if wait.recording is not None and state.recording != wait.recording:
        missing.append(f"recording {str(wait.recording).lower()} (seen {state.recording})")
    if wait.help_request is not None and state.help_request != wait.help_request:
        missing.append(f"help_request {str(wait.help_request).lower()} (seen {state.help_request})")
    if wait.study is not None and state.study != wait.study:
        missing.append(f"study {wait.study} (seen {state.study})")
    return missing


@dataclasses.dataclass(frozen=True)
class Keyframe:
    """One device state at one instant of a scenario.

    Attributes:
        time: [s] since the start of the scenario.
        position: [m] x, y, z in the device frame.
        rpy: [rad] roll, pitch, yaw; R = Rz(yaw) Ry(pitch) Rx(roll).
        gripper: [rad] gripper opening angle.
        click: a scripted click (gripper flick) starts at ``time``.
        line: line of the keyframe in its file (1-based), for messages.
        wait: what the system must show before the scenario goes on past ``time`` (None: nothing).
    """

    time: float
    position: Tuple[float, float, float]
    rpy: Tuple[float, float, float]
    gripper: float
    click: bool = False
    line: int = 0
    wait: Optional[Wait] = None


@dataclasses.dataclass(frozen=True)
class Scenario:
    """A validated scenario: keyframes in strictly increasing time order."""

    keyframes: Tuple[Keyframe, ...]
    interpolation: str = "linear"
    click_duration: float = DEFAULT_CLICK_DURATION
    description: str = ""
    source: str = "<scenario>"

    @property
    def duration(self) -> float:
        """[s] time of the last keyframe."""
        return self.keyframes[-1].time

    def click_times(self) -> List[float]:
        """[s] start times of the scripted clicks."""
        return [keyframe.time for keyframe in self.keyframes if keyframe.click]

    @property
    def waits(self) -> bool:
        """Whether any keyframe waits for the system."""
        return any(keyframe.wait is not None for keyframe in self.keyframes)


def load_scenario(path) -> Scenario:
    """Reads and validates a scenario file.

    Raises:
        ScenarioError: the file is missing, is not YAML, or breaks the format (message names line and field).
    """
    path = pathlib.Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise ScenarioError(f"{path}: cannot read the scenario file ({error.strerror})") from None
    return parse_scenario(text, source=str(path))


def parse_scenario(text: str, source: str = "<scenario>") -> Scenario:
    """Validates scenario YAML text; see the module docstring for the format.

    Raises:
        ScenarioError: the text breaks the format (message names line, keyframe index and field).
    """
    root, data = _yaml_of(text, source)
    if not isinstance(data, dict):
        raise ScenarioError(f"{source}: a scenario is a mapping with a 'keyframes' list")
    top_lines = _field_lines(root)
    for key in data:
        if key not in _TOP_LEVEL_FIELDS:
            raise ScenarioError(
                f"{source}:{top_lines.get(key, 1)}: unknown field '{key}' (allowed: {', '.join(_TOP_LEVEL_FIELDS)})"
            )
    interpolation = data.get("interpolation", "linear")
    if interpolation not in INTERPOLATIONS:
        raise ScenarioError(
            f"{source}:{top_lines.get('interpolation', 1)}: field 'interpolation' must be one of "
            f"{', '.join(INTERPOLATIONS)}, got {interpolation!r}"
        )
    click_duration = data.get("click_duration", DEFAULT_CLICK_DURATION)
    if not _is_number(click_duration) or not math.isfinite(click_duration) or click_duration <= 0.0:
        raise ScenarioError(
            f"{source}:{top_lines.get('click_duration', 1)}: field 'click_duration' must be a positive number of "
            f"seconds, got {click_duration!r}"
        )
    description = data.get("description", "")
    if not isinstance(description, str):
        raise ScenarioError(f"{source}:{top_lines.get('description', 1)}: field 'description' must be text")
    raw_keyframes = data.get("keyframes")
    if not isinstance(raw_keyframes, list) or not raw_keyframes:
        raise ScenarioError(f"{source}:{top_lines.get('keyframes', 1)}: field 'keyframes' must be a non-empty list")
    item_nodes = _mapping_value(root, "keyframes").value
    keyframes = [_parse_keyframe(raw, item_nodes[index], index, source) for index, raw in enumerate(raw_keyframes)]
    _check_times_increase(keyframes, source)
    _check_clicks_apart(keyframes, click_duration, source)
    return Scenario(tuple(keyframes), interpolation, float(click_duration), description, source)


def _yaml_of(text: str, source: str):
    """The text's YAML node tree (for line numbers) and its data; invalid YAML is an error naming its line."""
    try:
        return yaml.compose(text, Loader=yaml.SafeLoader), yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        line = f":{mark.line + 1}" if mark is not None else ""
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise ScenarioError(f"{source}{line}: not valid YAML: {problem}") from None


def _check_times_increase(keyframes: List[Keyframe], source: str) -> None:
    """Rejects keyframes out of time order: interpolating between them would run backwards."""
    for index in range(1, len(keyframes)):
        previous, current = keyframes[index - 1], keyframes[index]
        if current.time <= previous.time:
            raise ScenarioError(
                f"{source}:{current.line}: keyframes[{index}].t: times must increase strictly, "
                f"but t = {current.time} s is not after keyframes[{index - 1}].t = {previous.time} s"
            )


def _check_clicks_apart(keyframes: List[Keyframe], click_duration: float, source: str) -> None:
    """Rejects a click that starts before the previous one ended or ends after the last keyframe: it would be lost."""
    clicks = [(index, keyframe) for index, keyframe in enumerate(keyframes) if keyframe.click]
    for (index, keyframe), (next_index, following) in zip(clicks, clicks[1:]):
        if following.time < keyframe.time + click_duration:
            raise ScenarioError(
                f"{source}:{following.line}: keyframes[{next_index}].click: starts at {following.time} s, before the "
                f"click of keyframes[{index}] has ended ({keyframe.time} s + click_duration {click_duration} s)"
            )
    if clicks and clicks[-1][1].time + click_duration > keyframes[-1].time:
        index, keyframe = clicks[-1]
        raise ScenarioError(
            f"{source}:{keyframe.line}: keyframes[{index}].click: the click ends after the last keyframe "
            f"({keyframe.time} s + click_duration {click_duration} s > {keyframes[-1].time} s); add a keyframe after it"
        )


def check_clicks(scenario: Scenario, parameters: ClickParameters) -> None:
    """Makes sure the click detector will see every scripted click of ``scenario`` with these thresholds.

    Raises:
        ScenarioError: a scripted flick would not be detected (e.g. the gripper is not open enough before it).
    """
    trajectory = ScenarioTrajectory(scenario)
    step = 0.001  # [s] the node's default period
    for index, keyframe in enumerate(scenario.keyframes):
        if not keyframe.click:
            continue
        detector = ClickDetector(parameters)
        times = np.arange(keyframe.time, keyframe.time + scenario.click_duration + step, step)
        for time in times:
            detector.update(time, trajectory.gripper(time))
        if detector.clicks != 1:
            raise ScenarioError(
                f"{scenario.source}:{keyframe.line}: keyframes[{index}].click: this flick would not be detected as "
                f"one click (gripper {trajectory.gripper(keyframe.time):.3f} rad before it; the detector needs it "
                f"above release_threshold {parameters.release_threshold} rad and a close-and-back within "
                f"max_duration {parameters.max_duration} s)"
            )


class ScenarioTrajectory:
    """The continuous device motion of a scenario: keyframes interpolated, scripted clicks added.

    Position and gripper are interpolated piecewise linearly (``linear``) or with a shape-preserving cubic
    (``smooth``: scipy's PCHIP, continuous velocity, never overshoots a keyframe); orientation with scipy's Slerp.
    Before the first and after the last keyframe the device holds still.
    """

    def __init__(self, scenario: Scenario):
        self.scenario = scenario
        keyframes = list(scenario.keyframes)
        if len(keyframes) == 1:
            keyframes.append(dataclasses.replace(keyframes[0], time=keyframes[0].time + 1.0, click=False))
        times = np.array([keyframe.time for keyframe in keyframes])
        values = np.array([[*keyframe.position, keyframe.gripper] for keyframe in keyframes])
        if scenario.interpolation == "smooth":
            self._values = PchipInterpolator(times, values, axis=0)
        else:
            self._values = make_interp_spline(times, values, k=1, axis=0)
        rotations = rpy_rotation([keyframe.rpy for keyframe in keyframes])
        self._orientation = Slerp(times, rotations)
        self._first_time, self._last_time = times[0], times[-1]
        self._click_times = np.array(scenario.click_times())

    def _clamped(self, time: float) -> float:
        return min(max(time, self._first_time), self._last_time)

    def gripper(self, time: float) -> float:
        """[rad] gripper angle at ``time`` [s] of the scenario, scripted flicks included."""
        return self._with_flick(time, float(self._values(self._clamped(time))[3]))

    def _with_flick(self, time: float, base: float) -> float:
        index = int(np.searchsorted(self._click_times, time, side="right")) - 1
        if index < 0:
            return base
        return flick_gripper_angle(base, time - self._click_times[index], self.scenario.click_duration)

    def sample(self, time: float) -> DeviceSample:
        """The device state at ``time`` [s] since the start of the scenario."""
        clamped = self._clamped(time)
        values = self._values(clamped)
        orientation = self._orientation(clamped).as_quat()
        return DeviceSample(
            position=np.asarray(values[:3], dtype=float),
            orientation=orientation,
            gripper=self._with_flick(time, float(values[3])),
        )


class ScenarioBackend(DeviceBackend):
    """Plays a scenario: the sample read at ``time`` is the scenario's state at ``time - start_time - held``.

    The node reads it with ROS time (so it follows /clock under use_sim_time). ``held`` is the time spent at
    keyframes that wait for the system (``system()`` says what it shows): the device holds such a keyframe until
    its conditions are met; when its timeout expires first, :attr:`failure` says why and the backend has
    :attr:`finished`. After the last keyframe the device holds its last state; with ``at_end="exit"`` the backend
    then reports :attr:`finished`.

    A stall of the reading loop must not swallow a click: the flick a read jumped over (all of it or a part, before
    or after the gripper closed) is given by :meth:`missed_gripper`, which the loop's click detector catches up on.
    """

    flick_samples = 20  # per scripted flick, for the catch-up after a stall

    def __init__(
        self,
        scenario: Scenario,
        start_time: float,
        at_end: str = "hold",
        system: Callable[[], SystemState] = SystemState,
    ) -> None:
        if at_end not in AT_END_CHOICES:
            raise ValueError(f"at_end must be one of {', '.join(AT_END_CHOICES)}, got {at_end!r}")
        self._scenario = scenario
        self._trajectory = ScenarioTrajectory(scenario)
        self._start_time = start_time
        self._at_end = at_end
        self._system = system
        self._waits = [(index, keyframe) for index, keyframe in enumerate(scenario.keyframes) if keyframe.wait]
        self._next_wait = 0
        self._clicks = np.array(scenario.click_times())
        self._missed: List[Tuple[float, float]] = []
        self._held = 0.0
        self._waiting_since: Optional[float] = None
        self._elapsed = 0.0
        self.duration = scenario.duration
        self.failure = ""

    def read(self, time: float) -> DeviceSample:
        """The scenario's device state at ``time`` [s]."""
        elapsed = time - self._start_time - self._held
        while self._next_wait < len(self._waits) and not self.failure:
            index, keyframe = self._waits[self._next_wait]
            if keyframe.time > elapsed:
                break
            missing = unmet(keyframe.wait, self._system())
            if not missing:
                self._next_wait += 1
                self._waiting_since = None
                continue
            if self._waiting_since is None:
                self._waiting_since = time - (elapsed - keyframe.time)
            self._held += elapsed - keyframe.time
            elapsed = keyframe.time
            if time - self._waiting_since > keyframe.wait.timeout:
                self.failure = (
                    f"{self._scenario.source}:{keyframe.line}: keyframes[{index}].wait: still waiting after "
                    f"{keyframe.wait.timeout:g} s for {'; '.join(missing)}"
                )
            break
        self._missed = self._flicks_between(self._elapsed, elapsed, time)
        self._elapsed = elapsed
        return self._trajectory.sample(elapsed)

    def missed_gripper(self) -> List[Tuple[float, float]]:
        """The scripted flicks' gripper angles between the last two reads, at the loop's times.

        None without a stall: reads closer than a flick's sampling step miss nothing.
        """
        return self._missed

    def _flicks_between(self, previous: float, elapsed: float, time: float) -> List[Tuple[float, float]]:
        duration = self._scenario.click_duration
        step = duration / self.flick_samples
        if elapsed - previous <= step:
            return []
        missed = []
        for start in self._clicks[(self._clicks + duration > previous) & (self._clicks < elapsed)]:
            for moment in np.linspace(start, start + duration, self.flick_samples + 1):
                if previous < moment < elapsed:
                    missed.append((time - (elapsed - moment), self._trajectory.gripper(moment)))
        return missed

    @property
    def played(self) -> bool:
        """True once the last keyframe has been played (waits included)."""
        return self._elapsed > self.duration

    @property
    def finished(self) -> bool:
        """True once a wait timed out, or once the last keyframe has been played if the scenario should end there."""
        return bool(self.failure) or (self._at_end == "exit" and self._elapsed > self.duration)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _mapping_value(node: yaml.Node, key: str) -> Optional[yaml.Node]:
    for key_node, value_node in node.value:
        if key_node.value == key:
            return value_node
    return None


def _field_lines(node: yaml.Node) -> Dict[str, int]:
    if not isinstance(node, yaml.MappingNode):
        return {}
    return {key_node.value: key_node.start_mark.line + 1 for key_node, _ in node.value}


def _parse_keyframe(raw: Any, node: yaml.Node, index: int, source: str) -> Keyframe:
    line = node.start_mark.line + 1
    where = f"{source}:{line}: keyframes[{index}]"
    if not isinstance(raw, dict):
        raise ScenarioError(f"{where}: a keyframe is a mapping with fields {', '.join(_REQUIRED_KEYFRAME_FIELDS)}")
    lines = _field_lines(node)
    for key in raw:
        if key not in _KEYFRAME_FIELDS:
            raise ScenarioError(
                f"{source}:{lines.get(key, line)}: keyframes[{index}]: unknown field '{key}' "
                f"(allowed: {', '.join(_KEYFRAME_FIELDS)})"
            )
    for key in _REQUIRED_KEYFRAME_FIELDS:
        if key not in raw:
            raise ScenarioError(f"{where}: missing field '{key}'")

    def field_where(key: str) -> str:
        return f"{source}:{lines.get(key, line)}: keyframes[{index}].{key}"

    def number(key: str) -> float:
        value = raw[key]
        if not _is_number(value):
            raise ScenarioError(f"{field_where(key)}: must be a number, got {value!r}")
        if not math.isfinite(value):
            raise ScenarioError(f"{field_where(key)}: must be finite, got {value}")
        return float(value)

    def triple(key: str, unit: str) -> Tuple[float, float, float]:
        value = raw[key]
        if not (isinstance(value, list) and len(value) == 3 and all(_is_number(item) for item in value)):
            raise ScenarioError(f"{field_where(key)}: must be a list of 3 numbers [{unit}], got {value!r}")
        if not all(math.isfinite(item) for item in value):
            raise ScenarioError(f"{field_where(key)}: must be finite, got {value}")
        return (float(value[0]), float(value[1]), float(value[2]))

    time = number("t")
    if time < 0.0:
        raise ScenarioError(f"{field_where('t')}: must be >= 0 s, got {time}")
    gripper = number("gripper")
    if gripper < 0.0:
        raise ScenarioError(f"{field_where('gripper')}: must be >= 0 rad (0 = closed), got {gripper}")
    click = raw.get("click", False)
    if not isinstance(click, bool):
        raise ScenarioError(f"{field_where('click')}: must be true or false, got {click!r}")
    wait = _parse_wait(raw, field_where) if "wait" in raw else None
    if wait is None and "timeout" in raw:
        raise ScenarioError(f"{field_where('timeout')}: only a keyframe that waits has a timeout (add 'wait')")
    return Keyframe(time, triple("position", "m"), triple("rpy", "rad"), gripper, click, line, wait)


def _parse_wait(raw: Dict[str, Any], field_where: Callable[[str], str]) -> Wait:
    conditions = raw["wait"]
    if not isinstance(conditions, dict) or not conditions:
        raise ScenarioError(
            f"{field_where('wait')}: must be a mapping of one or more of {', '.join(_WAIT_FIELDS)}, got {conditions!r}"
        )
    unknown = sorted(set(conditions) - set(_WAIT_FIELDS))
    if unknown:
        raise ScenarioError(
            f"{field_where('wait')}: unknown condition {unknown[0]!r} (allowed: {', '.join(_WAIT_FIELDS)})"
        )
    tab = conditions.get("tab")
    if tab is not None:
        if tab in TABS:
            tab = TABS.index(tab)
        elif not (isinstance(tab, int) and not isinstance(tab, bool) and 0 <= tab < len(TABS)):
            raise ScenarioError(
                f"{field_where('wait')}: tab must be one of {', '.join(TABS)} (or 0..{len(TABS) - 1}), got {tab!r}"
            )
    running = conditions.get("tree_running")
    if running is not None and not (isinstance(running, str) and running):
        raise ScenarioError(f"{field_where('wait')}: tree_running must name a tree node or a pattern, got {running!r}")
    for key in ("recording", "help_request"):
        if key in conditions and not isinstance(conditions[key], bool):
            raise ScenarioError(f"{field_where('wait')}: {key} must be true or false, got {conditions[key]!r}")
    study = conditions.get("study")
    if study is not None and study not in PHASE_NAMES:
        raise ScenarioError(f"{field_where('wait')}: study must be one of {', '.join(PHASE_NAMES)}, got {study!r}")
    timeout = raw.get("timeout", DEFAULT_WAIT_TIMEOUT)
    if not _is_number(timeout) or not math.isfinite(timeout) or timeout <= 0.0:
        raise ScenarioError(f"{field_where('timeout')}: must be a positive number of seconds, got {timeout!r}")
    return Wait(tab, running, conditions.get("recording"), conditions.get("help_request"), float(timeout), study)
