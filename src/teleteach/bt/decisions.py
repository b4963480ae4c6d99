"""Who answers a help request: the robot alone, or the operator with the robot's proposal (issue 52, shared decisions).

The tree policy's confidence decides, as the authority does for low-level corrections (``skills/authority.py``):

- the policy's proposal reaches ``act_confidence``: the robot applies it itself (one edit, so one undo reverts it) and
  waits ``veto_window`` seconds for the operator's veto before it goes on;
- below, the operator is asked as before, the proposal (however unsure) attached for them to confirm or correct;
  the same failure's remembered repair (:mod:`teleteach.bt.repairs`) stays the help request's ``suggestion``.

Only the operator's answers teach the policy (:class:`teleteach.bt.teaching.TeachingTree`): a proposal the robot
applied and nobody touched is not a demonstration, or the policy would learn from itself.
"""

import typing

from teleteach.bt.editor import EditRequest
from teleteach.bt.situations import Situation
from teleteach.bt.tree_policy import TreePolicy


class Advice(typing.NamedTuple):
    """The policy's proposal for a failure, its confidence and reason, and whether the robot applies it alone."""

    proposal: typing.Tuple[EditRequest, ...] = ()
    confidence: float = 0.0
    why: str = ""
    acts: bool = False


def advise(policy: typing.Optional[TreePolicy], situation: typing.Optional[Situation]) -> Advice:
    """The advice for a failure (see the module docstring); no policy or no situation: nothing to advise."""
    if policy is None or situation is None:
        return Advice()
    proposal = policy.propose(situation)
    return Advice(proposal.edits, proposal.confidence, proposal.why, proposal.acts(policy.config.act_confidence))
