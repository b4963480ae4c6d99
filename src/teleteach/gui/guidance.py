"""The haptic guidance each GUI state asks of the device (teleteach.haptics.guidance renders it in the device loop).

The thesis' operator fights the device: selecting with X the hand drifts in Y (Fig. 5). So the GUI holds still what
the current step does not use and puts a detent at every position the step can stop at:

- START: detents at the left / right choices along X and at the "up" choice (SHARED CONTROL) along Y;
- HIGH-LEVEL step 1 (and the robot's proposal preselected): a detent at each button along X, Y and Z held; step 2: a
  detent at each operation of the page along Y, X held where the node was confirmed, roll free (it turns the page);
  step 3: a detent at each dial position in roll, X and Y held; Z is held in every step, so pushing it down or
  pulling it up (undo, redo) is a deliberate act against a spring;
- LOW-LEVEL modes X, Y, Z: everything held where it was when the mode began, except the selected axis' translation
  (free) and rotation (a detent where it began, ``guidance_mode_angle_*``: the thesis (IV) found length and
  rotation of an axis coupled, "changing the axis length unavoidably leads to slight changes in orientation"; a
  deliberate turn breaks out of the well); ALL: free;
- SHARED CONTROL: free (the shared controller takes the hand's motion as it comes).

Held centres are the device's pose when the state began (:class:`HeldPose`), so holding never moves what was set.
Every detent also holds the device at its centre while the gripper is closed for a click (``guidance_*click_*``): the
finger's push on the handle must not change the selection the click confirms.
"""

import dataclasses
from typing import Optional, Sequence, Tuple

import numpy as np

from teleteach.core.gui_config import GuiConfig
from teleteach.gui.device import DeviceSample
from teleteach.gui.selection import SelectionFlow, Step
from teleteach.haptics.guidance import AXES, AxisGuidance, Guidance

FREE = AxisGuidance()


def bin_centres(count: int, half_range: float) -> Tuple[float, ...]:
    """Where the slider positions of :func:`teleteach.gui.device.scale_to_index` are centred."""
    width = 2.0 * half_range / count
    return tuple(-half_range + (index + 0.5) * width for index in range(count))


class HeldPose:
    """The device pose when the current GUI state began: what held axes are held at."""

    def __init__(self) -> None:
        self._state: Optional[tuple] = None
        self._pose: Tuple[float, ...] = (0.0,) * len(AXES)

    def at(self, state: tuple, sample: Optional[DeviceSample]) -> Tuple[float, ...]:
        """The pose latched when ``state`` began (``sample`` latched now if the state just changed)."""
        if state != self._state and sample is not None:
            self._state, self._pose = state, sample.as_tuple()
        return self._pose


@dataclasses.dataclass(frozen=True)
class GuidanceDesigner:
    """Builds the guidance of a GUI state from ``config`` (``guidance_*`` in config/gui.yaml)."""

    config: GuiConfig

    def _detents(
        self, positions: Sequence[float], width: float, angular: bool = False, stiffness: Optional[float] = None
    ) -> AxisGuidance:
        config = self.config
        if stiffness is None:
            stiffness = config.guidance_angle_detent_stiffness if angular else config.guidance_detent_stiffness
        damping = config.guidance_angular_damping if angular else config.guidance_damping
        click = config.guidance_angle_click_stiffness if angular else config.guidance_click_stiffness
        return AxisGuidance(
            "detents",
            detents=tuple(positions),
            stiffness=stiffness,
            width=width,
            damping=damping,
            click_stiffness=click,
        )

    def _hold(self, centre: float, angular: bool = False) -> AxisGuidance:
        config = self.config
        stiffness = config.guidance_angle_hold_stiffness if angular else config.guidance_hold_stiffness
        damping = config.guidance_angular_damping if angular else config.guidance_damping
        return AxisGuidance("hold", centre=centre, stiffness=stiffness, damping=damping)

    def _guidance(self, **axes: AxisGuidance) -> Guidance:
        config = self.config
        if not config.guidance:
            return Guidance(max_force=config.guidance_max_force, max_torque=config.guidance_max_torque)
        return Guidance(
            axes=tuple(axes.get(name, FREE) for name in AXES),
            max_force=config.guidance_max_force,
            max_torque=config.guidance_max_torque,
        )

    def free(self) -> Guidance:
        """No force (SHARED CONTROL, LOW-LEVEL mode ALL, guidance switched off)."""
        return Guidance(max_force=self.config.guidance_max_force, max_torque=self.config.guidance_max_torque)

    def start(self) -> Guidance:
        """START: left (HIGH-LEVEL), the neutral centre, right (LOW-LEVEL), up (SHARED CONTROL), down (TELEOP)."""
        reach = self.config.device_range
        return self._guidance(
            x=self._detents((-0.5 * reach, 0.0, 0.5 * reach), 0.5 * reach),
            y=self._detents((-0.75 * reach, 0.0, 0.75 * reach), 0.5 * reach),
            z=self._hold(0.0),
        )

    def high_level(self, flow: SelectionFlow) -> Guidance:
        """HIGH-LEVEL: the current step's positions as detents, the rest held (see the module docstring)."""
        reach, turn = self.config.device_range, self.config.device_angle_range
        nodes = bin_centres(max(1, len(flow.choices)), reach)
        node_x = nodes[min(flow.node_index, len(nodes) - 1)]
        if flow.step in (Step.NODE, Step.PROPOSAL):  # a preselection is left by moving to another button
            return self._guidance(
                x=self._detents(nodes, 2.0 * reach / len(nodes)), y=self._hold(0.0), z=self._hold(0.0)
            )
        operations = bin_centres(len(flow.operations), reach)
        if flow.step is Step.OPERATION:
            return self._guidance(
                x=self._hold(node_x), y=self._detents(operations, 2.0 * reach / len(operations)), z=self._hold(0.0)
            )
        operation_y = operations[min(flow.operation_index, len(operations) - 1)]
        if flow.step in (Step.INDEX, Step.PARAMETER):
            count = flow.insert_slots if flow.step is Step.INDEX else len(flow.parameter_values)
            dial = self._detents(bin_centres(count, turn), 2.0 * turn / count, angular=True)
            return self._guidance(x=self._hold(node_x), y=self._hold(operation_y), z=self._hold(0.0), roll=dial)
        return self._guidance(x=self._hold(node_x), y=self._hold(operation_y), z=self._hold(0.0))

    def low_level(self, mode: str, held: Tuple[float, ...]) -> Guidance:
        """LOW-LEVEL: in X, Y or Z that axis' translation free, its rotation in a well, the rest held; ALL free."""
        if mode == "ALL":
            return self._guidance()
        axis = "XYZ".index(mode)
        axes = {name: self._hold(held[index], angular=index >= 3) for index, name in enumerate(AXES)}
        axes[AXES[axis]] = FREE
        angle = 3 + axis
        config = self.config
        well = self._detents(
            (held[angle],),
            config.guidance_mode_angle_width,
            angular=True,
            stiffness=config.guidance_mode_angle_stiffness,
        )
        axes[AXES[angle]] = well
        return self._guidance(**axes)


def guidance_fields(guidance: Guidance) -> dict:
    """The teleteach/HapticGuidance fields of a guidance (the worker fills the message with them)."""
    fields = {
        "modes": [axis.mode for axis in guidance.axes],
        "centres": [axis.centre for axis in guidance.axes],
        "stiffness": [axis.stiffness for axis in guidance.axes],
        "detent_widths": [axis.width for axis in guidance.axes],
        "damping": [axis.damping for axis in guidance.axes],
        "click_stiffness": [axis.click_stiffness for axis in guidance.axes],
        "gripper_click": guidance.gripper_detent is not None,
        "gripper_detent": guidance.gripper_detent or 0.0,
        "gripper_stiffness": guidance.gripper_stiffness,
        "gripper_width": guidance.gripper_width,
        "max_force": guidance.max_force,
        "max_torque": guidance.max_torque,
    }
    for name, axis in zip(AXES, guidance.axes):
        fields[f"detents_{name}"] = list(np.asarray(axis.detents, dtype=float))
    return fields
