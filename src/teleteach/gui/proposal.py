"""The robot's part in a help request as the GUI shows it (issue 52: shared high-level decisions); no Qt here.

The tree policy's confidence decides who acts (teleteach.bt.decisions); the GUI makes either case one gesture:

- unsure, the robot asks with its proposal: HIGH-LEVEL preselects it (:class:`Offer`), so one click confirms it.
  The click sends /change_tree ``repair`` when that applies the proposal (nothing is remembered of the failure, or the
  remembered repair is the proposal), else the proposal's one edit itself. A proposal of several edits beside another
  remembered repair cannot be one request: it is only told, the operator builds it or takes the remembered one.
- confident, the robot applied its proposal alone: the banner says so and counts the veto window down; the undo
  gesture (a click with the handle pushed down) vetoes it within the window, as it undoes any edit. The robot then
  asks, its proposal told but not preselected: the operator has just said no to it.
"""

import math
from typing import NamedTuple, Optional, Tuple

from teleteach.bt.decisions import VETOED
from teleteach.bt.editor import EditRequest

REPAIR_CHOICE = "Repair as last time"  # HIGH-LEVEL's first button while a remembered repair is suggested


class Offer(NamedTuple):
    """A proposal HIGH-LEVEL preselects: the edit it shows (node, operation), the request a click sends, in words."""

    shown: EditRequest
    request: EditRequest
    text: str  # e.g. "remove PickItem, 62 % sure"


def percent(confidence: float) -> str:
    """A confidence as the operator reads it: "62 %"."""
    return f"{round(100.0 * confidence)} %"


class HelpRequestView(NamedTuple):
    """The fields of teleteach/HelpRequest the GUI uses; ``veto_left`` [s] is what was left of the window on arrival."""

    node_name: str
    reason: str = ""
    suggestion: Tuple[str, ...] = ()
    proposal: Tuple[str, ...] = ()
    confidence: float = 0.0
    why: str = ""
    applied: bool = False
    veto_left: float = 0.0

    @property
    def proposal_text(self) -> str:
        """The proposal and the robot's confidence in one phrase."""
        return f"{'; '.join(self.proposal)}, {percent(self.confidence)} sure"

    def offer(self) -> Optional[Offer]:
        """What HIGH-LEVEL preselects for one click, or None (nothing asked or proposed, applied, or just vetoed)."""
        if not self.node_name or not self.proposal or self.applied or self.why.startswith(VETOED):
            return None
        edits = [EditRequest.from_line(line) for line in self.proposal]
        if None in edits:
            return None  # a line this GUI cannot read back: told in the banner, not clickable
        if not self.suggestion or tuple(self.suggestion) == tuple(self.proposal):
            request = EditRequest(self.node_name, "repair")  # /change_tree applies the proposal as one edit
        elif len(edits) == 1:
            request = edits[0]
        else:
            return None
        return Offer(edits[0], request, self.proposal_text)

    def banner(self, seconds_left: float) -> str:
        """The red banner's text (``seconds_left`` of the veto window now); "" once the request is answered."""
        if not self.node_name:
            return ""
        failed = f"{self.node_name} failed: {self.reason}."
        if self.applied and seconds_left > 0.0:
            return (
                f"{failed} The robot applied its proposal: {self.proposal_text}. Undo within"
                f" {math.ceil(seconds_left)} s to veto (HIGH-LEVEL: click with the handle pushed down)."
            )
        if self.applied:
            return f"{failed} The robot applied its proposal: {self.proposal_text}. Change the tree or go on."
        text = f"The robot asks for help: {self.node_name} failed ({self.reason}). Change the tree."
        if self.suggestion:
            remembered = "; ".join(self.suggestion)
            text += f" Last time: {remembered}. HIGH-LEVEL: select \u201c{REPAIR_CHOICE}\u201d and click."
        if self.proposal:
            text += f" The robot proposes: {self.proposal_text} ({self.why})."
            if self.offer() is not None:
                text += " HIGH-LEVEL: it is preselected, click to apply it."
        return text
