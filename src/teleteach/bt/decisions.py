"""Who answers a help request: the robot alone, or the operator with the robot's proposal (issue 52, shared decisions).

The tree policy's confidence decides, as the authority does for low-level corrections (``skills/authority.py``):

- the policy's proposal reaches ``act_confidence``: the robot applies it itself (one edit, so one undo reverts it) and
  waits ``veto_window`` seconds for the operator's veto before it goes on;
- below, the operator is asked as before, the proposal (however unsure) attached for them to confirm or correct;
  the same failure's remembered repair (:mod:`teleteach.bt.repairs`) stays the help request's ``suggestion``.

Only the operator's answers teach the policy (:class:`teleteach.bt.teaching.TeachingTree`): a proposal the robot
applied and nobody touched is not a demonstration, or the policy would learn from itself.

:class:`TaskKnowledge` fills a failure's product, gap and base from what the tree node knows without perceiving: the
scene as configured and what each skill acts on.
"""

import typing

from teleteach.bt.editor import EditRequest
from teleteach.bt.situations import Situation, Spec, describe
from teleteach.bt.tree_policy import TreePolicy
from teleteach.core.scene import Scene, SceneError

VETOED = "vetoed by the operator"  # how a help request's ``why`` begins after a veto: the GUI does not offer it again


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


class TaskKnowledge(typing.NamedTuple):
    """What the tree knows of the task around a failure: the configured scene and what each skill acts on.

    The scene is the configured one (config/supermarket.yaml: nominal masses, sizes, gaps, base poses), not the
    perceived one; ``targets`` maps each skill to the product, gap or base pose it acts on (config/skills_motion.yaml's
    ``skills``), which a leaf's own ``parameters`` override. Around the failed leaf, in the order the tree runs its
    leaves: the product is the one it picks or else the last one picked before it (the one in the hand), the gap the
    one it places into or else the next one placed into, the base where the last drive up to it went.
    """

    scene: Scene
    targets: typing.Mapping[str, typing.Mapping[str, str]]

    def situation(
        self, root: Spec, execution: str, node_name: str, reason: str, library: typing.Iterable[typing.Tuple[str, str]]
    ) -> Situation:
        """The failure's situation; what cannot be told (a composite failed, a name the scene lacks) is left out."""
        leaves = self._leaves(root)
        names = [name for name, _ in leaves]
        at = names.index(node_name) if node_name in names else None
        found: typing.Dict[str, typing.Any] = {}
        if at is not None:
            order = {"product": leaves[at::-1], "gap": leaves[at:], "base_pose": leaves[at::-1]}
            for key, ordered in order.items():
                name = next((acts_on[key] for _, acts_on in ordered if key in acts_on), None)
                found[key] = self._lookup(key, name)
        return describe(
            root, execution, node_name, reason, library, found.get("product"), found.get("gap"), found.get("base_pose")
        )

    def _leaves(self, spec: Spec) -> typing.List[typing.Tuple[str, typing.Dict[str, str]]]:
        """(name, what it acts on) of every leaf below ``spec``, in the order the tree runs them."""
        if spec["type"] == "skill":
            acts_on = {**self.targets.get(spec.get("skill", spec["name"]), {}), **spec.get("parameters", {})}
            return [(spec["name"], {key: str(value) for key, value in acts_on.items()})]
        return [leaf for child in spec.get("children", []) for leaf in self._leaves(child)]

    def _lookup(self, key: str, name: typing.Optional[str]) -> typing.Any:
        """The scene's product, gap or base pose called ``name``; None for no name or one the scene lacks."""
        if name is None:
            return None
        try:
            if key == "product":
                return self.scene.product(name)
            return self.scene.gap(name) if key == "gap" else self.scene.base_poses[name]
        except (KeyError, SceneError):
            return None
