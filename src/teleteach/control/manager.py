"""Controller manager with ros_control semantics: named controllers, one running at a time, STRICT / BEST_EFFORT.

STRICT fails (and changes nothing) when any named controller is unknown or in the wrong state; BEST_EFFORT skips
those and does the rest. Starting a controller whose joints another running controller claims is a resource
conflict and fails in both modes, as in ros_control. A started controller holds the current state (bumpless).
"""

from dataclasses import dataclass
from typing import Dict, List, Sequence, Tuple

BEST_EFFORT = 1
STRICT = 2
RUNNING = "running"
STOPPED = "stopped"


@dataclass(frozen=True)
class ControllerInfo:
    """What list_controllers reports about one controller."""

    name: str
    state: str
    type: str
    hardware_interface: str
    resources: Tuple[str, ...]


class ControllerManager:
    """Owns the controllers and decides which one commands the joints.

    Args:
        controllers: name -> controller (with type, hardware_interface, starting(state), update(state)).
        resources: the joints every controller claims.
    """

    def __init__(self, controllers: Dict[str, object], resources: Sequence[str]):
        self._controllers = dict(controllers)
        self._resources = tuple(resources)
        self._running = []

    @property
    def running(self):
        """Name of the running controller, or None."""
        return self._running[0] if self._running else None

    def controller(self, name):
        """The controller object called name (KeyError if unknown)."""
        return self._controllers[name]

    def list_controllers(self) -> List[ControllerInfo]:
        """Every controller with its state, type and claimed resources."""
        return [
            ControllerInfo(
                name,
                RUNNING if name in self._running else STOPPED,
                controller.type,
                controller.hardware_interface,
                self._resources,
            )
            for name, controller in self._controllers.items()
        ]

    def switch(self, start: Sequence[str], stop: Sequence[str], strictness: int, state) -> Tuple[bool, str]:
        """Stop then start controllers; returns (ok, message). On failure nothing changes.

        Args:
            start: controllers to start.
            stop: controllers to stop.
            strictness: STRICT or BEST_EFFORT (0 is taken as BEST_EFFORT, as ros_control does).
            state: the robot state the started controller holds (RobotState).
        """
        if strictness not in (0, BEST_EFFORT, STRICT):
            return False, f"unknown strictness {strictness}"
        strict = strictness == STRICT
        problems = []
        to_stop, to_start = [], []
        for name in stop:
            if name not in self._controllers:
                problems.append(f"cannot stop '{name}': no such controller")
            elif name not in self._running:
                problems.append(f"cannot stop '{name}': it is not running")
            elif name not in to_stop:
                to_stop.append(name)
        for name in start:
            if name not in self._controllers:
                problems.append(f"cannot start '{name}': no such controller")
            elif name in self._running and name not in to_stop:
                problems.append(f"cannot start '{name}': it is already running")
            elif name not in to_start:
                to_start.append(name)
        if problems and strict:
            return False, "; ".join(problems)
        remaining = [name for name in self._running if name not in to_stop]
        if len(remaining) + len(to_start) > 1:
            return False, f"resource conflict: {remaining + to_start} would all claim {list(self._resources)}"
        for name in to_start:
            self._controllers[name].starting(state)
        self._running = remaining + to_start
        message = "; ".join(problems) if problems else "ok"
        return True, message

    def update(self, state):
        """The running controller's command for this tick, or None when no controller holds the arm."""
        if not self._running:
            return None
        return self._controllers[self._running[0]].update(state)
