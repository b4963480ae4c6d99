"""Skill leaves without ROS for the behaviour-tree unit tests: each skill runs for a few ticks, then succeeds or
fails as scripted; every start, cancel and end is logged so tests can check what ran."""

import pathlib

import py_trees
from py_trees.common import Status

from teleteach.bt.behaviours import SkillLeaf
from teleteach.bt.library import SkillLibrary
from teleteach.bt.teaching import TeachingTree
from teleteach.bt.tree import load_tree
from teleteach.skills.predefined import PREDEFINED_SKILLS

CONFIG = pathlib.Path(__file__).resolve().parents[2] / "config"
THESIS_SEQUENCE = list(PREDEFINED_SKILLS)  # the thesis tree's leaves, in the order it runs them


class SkillWorld:
    """Where scripted skills run: durations in ticks, scripted failures, and a log of events."""

    def __init__(self, ticks=2, durations=None, failures=None):
        self.ticks = ticks
        self.durations = durations or {}
        self.failures = {skill: list(reasons) for skill, reasons in (failures or {}).items()}
        self.events = []

    def make_leaf(self, name, entry):
        return ScriptedSkill(name, entry, self)

    def names(self, event):
        return [name for kind, name in self.events if kind == event]


class ScriptedSkill(SkillLeaf):
    def __init__(self, name, entry, world):
        super().__init__(name, entry.name, entry.kind, entry.data_file)
        self.world = world
        self.remaining = 0

    def start(self):
        self.world.events.append(("start", self.name))
        self.remaining = self.world.durations.get(self.skill, self.world.ticks)

    def poll(self):
        self.remaining -= 1
        if self.remaining > 0:
            return Status.RUNNING, f"{self.skill}: {self.remaining} ticks to go"
        reasons = self.world.failures.get(self.skill)
        if reasons:
            self.world.events.append(("fail", self.name))
            return Status.FAILURE, reasons.pop(0)
        self.world.events.append(("succeed", self.name))
        return Status.SUCCESS, f"{self.skill} done"

    def cancel(self):
        self.world.events.append(("cancel", self.name))


def thesis_tree(world, store=None, data_root=None, repairs=None, **options):
    py_trees.blackboard.Blackboard.clear()
    library = SkillLibrary.load(CONFIG / "skills.yaml")
    spec = load_tree(CONFIG / "tree.yaml", library)
    return TeachingTree(spec, library, world.make_leaf, store=store, data_root=data_root, repairs=repairs, **options)


def leaf_names(node):
    return [child.name for child in node.children]


def status_of(tree, name):
    return tree.editor.nodes[name].status
