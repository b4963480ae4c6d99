"""A model of the operator's hand on the device, so that guidance can be felt by a scripted or virtual operator.

Without hardware, the scenario, virtual and topic backends give the pose the operator *intends*. With the hand model the
device's pose results from a hand spring-damper pulling the device's mass toward that intention, together with the
guidance's force (what the device renders), plus an optional seeded tremor of the hand: physiological (8-12 Hz)
and a slow drift (0.1-0.5 Hz), each a sum of sinusoids with the configured RMS per translation axis. Per axis::

    m q'' = k (target - q) - b q' + F_guidance        (target = intention + tremor + drift)

integrated with semi-implicit Euler in steps of at most 1 ms (across a stalled loop's gap too, with the last force and
the intention, the tremor at each step's time: a slow loop does not hold the tremor and shake the device harder);
angles (roll, pitch, yaw) likewise with an inertia, an angular spring and damping and the guidance's torque.
:class:`HandModelBackend` puts the model between any backend and the loop.
"""

import dataclasses
import math
from typing import Optional, Sequence, Tuple

import numpy as np

from teleteach.core.rotations import quaternion_to_rpy, rpy_to_quaternion
from teleteach.haptics.device import DeviceBackend, DeviceSample
from teleteach.haptics.guidance import Wrench

TREMOR_BAND = (8.0, 12.0)  # [Hz] physiological tremor
DRIFT_BAND = (0.1, 0.5)  # [Hz] slow drift of a hand that means to hold still
SINUSOIDS = 5  # per axis and band
MAX_STEP = 0.001  # [s] integration step
# [s] a gap between two reads (the loop stalled on a busy machine) is integrated with the last force, as a real device
# keeps the force last commanded; only a longer one (a paused process) restarts the model at the intention. Restarting
# after 50 ms stalls teleported the guided device to the intention, and the guidance snapped it back.
MAX_GAP = 0.5


@dataclasses.dataclass(frozen=True)
class HandParameters:
    """The hand's grip and the device's moving mass (``config/device.yaml`` ``hand``); tremor as RMS per axis."""

    stiffness: float  # [N/m]
    damping: float  # [N s/m]
    mass: float  # [kg]
    angular_stiffness: float  # [Nm/rad]
    angular_damping: float  # [Nm s/rad]
    inertia: float  # [kg m^2]
    tremor_rms: float  # [m]
    drift_rms: float  # [m]
    seed: int

    def __post_init__(self):
        for field in ("stiffness", "damping", "mass", "angular_stiffness", "angular_damping", "inertia"):
            value = getattr(self, field)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"hand {field} must be a positive number, got {value}")
        for field in ("tremor_rms", "drift_rms"):
            value = getattr(self, field)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"hand {field} must be a number >= 0 [m], got {value}")

    @classmethod
    def from_yaml(cls, **changes) -> "HandParameters":
        """config/device.yaml's ``hand`` section, the one place of its values, with ``changes``."""
        from teleteach.core.paths import config_values

        values = config_values("device.yaml", "hand")
        del values["enabled"]  # whether the node models a hand, not the hand
        return cls(**{**values, **changes})


class Tremor:
    """The hand's involuntary motion [m] per translation axis at a time: seeded sums of sinusoids."""

    def __init__(self, parameters: HandParameters) -> None:
        rng = np.random.default_rng(parameters.seed)
        self._waves = []
        for rms, band in ((parameters.tremor_rms, TREMOR_BAND), (parameters.drift_rms, DRIFT_BAND)):
            if rms > 0.0:
                amplitude = rms / math.sqrt(SINUSOIDS / 2.0)  # the RMS of a sum of equal sinusoids
                frequencies = rng.uniform(*band, size=(3, SINUSOIDS))
                phases = rng.uniform(0.0, 2.0 * math.pi, size=(3, SINUSOIDS))
                self._waves.append((amplitude, 2.0 * math.pi * frequencies, phases))

    def at(self, time: float) -> np.ndarray:
        """The offset [m] of the hand at ``time`` [s]."""
        offset = np.zeros(3)
        for amplitude, omegas, phases in self._waves:
            offset += amplitude * np.sin(omegas * time + phases).sum(axis=1)
        return offset


class HandModel:
    """The device pose a hand holding it produces (see the module docstring)."""

    def __init__(self, parameters: HandParameters) -> None:
        self.parameters = parameters
        self.tremor = Tremor(parameters)
        self._time: Optional[float] = None
        self._pose = np.zeros(6)  # x, y, z [m], roll, pitch, yaw [rad]
        self._velocity = np.zeros(6)
        p = parameters
        self._stiffness = np.array([p.stiffness] * 3 + [p.angular_stiffness] * 3)
        self._damping = np.array([p.damping] * 3 + [p.angular_damping] * 3)
        self._mass = np.array([p.mass] * 3 + [p.inertia] * 3)

    def step(self, time: float, intended: np.ndarray, wrench: Wrench) -> np.ndarray:
        """Advance to ``time`` [s] toward the ``intended`` pose (x, y, z, roll, pitch, yaw) under ``wrench``."""
        intention = np.asarray(intended, dtype=float)
        target = intention.copy()
        if self._time is None or not 0.0 <= time - self._time <= MAX_GAP:
            target[:3] += self.tremor.at(time)
            self._time, self._pose, self._velocity = time, target, np.zeros(6)
            return self._pose.copy()
        load = np.concatenate([wrench.force, wrench.torque])
        steps = max(1, math.ceil(round((time - self._time) / MAX_STEP, 6)))  # 0.05 / 0.001 is 50.000000000000007
        dt = (time - self._time) / steps
        for step in range(1, steps + 1):
            target[:3] = intention[:3] + self.tremor.at(self._time + step * dt)
            acceleration = (
                self._stiffness * (target - self._pose) - self._damping * self._velocity + load
            ) / self._mass
            self._velocity += acceleration * dt
            self._pose += self._velocity * dt
        self._time = time
        return self._pose.copy()


class HandModelBackend(DeviceBackend):
    """Any backend's samples taken as the operator's intention, the device's pose from :class:`HandModel`.

    The wrench the loop renders acts on the model (the inner backend has no force feedback); the gripper and a
    native button pass through unchanged.
    """

    def __init__(self, inner: DeviceBackend, parameters: HandParameters) -> None:
        self.inner = inner
        self.hand = HandModel(parameters)
        self._wrench = Wrench.zero()

    def read(self, time: float) -> DeviceSample:
        """The inner sample, moved to where the hand puts the device."""
        intended = self.inner.read(time)
        pose = self.hand.step(
            time, np.concatenate([intended.position, quaternion_to_rpy(intended.orientation)]), self._wrench
        )
        return dataclasses.replace(intended, position=pose[:3], orientation=np.asarray(rpy_to_quaternion(*pose[3:])))

    def missed_gripper(self) -> Sequence[Tuple[float, float]]:
        """The inner backend's: the hand moves the device, not the gripper."""
        return self.inner.missed_gripper()

    def render(self, wrench: Wrench) -> None:
        """The guidance force acts on the modelled device."""
        self._wrench = wrench

    @property
    def finished(self) -> bool:
        """The inner backend's."""
        return self.inner.finished

    @property
    def failure(self) -> str:
        """The inner backend's failure, if it has one (a scenario's wait that timed out)."""
        return getattr(self.inner, "failure", "")

    def close(self) -> None:
        """Closes the inner backend."""
        self.inner.close()
