"""What the simulated robot gets wrong (config/uncertainty.yaml): where MoveBase stops, and what perception reports.

robot_sim keeps the truth; :class:`BaseError` turns a MoveBase goal into where the base really stops, and
:class:`PerceptionNoise` turns the true scene into the one the skills see. Both draw from their own streams of one
seed, so a run is reproducible and switching one off leaves the other's draws unchanged.
"""

import dataclasses
import math
import pathlib
import zlib
from typing import Any, Dict, Mapping, Optional, Tuple

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from teleteach.core.frames import Transform
from teleteach.core.observed import ObservedBox, ObservedScene
from teleteach.core.paths import config_file
from teleteach.core.rotations import FIXED_AXES, yaw_quaternion, yaw_rotation
from teleteach.core.scene import Gap, Surface

DEFAULT_UNCERTAINTY_FILE = config_file("uncertainty.yaml")
MAX_POSITION = 0.5  # [m] a standard deviation or limit above this is a mistake, not an uncertainty
MAX_ANGLE = math.pi / 2.0  # [rad] the same for angles
MAX_DRAWS = 1000  # a truncated draw gives up (and takes the limit) after this many tries
BASE_STREAM, BIAS_STREAM, NOISE_STREAM = 0, 1, 2  # the separate streams of one seed


class UncertaintyError(ValueError):
    """The uncertainty settings lack a value or hold a wrong one; the message names the field."""


def _number(values: Mapping[str, Any], key: str, where: str, limit: float) -> float:
    try:
        value = float(values[key])
    except KeyError:
        raise UncertaintyError(f"uncertainty {where}: missing {key}") from None
    except (TypeError, ValueError):
        raise UncertaintyError(f"uncertainty {where}.{key}: not a number ({values[key]!r})") from None
    if not math.isfinite(value) or value < 0.0 or value > limit:
        raise UncertaintyError(f"uncertainty {where}.{key}: {value} must be finite, >= 0 and <= {limit:g}")
    return value


def _triple(values: Mapping[str, Any], key: str, where: str, limit: float) -> np.ndarray:
    raw = values.get(key)
    if not isinstance(raw, (list, tuple)) or len(raw) != 3:
        raise UncertaintyError(f"uncertainty {where}.{key}: expected [x, y, z], got {raw!r}")
    return np.array([_number({key: value}, key, where, limit) for value in raw])


def _enabled(values: Mapping[str, Any], where: str) -> bool:
    enabled = values.get("enabled")
    if not isinstance(enabled, bool):
        raise UncertaintyError(f"uncertainty {where}.enabled: expected true or false, got {enabled!r}")
    return enabled


@dataclasses.dataclass(frozen=True)
class BaseErrorSettings:
    """Normal stop error of MoveBase, truncated: std along x and y [m], of yaw [rad], and the limits."""

    enabled: bool
    position_std: float
    yaw_std: float
    max_position: float
    max_yaw: float

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> "BaseErrorSettings":
        """Validated settings of the ``base_error`` section."""
        where = "base_error"
        return cls(
            enabled=_enabled(values, where),
            position_std=_number(values, "position_std", where, MAX_POSITION),
            yaw_std=_number(values, "yaw_std", where, MAX_ANGLE),
            max_position=_number(values, "max_position", where, MAX_POSITION),
            max_yaw=_number(values, "max_yaw", where, MAX_ANGLE),
        )


@dataclasses.dataclass(frozen=True)
class ObjectNoise:
    """Perception error of one class of object, in its own frame: bias per viewpoint and noise per message."""

    position_bias_std: np.ndarray
    yaw_bias_std: float
    position_noise_std: float
    yaw_noise_std: float

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], where: str) -> "ObjectNoise":
        """Validated settings of ``perception.products`` or ``perception.gaps``."""
        return cls(
            position_bias_std=_triple(values, "position_bias_std", where, MAX_POSITION),
            yaw_bias_std=_number(values, "yaw_bias_std", where, MAX_ANGLE),
            position_noise_std=_number(values, "position_noise_std", where, MAX_POSITION),
            yaw_noise_std=_number(values, "yaw_noise_std", where, MAX_ANGLE),
        )


@dataclasses.dataclass(frozen=True)
class SurfaceNoise:
    """Perception error of a surface to wipe, in its own frame (u, v along it, n its normal): bias and noise.

    Attributes:
        position_bias_std: (u, v, n) [m]; n is the error of the surface's distance.
        tilt_bias_std: about u and about v, each [rad].
        yaw_bias_std: about n [rad].
        position_noise_std: each axis, each look [m].
        tilt_noise_std: each of the three angles, each look [rad].
    """

    position_bias_std: np.ndarray
    tilt_bias_std: float
    yaw_bias_std: float
    position_noise_std: float
    tilt_noise_std: float

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], where: str) -> "SurfaceNoise":
        """Validated settings of ``perception.surfaces``."""
        return cls(
            position_bias_std=_triple(values, "position_bias_std", where, MAX_POSITION),
            tilt_bias_std=_number(values, "tilt_bias_std", where, MAX_ANGLE),
            yaw_bias_std=_number(values, "yaw_bias_std", where, MAX_ANGLE),
            position_noise_std=_number(values, "position_noise_std", where, MAX_POSITION),
            tilt_noise_std=_number(values, "tilt_noise_std", where, MAX_ANGLE),
        )

    def draw(self, rng: np.random.Generator, bias: bool) -> Transform:
        """One error (the bias, or one look's noise) as the perceived frame in the true one."""
        if bias:
            position = rng.normal(0.0, 1.0, 3) * self.position_bias_std
            angles = rng.normal(0.0, 1.0, 3) * np.array([self.tilt_bias_std, self.tilt_bias_std, self.yaw_bias_std])
        else:
            position = rng.normal(0.0, self.position_noise_std, 3)
            angles = rng.normal(0.0, self.tilt_noise_std, 3)
        return Transform(position, Rotation.from_rotvec(angles))


@dataclasses.dataclass(frozen=True)
class PerceptionSettings:
    """Whether perception errs, and how, for products, gaps and surfaces to wipe."""

    enabled: bool
    products: ObjectNoise
    gaps: ObjectNoise
    surfaces: SurfaceNoise

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> "PerceptionSettings":
        """Validated settings of the ``perception`` section."""
        for section in ("products", "gaps", "surfaces"):
            if not isinstance(values.get(section), Mapping):
                raise UncertaintyError(f"uncertainty perception: missing section {section}")
        return cls(
            enabled=_enabled(values, "perception"),
            products=ObjectNoise.from_mapping(values["products"], "perception.products"),
            gaps=ObjectNoise.from_mapping(values["gaps"], "perception.gaps"),
            surfaces=SurfaceNoise.from_mapping(values["surfaces"], "perception.surfaces"),
        )


@dataclasses.dataclass(frozen=True)
class UncertaintySettings:
    """The whole file: the seed, the base's error and perception's."""

    seed: int
    base_error: BaseErrorSettings
    perception: PerceptionSettings

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> "UncertaintySettings":
        """Validated settings; UncertaintyError names the first wrong field."""
        if not isinstance(values, Mapping):
            raise UncertaintyError(f"uncertainty settings must be a mapping, got {values!r}")
        seed = values.get("seed")
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise UncertaintyError(f"uncertainty seed: expected an integer >= 0, got {seed!r}")
        for section in ("base_error", "perception"):
            if not isinstance(values.get(section), Mapping):
                raise UncertaintyError(f"uncertainty: missing section {section}")
        return cls(
            seed=seed,
            base_error=BaseErrorSettings.from_mapping(values["base_error"]),
            perception=PerceptionSettings.from_mapping(values["perception"]),
        )

    def with_overrides(
        self, seed: Optional[int] = None, base_error: Optional[bool] = None, perception_noise: Optional[bool] = None
    ) -> "UncertaintySettings":
        """The settings with the seed and the two switches replaced where given (launch arguments)."""
        settings = self
        if seed is not None:
            if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
                raise UncertaintyError(f"uncertainty seed: expected an integer >= 0, got {seed!r}")
            settings = dataclasses.replace(settings, seed=seed)
        if base_error is not None:
            settings = dataclasses.replace(
                settings, base_error=dataclasses.replace(settings.base_error, enabled=bool(base_error))
            )
        if perception_noise is not None:
            settings = dataclasses.replace(
                settings, perception=dataclasses.replace(settings.perception, enabled=bool(perception_noise))
            )
        return settings

    @classmethod
    def none(cls) -> "UncertaintySettings":
        """A world that forgives everything: MoveBase exact, perception perfect."""
        exact = ObjectNoise(np.zeros(3), 0.0, 0.0, 0.0)
        flat = SurfaceNoise(np.zeros(3), 0.0, 0.0, 0.0, 0.0)
        return cls(0, BaseErrorSettings(False, 0.0, 0.0, 0.0, 0.0), PerceptionSettings(False, exact, exact, flat))


def load_uncertainty(path: Optional[str] = None) -> UncertaintySettings:
    """Read config/uncertainty.yaml (or ``path``); UncertaintyError names the file and the wrong field."""
    path = pathlib.Path(path) if path else DEFAULT_UNCERTAINTY_FILE
    try:
        values = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as error:
        raise UncertaintyError(f"{path}: {error}") from None
    try:
        return UncertaintySettings.from_mapping(values)
    except UncertaintyError as error:
        raise UncertaintyError(f"{path}: {error}") from None


def base_stream(seed: int) -> np.random.Generator:
    """The base error's generator of a seed (perception draws from others: switching one off leaves the other)."""
    return np.random.default_rng([seed, BASE_STREAM])


class BaseError:
    """Where MoveBase really stops: each goal plus an error drawn once, normal and truncated to the limits.

    Args:
        settings: the ``base_error`` settings.
        rng: the generator to draw from.
    """

    def __init__(self, settings: BaseErrorSettings, rng: np.random.Generator):
        self.settings = settings
        self.rng = rng
        self.last = np.zeros(3)

    def draw(self) -> np.ndarray:
        """The next error: (x [m], y [m], yaw [rad]) in world, zero when disabled."""
        settings = self.settings
        if not settings.enabled:
            self.last = np.zeros(3)
            return self.last.copy()
        position, yaw = None, None
        for _ in range(MAX_DRAWS):
            candidate = self.rng.normal(0.0, settings.position_std, 2)
            if np.linalg.norm(candidate) <= settings.max_position:
                position = candidate
                break
        for _ in range(MAX_DRAWS):
            candidate = float(self.rng.normal(0.0, settings.yaw_std))
            if abs(candidate) <= settings.max_yaw:
                yaw = candidate
                break
        position = np.zeros(2) if position is None else position
        yaw = 0.0 if yaw is None else yaw
        self.last = np.array([position[0], position[1], yaw])
        return self.last.copy()

    def stop_pose(self, goal) -> np.ndarray:
        """Where the base stops when sent to goal (x [m], y [m], yaw [rad] in world)."""
        return np.asarray(goal, dtype=float) + self.draw()


@dataclasses.dataclass(frozen=True)
class PoseError:
    """An error of a perceived pose, in the object's frame: position (x, y, z) [m] and yaw [rad]."""

    position: np.ndarray
    yaw: float

    def apply(self, position, quaternion) -> Tuple[np.ndarray, np.ndarray]:
        """The pose (centre [m], (x, y, z, w) quaternion in world) with this error in its own frame."""
        rotation = Rotation.from_quat(quaternion)
        moved = np.asarray(position, dtype=float) + rotation.apply(self.position)
        return moved, (rotation * yaw_rotation(self.yaw)).as_quat()


class PerceptionNoise:
    """The scene as an imperfect perception reports it: a bias per object and viewpoint, noise per message.

    An object's bias at the n-th viewpoint is drawn from a generator of (seed, n, the object), so it is the same in
    every run with this seed, however many messages were published before; the per-message noise comes from one stream.

    Args:
        settings: the ``perception`` settings.
        seed: the seed of every draw.
    """

    def __init__(self, settings: PerceptionSettings, seed: int):
        self.settings = settings
        self.seed = seed
        self.viewpoint = 0
        self.rng = np.random.default_rng([seed, NOISE_STREAM])
        self._biases: Dict[Tuple[str, str], PoseError] = {}
        self._surface_biases: Dict[str, Transform] = {}

    def new_viewpoint(self) -> None:
        """The robot stopped somewhere new: every object's bias is drawn again when next seen."""
        self.viewpoint += 1
        self._biases.clear()
        self._surface_biases.clear()

    def bias(self, kind: str, name: str) -> PoseError:
        """The bias of object name of kind products | gaps at this viewpoint."""
        key = (kind, name)
        if key not in self._biases:
            noise = getattr(self.settings, kind)
            rng = np.random.default_rng([self.seed, BIAS_STREAM, self.viewpoint, zlib.crc32(f"{kind}/{name}".encode())])
            self._biases[key] = PoseError(
                rng.normal(0.0, 1.0, 3) * noise.position_bias_std, float(rng.normal(0.0, noise.yaw_bias_std))
            )
        return self._biases[key]

    def _error(self, kind: str, name: str) -> PoseError:
        noise = getattr(self.settings, kind)
        bias = self.bias(kind, name)
        return PoseError(
            bias.position + self.rng.normal(0.0, noise.position_noise_std, 3),
            bias.yaw + float(self.rng.normal(0.0, noise.yaw_noise_std)),
        )

    def surface_bias(self, name: str) -> Transform:
        """The bias of surface name at this viewpoint: the perceived surface frame in the true one."""
        if name not in self._surface_biases:
            rng = np.random.default_rng(
                [self.seed, BIAS_STREAM, self.viewpoint, zlib.crc32(f"surfaces/{name}".encode())]
            )
            self._surface_biases[name] = self.settings.surfaces.draw(rng, bias=True)
        return self._surface_biases[name]

    def _seen_surface_frame(self, name: str, frame: Transform) -> Transform:
        """A surface's true frame as perception reports it now: moved and turned by bias and noise in its own frame."""
        return frame * self.surface_bias(name) * self.settings.surfaces.draw(self.rng, bias=False)

    def perceive_surface(self, truth: Surface) -> Surface:
        """The surface as perception reports it now (the truth itself when disabled)."""
        if not self.settings.enabled:
            return truth
        seen = self._seen_surface_frame(truth.name, truth.frame)
        return dataclasses.replace(
            truth, center=tuple(seen.position.tolist()), rpy=tuple(seen.rotation.as_euler(FIXED_AXES).tolist())
        )

    def perceive(self, truth: ObservedScene) -> ObservedScene:
        """The true scene as perception reports it now (the truth itself when disabled)."""
        if not self.settings.enabled:
            return truth
        products = {}
        for name, box in truth.products.items():
            position, quaternion = self._error("products", name).apply(box.position, box.quaternion)
            products[name] = ObservedBox(name, position, quaternion, box.size)
        gaps = {}
        for name, gap in truth.gaps.items():
            error = self._error("gaps", name)
            position, _ = error.apply(gap.position, yaw_quaternion(gap.yaw))
            gaps[name] = Gap(name, tuple(position.tolist()), gap.yaw + error.yaw, gap.width, gap.tolerance)
        surfaces = {}
        for name, box in truth.surfaces.items():
            seen = self._seen_surface_frame(name, Transform(box.position, Rotation.from_quat(box.quaternion)))
            surfaces[name] = ObservedBox(name, seen.position, seen.rotation.as_quat(), box.size)
        return ObservedScene(products, gaps, dict(truth.tables), truth.stamp, surfaces)
