"""shared_control's parameters (config/shared_control.yaml): the MPC's, and the node's own around it.

The MPC's keys make a :class:`teleteach.shared_control.loop.SharedControlConfig`; the node's (its input, the task
plane and boundary, the timeouts, the approach on enable) are read with them, in one place, by
:meth:`SharedControlNodeConfig.from_parameters`, from the yaml alone or the parameter server.
"""

import dataclasses
from typing import Any, Mapping, Optional, Sequence, Tuple

import numpy as np

from teleteach.core.parameters import from_mapping
from teleteach.shared_control.constraints import Box
from teleteach.shared_control.loop import SharedControlConfig
from teleteach.shared_control.plane import TaskPlane

INPUTS = ("operator_command", "twist", "joy")


@dataclasses.dataclass(frozen=True)
class SharedControlNodeConfig:
    """shared_control's parameters: config/shared_control.yaml's keys (the one place of values and meanings).

    The MPC's keys make ``mpc`` (``rate`` its cycle period); the others are the node's own.

    Attributes:
        mpc: MPC parameters (``solver="compiled"`` compiles the solvers before the node starts if scripts/setup has
            not cached them).
        input: one of ``INPUTS``.
        initial_state: start in the task plane [m].
        boundary: x_min, y_min, x_max, y_max in the task plane [m]; empty: no boundary.
        plane: task plane in base_link.
        frame_id: frame of /equilibrium_pose.
        surface: a surface of the scene file to wipe, located on each enable ("": the plane as given).
        command_timeout: a command older than this counts as zero [s].
        command_delay: each cycle reads the operator's commands this much before its own time, placed by their
            header stamps (messages up to this late, bunched or out of order give the same window) [s].
        obstacle_timeout: the obstacle is dropped when not refreshed for this long [s] (0: never).
        enabled: drive the arm from the start; False waits for /shared_control/enable (the GUI's SHARED CONTROL tab).
        approach_speed: when enabled, the reference goes from the arm's pose to the task plane at most this fast
            [m/s] (then the MPC starts there, inside the boundary); commands wait until it has arrived.
        approach_turn_rate: ... and turns at most this fast [rad/s].
        state_from_arm: each cycle starts the MPC from the arm's measured pose projected on the plane (the paper's
            x is the robot's) when /cartesian_pose is fresher than command_timeout; False integrates its own state.
        twist_projection: 2 x 3 matrix from device linear velocity to the task plane (``twist``).
        twist_scale: task-plane speed per device speed [-] (``twist``).
        twist_deadband: projected device speeds below this are zero [m/s] (``twist``).
        joy_axes: indices of the joystick axes for x and y (``joy``).
        joy_scale: task-plane speed at full deflection per axis [m/s] (``joy``).
    """

    mpc: SharedControlConfig
    input: str
    initial_state: Tuple[float, float]
    boundary: Tuple[float, ...]
    plane: TaskPlane
    frame_id: str
    surface: str
    command_timeout: float
    command_delay: float
    obstacle_timeout: float
    enabled: bool
    approach_speed: float
    approach_turn_rate: float
    state_from_arm: bool
    twist_projection: Tuple[Sequence[float], ...]
    twist_scale: float
    twist_deadband: float
    joy_axes: Tuple[int, int]
    joy_scale: Tuple[float, float]

    def __post_init__(self):
        if self.input not in INPUTS:
            raise ValueError(f"input must be one of {INPUTS}, got {self.input!r}")
        projection = np.asarray(self.twist_projection, dtype=float)
        if projection.shape != (2, 3) or not np.all(np.isfinite(projection)):
            raise ValueError(f"twist_projection must be a finite 2 x 3 matrix, got {list(self.twist_projection)}")
        if self.mpc.dt <= 0 or self.command_timeout <= 0 or not 0 <= self.command_delay < self.command_timeout:
            raise ValueError("dt and command_timeout must be > 0, command_delay in [0, command_timeout)")
        self.box  # noqa: B018 - a bad boundary is refused here, with its reason

    @property
    def box(self) -> Optional[Box]:
        """The boundary in the task plane, or None."""
        return Box(*(float(value) for value in self.boundary)) if self.boundary else None

    @classmethod
    def from_parameters(cls, parameters: Mapping[str, Any]) -> "SharedControlNodeConfig":
        """From the yaml's keys, each perhaps overridden; a missing or unknown key is named."""
        mpc = SharedControlConfig.from_parameters(parameters)
        read_by_mpc = {field.name for field in dataclasses.fields(SharedControlConfig)} | {"rate"}
        values = {name: value for name, value in parameters.items() if name not in read_by_mpc}
        return from_mapping(cls, {**values, "mpc": mpc}, "shared_control's parameters (config/shared_control.yaml)")
