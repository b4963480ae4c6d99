"""Who answers a help request: the robot alone, the robot proposing, or the operator (issue 52, shared decisions).

The tree policy's confidence decides, as the authority does for low-level corrections (``skills/authority.py``):

- the policy's proposal reaches ``act_confidence``: the robot applies it itself (one edit, so one undo reverts it) and
  waits ``veto_window`` seconds for the operator's veto before it goes on;
- else the same failure's remembered repair (:mod:`teleteach.bt.repairs`), if there is one, is suggested: an exact
  repeat of what the operator did, which the policy may still be unsure of;
- else the policy's proposal, however unsure, is suggested, so the operator confirms it with one click;
- else the operator is asked with nothing suggested, as before the policy existed.

Only the operator's answers teach the policy (:class:`teleteach.bt.teaching.TeachingTree`): a proposal the robot
applied and nobody touched is not a demonstration, or the policy would learn from itself.
"""

import typing

from teleteach.bt.editor import EditRequest
from teleteach.bt.situations import Situation
from teleteach.bt.tree_policy import TreePolicy

MEMORY = "memory"
POLICY = "policy"


class Advice(typing.NamedTuple):
    """What a help request suggests, where it comes from ("" none, MEMORY, POLICY), and whether the robot acts."""

    suggestion: typing.Tuple[EditRequest, ...] = ()
    source: str = ""
    confidence: float = 0.0  # the policy's, in its proposal (0 for a remembered repair the policy did not propose)
    why: str = ""
    acts: bool = False


def advise(
    policy: typing.Optional[TreePolicy],
    situation: typing.Optional[Situation],
    remembered: typing.Sequence[EditRequest],
) -> Advice:
    """The advice for a failure (see the module docstring); ``situation`` None: the policy cannot be asked."""
    remembered = tuple(remembered)
    if policy is None or situation is None:
        return Advice(remembered, MEMORY if remembered else "")
    proposal = policy.propose(situation)
    if proposal.acts(policy.config.act_confidence):
        return Advice(proposal.edits, POLICY, proposal.confidence, proposal.why, acts=True)
    if remembered:
        confidence = proposal.confidence if proposal.edits == remembered else 0.0
        why = f"the same failure's remembered repair; the policy: {proposal.why}"
        return Advice(remembered, MEMORY, confidence, why)
    if proposal.edits:
        return Advice(proposal.edits, POLICY, proposal.confidence, proposal.why)
    return Advice(why=proposal.why)
