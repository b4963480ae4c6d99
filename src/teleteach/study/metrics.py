"""What a trial measures, from what the operator and the robot did while it ran.

- selections: every choice confirmed with a click (``teleteach/selection``); a *wrong selection* is one that differs
  from the task's ``intended`` choice for that step (the mode on START, the node, the operation, the index);
- undo count: undo gestures (a click with the handle pushed down in HIGH-LEVEL);
- help requests: the robot's requests for help (``/behaviour_tree/help_request`` naming a node);
- contact: the largest external force and torque at the end effector (``/force_torque_ext``) and the number of
  contacts (the force rising above a threshold, counted again only after it fell below half of it);
- the stiffness profile: every commanded principal stiffness (``/eigenvalues``) with its time.
"""

import dataclasses
import io
import math
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

INTENDED_STEP = {("START", "mode"): "mode", ("HIGH_LEVEL", "node"): "node"}
INTENDED_STEP.update({("HIGH_LEVEL", "operation"): "operation", ("HIGH_LEVEL", "index"): "index"})


@dataclasses.dataclass(frozen=True)
class Selection:
    """A confirmed choice: [s] since the trial started, the tab, the step and what was chosen."""

    time: float
    tab: str
    step: str
    choice: str


class TrialMetrics:
    """Accumulates one trial's measurements (times in seconds since the trial started)."""

    def __init__(self, intended: Mapping[str, str], contact_threshold: float):
        self.intended = dict(intended)
        self.contact_threshold = contact_threshold
        self.selections: List[Selection] = []
        self.help_requests: List[Tuple[float, str, str]] = []
        self._open_request: Optional[Tuple[str, str]] = None
        self.peak_force = 0.0
        self.peak_torque = 0.0
        self.contacts = 0
        self._in_contact = False
        self.stiffness: List[Tuple[float, float, float, float]] = []

    def selection(self, time: float, tab: str, step: str, choice: str) -> None:
        """A confirmed choice."""
        self.selections.append(Selection(time, tab, step, choice))

    def help_request(self, time: float, node: str, reason: str) -> None:
        """The robot's help request about ``node``; counted once while it stays open (an empty name closes it)."""
        if node and (node, reason) != self._open_request:
            self.help_requests.append((time, node, reason))
        self._open_request = (node, reason) if node else None

    def wrench(self, force: Sequence[float], torque: Sequence[float]) -> None:
        """An external wrench [N, Nm]; NaN is ignored."""
        force_norm, torque_norm = float(np.linalg.norm(force)), float(np.linalg.norm(torque))
        if not (math.isfinite(force_norm) and math.isfinite(torque_norm)):
            return
        self.peak_force = max(self.peak_force, force_norm)
        self.peak_torque = max(self.peak_torque, torque_norm)
        if not self._in_contact and force_norm > self.contact_threshold:
            self._in_contact = True
            self.contacts += 1
        elif self._in_contact and force_norm < 0.5 * self.contact_threshold:
            self._in_contact = False

    def eigenvalues(self, time: float, values: Sequence[float]) -> None:
        """A commanded principal stiffness [N/m]."""
        if len(values) == 3 and all(math.isfinite(value) for value in values):
            self.stiffness.append((time, float(values[0]), float(values[1]), float(values[2])))

    def wrong(self, selection: Selection) -> bool:
        """Whether a confirmed choice differs from the task's intended one for its step."""
        step = INTENDED_STEP.get((selection.tab, selection.step))
        return step is not None and step in self.intended and selection.choice != self.intended[step]

    @property
    def wrong_selections(self) -> int:
        """Confirmed choices that differ from the intended ones."""
        return sum(1 for selection in self.selections if self.wrong(selection))

    @property
    def undo_count(self) -> int:
        """Undo gestures."""
        return sum(1 for selection in self.selections if selection.step == "undo")

    def stiffness_csv(self) -> str:
        """The stiffness profile: time [s since the trial started], kx, ky, kz [N/m]."""
        stream = io.StringIO()
        stream.write("time_s,kx_n_per_m,ky_n_per_m,kz_n_per_m\n")
        for row in self.stiffness:
            stream.write(",".join(f"{value:.4f}" if index == 0 else f"{value:.1f}" for index, value in enumerate(row)))
            stream.write("\n")
        return stream.getvalue()

    def summary(self) -> Dict[str, object]:
        """The trial's numbers for result.json."""
        final: Optional[List[float]] = list(self.stiffness[-1][1:]) if self.stiffness else None
        return {
            "selections": [dataclasses.asdict(selection) for selection in self.selections],
            "wrong_selections": self.wrong_selections,
            "undo_count": self.undo_count,
            "help_requests": len(self.help_requests),
            "help_request_nodes": [node for _, node, _ in self.help_requests],
            "peak_force_n": round(self.peak_force, 3),
            "peak_torque_nm": round(self.peak_torque, 4),
            "contacts": self.contacts,
            "stiffness_samples": len(self.stiffness),
            "stiffness_final_n_per_m": final,
        }
