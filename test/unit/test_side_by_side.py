"""The suite's side-by-side rule (test/conftest.py): what each kind of test holds of the run's locks, with a second
process holding them as another worker would, and that every test the rule names exists."""

import multiprocessing
import pathlib
import threading

import pytest
from bench_scripts import suite_rule

RULE = suite_rule()  # test/conftest.py: `conftest` may name another folder's in a worker
ALONE, LIGHT, MEASURES_RATES, ROOT, RunLocks = RULE.ALONE, RULE.LIGHT, RULE.MEASURES_RATES, RULE.ROOT, RULE.RunLocks
locks_needed = RULE.locks_needed

WAIT = 1.0  # [s] for a lock that is free


def held_elsewhere(folder: pathlib.Path, needed: dict):
    """A process that holds ``needed`` until told to let go: (let go, process)."""
    context = multiprocessing.get_context("fork")
    holding, let_go = context.Event(), context.Event()
    process = context.Process(target=_hold, args=(str(folder), needed, holding, let_go), daemon=True)
    process.start()
    assert holding.wait(30.0), "the other worker did not get its locks"
    return let_go, process


def _hold(folder, needed, holding, let_go):
    locks = RunLocks(pathlib.Path(folder))
    locks.hold(needed)
    holding.set()
    let_go.wait(60.0)
    locks.release()


def taken_within(locks: RunLocks, needed: dict, seconds: float) -> threading.Event:
    """Start taking ``needed`` in a thread; the event is set once taken (checked after ``seconds``)."""
    taken = threading.Event()
    threading.Thread(target=lambda: (locks.hold(needed), taken.set()), daemon=True).start()
    taken.wait(seconds)
    return taken


@pytest.mark.parametrize(
    "other, mine, beside",
    [
        ({"system": "exclusive"}, {"rates": "shared"}, True),  # LIGHT beside an e2e system
        ({"system": "exclusive"}, {"system": "shared"}, False),  # another system test waits for the e2e system
        ({"system": "exclusive", "rates": "exclusive"}, {"rates": "shared"}, False),  # nothing beside a rate bench
        ({"system": "shared"}, {"rates": "shared"}, True),
        ({"system": "shared"}, {"system": "shared"}, True),
        ({"rates": "shared"}, {"system": "exclusive", "rates": "exclusive"}, False),
    ],
)
def test_a_test_runs_beside_another_worker_s_only_where_the_rule_says(tmp_path, other, mine, beside):
    let_go, process = held_elsewhere(tmp_path, other)
    locks = RunLocks(tmp_path)
    try:
        taken = taken_within(locks, mine, WAIT)
        assert taken.is_set() == beside
        let_go.set()
        # Expect: what waited is taken once the other worker lets go
        assert taken.wait(30.0), f"{mine} not taken after the other worker let go of {other}"
    finally:
        let_go.set()
        process.join(30.0)
    locks.release()
    assert locks.held == {}


class Item:
    """What locks_needed reads of a pytest item: its id and whether it is marked `system`."""

    def __init__(self, nodeid: str, system: bool = True):
        self.nodeid, self.system = nodeid, system

    def get_closest_marker(self, name):
        return True if name == "system" and self.system else None


def test_each_kind_of_test_needs_its_locks():
    light = next(iter(LIGHT))
    assert locks_needed(Item("test/e2e/test_study_e2e.py::test_x")) == {"system": "exclusive"}
    assert locks_needed(Item(MEASURES_RATES[0])) == {"system": "exclusive", "rates": "exclusive"}
    assert locks_needed(Item(light)) == {"rates": "shared"}
    assert locks_needed(Item("test/test_rostests.py::test_rostest[pick_and_place]")) == {"system": "shared"}
    assert locks_needed(Item("test/unit/test_bt_tree.py::test_x", system=False)) == {}


def test_every_test_the_rule_names_exists():
    rostests = {path.stem for path in (ROOT / "test" / "ros").glob("*.test")}
    for name in [*ALONE, *LIGHT, *MEASURES_RATES]:
        path, _, test = name.partition("::")
        assert (ROOT / path).exists(), name
        if test.startswith("test_rostest["):
            assert test[len("test_rostest[") : -1] in rostests, name
    assert set(MEASURES_RATES) <= set(ALONE)
    assert not set(LIGHT) & set(ALONE)
