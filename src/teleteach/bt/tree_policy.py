"""A policy learned from the operator's tree edits: it proposes the edit for a situation it has not seen (issue 52).

Each demonstration is a situation (:mod:`teleteach.bt.situations`) and the /change_tree requests that answered it. The
requests are generalised before learning: the failed node becomes ``{failed}``, its parent ``{parent}`` and an insert
into that parent keeps its index relative to the failed node, so "wrap PlaceItem in a retry" and "wrap PlaceItem2 in a
retry" are one repair. A scikit-learn classifier maps the situation's features (numbers divided by their scales,
categories one-hot) to the repair; its probabilities are calibrated (sigmoid, cross-validated over the
demonstrations) when each repair has at least two demonstrations.

The policy says it does not know (confidence 0) when no demonstration had the failure's category, or when a measured,
product or target value lies more than ``novelty_margin`` scales beyond the values the demonstrations of that
category had: a classifier extrapolates with confidence, the operator should not be replaced where nobody showed it.
A proposal whose repair names a skill the library lacks is skipped for the next likeliest one.

The model's classes are chosen by bench/tree_policy.py on its development part (config/tree_policy.yaml); the saved
policy is its demonstrations (plain yaml, no pickled model): the model is fitted again when it is read.
"""

import dataclasses
import typing

import numpy as np
import yaml

from teleteach.bt.editor import EditRequest
from teleteach.bt.repairs import RepairError, edit_request
from teleteach.bt.situations import SCALES, NodeContext, Situation, feature_set

MODELS = ("nearest_neighbour", "logistic_regression", "random_forest", "decision_tree")
CALIBRATIONS = ("sigmoid", "isotonic", "none")
FAILED = "{failed}"
PARENT = "{parent}"
INSERTING = ("add", "prepend", "insert")
RANDOM_STATE = 0  # fitting the same demonstrations gives the same policy
CALIBRATION_FOLDS = 3


class PolicyFileError(RepairError):
    """A saved policy is malformed or was saved under another feature set (set aside like a repair memory)."""


@dataclasses.dataclass(frozen=True)
class PolicyConfig:
    """How the policy learns and when it may act.

    Args:
        model: the classifier (one of MODELS).
        calibration: how its probabilities are calibrated (one of CALIBRATIONS): cross-validated over the
            demonstrations, when each repair has at least two.
        novelty_margin: [scales] how far beyond the demonstrated values a situation may lie and still be known.
        act_confidence: [-] the confidence from which the robot applies its proposal without asking.
        veto_window: [s] how long the operator may veto (undo) a proposal the robot applied alone before it goes on.
    """

    model: str
    calibration: str
    novelty_margin: float
    act_confidence: float
    veto_window: float

    def __post_init__(self):
        if self.model not in MODELS:
            raise ValueError(f"tree policy: unknown model '{self.model}'; expected one of {', '.join(MODELS)}")
        if self.calibration not in CALIBRATIONS:
            raise ValueError(
                f"tree policy: unknown calibration '{self.calibration}'; expected one of {', '.join(CALIBRATIONS)}"
            )
        if not self.novelty_margin >= 0.0 or not 0.0 <= self.act_confidence <= 1.0 or not self.veto_window >= 0.0:
            raise ValueError(
                f"tree policy: novelty_margin and veto_window must be >= 0 and act_confidence in [0, 1], got "
                f"{self.novelty_margin}, {self.veto_window} and {self.act_confidence}"
            )

    @classmethod
    def from_yaml(cls, **changes) -> "PolicyConfig":
        """config/tree_policy.yaml, the one place of its values, with ``changes``."""
        from teleteach.core.paths import config_values

        return cls(**{**config_values("tree_policy.yaml"), **changes})


Template = typing.Tuple[EditRequest, ...]


class Demonstration(typing.NamedTuple):
    """A situation and the edits the operator answered it with (only edits the tree accepted)."""

    situation: Situation
    edits: typing.Tuple[EditRequest, ...]


class Proposal(typing.NamedTuple):
    """What the policy would do: the edits (empty: nothing to propose), its confidence, and why, in words."""

    edits: typing.Tuple[EditRequest, ...]
    confidence: float
    why: str

    def acts(self, act_confidence: float) -> bool:
        """Whether the robot applies it without asking."""
        return bool(self.edits) and self.confidence >= act_confidence


def generalise(edits: typing.Sequence[EditRequest], node: NodeContext) -> Template:
    """The edits with the failed node, its parent and an insert's index made relative to the failed node.

    An empty parent is the execution composite (/change_tree's default): the same as naming it.
    """
    template = []
    for request in edits:
        into_parent = request.parent == node.parent or (request.parent == "" and node.in_execution)
        template.append(
            request._replace(
                node_name=FAILED if request.node_name == node.name else request.node_name,
                parent=PARENT if into_parent else request.parent,
                index=request.index - node.index if request.operation == "insert" and into_parent else request.index,
            )
        )
    return tuple(template)


def instantiate(template: Template, situation: Situation) -> typing.Optional[typing.Tuple[EditRequest, ...]]:
    """The template's edits for this situation's node; None when it adds a skill the library does not have.

    The execution composite is named as /change_tree's default: an empty parent.
    """
    node, skills = situation.node, {name for name, _ in situation.library}
    edits = []
    for request in template:
        if request.operation in INSERTING and request.node_name != FAILED and request.node_name not in skills:
            return None
        relative = request.operation == "insert" and request.parent == PARENT
        edits.append(
            request._replace(
                node_name=node.name if request.node_name == FAILED else request.node_name,
                parent=("" if node.in_execution else node.parent) if request.parent == PARENT else request.parent,
                index=request.index + node.index if relative else request.index,
            )
        )
    return tuple(edits)


def describe_template(template: Template) -> str:
    """One line for people, e.g. "wrap {failed} in a retry (2)"."""
    return "; ".join(request.describe() for request in template)


def scaled(features: typing.Mapping[str, typing.Union[float, str]]) -> typing.Dict[str, typing.Union[float, str]]:
    """Numbers in units of their scale (1 for flags), categories unchanged."""
    return {
        name: value if isinstance(value, str) else float(value) / SCALES.get(name, 1.0)
        for name, value in features.items()
    }


def _classifier(model: str):
    """A fresh scikit-learn classifier; imported here so that reading the tree module does not load scikit-learn."""
    from sklearn.ensemble import RandomForestClassifier
    from sklearn.linear_model import LogisticRegression
    from sklearn.neighbors import KNeighborsClassifier
    from sklearn.tree import DecisionTreeClassifier

    return {
        "nearest_neighbour": lambda: KNeighborsClassifier(n_neighbors=1),
        "logistic_regression": lambda: LogisticRegression(C=1.0, max_iter=2000),
        "random_forest": lambda: RandomForestClassifier(n_estimators=30, random_state=RANDOM_STATE),
        "decision_tree": lambda: DecisionTreeClassifier(random_state=RANDOM_STATE),
    }[model]()


class TreePolicy:
    """Proposes an edit for a situation, learned from demonstrations (see the module docstring)."""

    def __init__(self, config: PolicyConfig, demonstrations: typing.Iterable[Demonstration] = ()):
        self.config = config
        self.demonstrations: typing.List[Demonstration] = list(demonstrations)
        self._fit()

    def __len__(self) -> int:
        return len(self.demonstrations)

    def learn(self, situation: Situation, edits: typing.Sequence[EditRequest]) -> bool:
        """Add a demonstration (the accepted edits that answered ``situation``); False when there were none."""
        if not edits:
            return False
        self.demonstrations.append(Demonstration(situation, tuple(edits)))
        self._fit()
        return True

    def _fit(self) -> None:
        """Refit on every demonstration; scikit-learn is loaded only once there are two repairs to tell apart."""
        self._templates = [generalise(edits, situation.node) for situation, edits in self.demonstrations]
        features = [situation.features() for situation, _ in self.demonstrations]
        self._categories = {situation.failure.category for situation, _ in self.demonstrations}
        self._ranges: typing.Dict[str, typing.Tuple[float, float]] = {}  # of each numeric feature demonstrated
        for name in SCALES:
            seen = [values[name] for values in features if name in values]
            if seen:
                self._ranges[name] = (min(seen), max(seen))
        self.repairs: typing.List[Template] = sorted(set(self._templates), key=describe_template)
        self._model = None
        if len(self.repairs) < 2:
            return
        from sklearn.calibration import CalibratedClassifierCV
        from sklearn.feature_extraction import DictVectorizer

        self._vectoriser = DictVectorizer(sparse=False)
        rows = self._vectoriser.fit_transform([scaled(values) for values in features])
        labels = np.array([self.repairs.index(template) for template in self._templates])
        smallest = min(np.bincount(labels))
        model = _classifier(self.config.model)
        if self.config.calibration != "none" and smallest >= 2:
            folds = min(CALIBRATION_FOLDS, smallest)
            model = CalibratedClassifierCV(model, method=self.config.calibration, cv=folds)
        self._model = model.fit(rows, labels)

    def propose(self, situation: Situation) -> Proposal:
        """The likeliest applicable repair of ``situation`` with its confidence (0 where the policy does not know)."""
        unknown = self.unknown(situation)
        if len(self.repairs) == 1:
            edits = instantiate(self.repairs[0], situation) or ()
            return Proposal(edits, 0.0, unknown or "one kind of repair was demonstrated: nothing to tell it from")
        if not self.repairs:
            return Proposal((), 0.0, "nothing was demonstrated yet")
        probabilities = self._model.predict_proba(self._vectoriser.transform([scaled(situation.features())]))[0]
        for label in np.argsort(-probabilities, kind="stable"):
            template = self.repairs[self._model.classes_[label]]
            edits = instantiate(template, situation)
            if edits is None:
                continue
            if unknown:
                return Proposal(edits, 0.0, unknown)
            confidence = float(probabilities[label])
            why = f"{describe_template(template)}: {confidence:.0%} from {len(self)} demonstrations"
            return Proposal(edits, confidence, why)
        return Proposal((), 0.0, "every demonstrated repair adds a skill the library does not have")

    def unknown(self, situation: Situation) -> str:
        """Why the situation lies far from every demonstration ("" when it does not)."""
        category = situation.failure.category
        if category not in self._categories:
            return f"no demonstration had a failure like this one ({category})"
        for name, value in situation.features().items():
            if name not in self._ranges:
                continue
            low, high = self._ranges[name]
            beyond = max(low - value, value - high, 0.0) / SCALES[name]
            if beyond > self.config.novelty_margin:
                return f"{name} {value:.3g} lies {beyond:.1f} scales beyond the demonstrated {low:.3g} .. {high:.3g}"
        return ""

    def deciding_features(self, count: int = 8) -> typing.List[typing.Tuple[str, float]]:
        """The features that change the policy's choice most on its demonstrations (permutation importance)."""
        if self._model is None:
            return []
        from sklearn.inspection import permutation_importance

        rows = self._vectoriser.transform([scaled(situation.features()) for situation, _ in self.demonstrations])
        labels = np.array([self.repairs.index(template) for template in self._templates])
        found = permutation_importance(self._model, rows, labels, n_repeats=5, random_state=RANDOM_STATE)
        names = self._vectoriser.get_feature_names_out()
        ranked = sorted(zip(names, found.importances_mean), key=lambda item: -item[1])
        return [(str(name), float(weight)) for name, weight in ranked[:count] if weight > 0.0]

    def to_dict(self) -> typing.Dict[str, typing.Any]:
        """Plain data for yaml: the feature set and the demonstrations."""
        return {
            "feature_set": feature_set(),
            "demonstrations": [
                {"situation": situation.to_dict(), "edits": [request._asdict() for request in edits]}
                for situation, edits in self.demonstrations
            ],
        }

    @classmethod
    def from_dict(cls, data: typing.Any, config: PolicyConfig, source: str = "tree policy") -> "TreePolicy":
        """Build from :meth:`to_dict`'s data; :class:`PolicyFileError` naming what is wrong or incompatible."""
        if not isinstance(data, dict) or not isinstance(data.get("demonstrations"), list):
            raise PolicyFileError(f"{source}: expected a mapping with a 'demonstrations' list")
        if data.get("feature_set") != feature_set():
            raise PolicyFileError(
                f"{source}: saved with feature set {data.get('feature_set')!r}, this teleteach describes situations "
                f"as {feature_set()!r}"
            )
        demonstrations = []
        for number, entry in enumerate(data["demonstrations"], start=1):
            where = f"{source}: demonstration {number}"
            try:
                situation = Situation.from_dict(entry["situation"])
                edits = tuple(edit_request(edit, where) for edit in entry["edits"])
            except RepairError as error:
                raise PolicyFileError(str(error)) from None
            except (AttributeError, KeyError, TypeError, ValueError) as error:
                raise PolicyFileError(f"{where}: {type(error).__name__}: {error}") from None
            demonstrations.append(Demonstration(situation, edits))
        return cls(config, demonstrations)


def policy_yaml(policy: TreePolicy) -> str:
    """The saved form of a policy."""
    return yaml.safe_dump(policy.to_dict(), sort_keys=False)
