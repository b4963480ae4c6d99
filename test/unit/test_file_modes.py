"""What a user teaches or records is written with the user's umask (0644 under the usual 022), not mkstemp's 0600."""

import os
import stat
import subprocess
import sys

import pytest

WRITE_EVERYTHING = """
import os, pathlib, sys
os.umask(int(sys.argv[2], 8))
from teleteach.bt.teaching import TreeStore
from teleteach.core.datadir import atomic_write_text
from teleteach.learning.synthetic import placement_demo
from teleteach.core import skill_file
root = pathlib.Path(sys.argv[1])
skill, _, _ = placement_demo(angle=0.0, duration=2.0, gui_rate=4.0, seed=1)
skill.name = "Demo"
skill_file.save(skill, root / "skills" / "Demo.npz")
store = TreeStore(root / "trees")
store.save_tree("execution: BehaviorExecution\\n")
store.save_tree("execution: BehaviorExecution\\n")  # the first save becomes the previous version
atomic_write_text(root / "report" / "summary.md", "# report\\n")
"""


@pytest.mark.parametrize("umask, expected", [("022", 0o644), ("027", 0o640), ("077", 0o600)])
def test_skills_trees_and_reports_follow_the_umask(tmp_path, umask, expected):
    subprocess.run([sys.executable, "-c", WRITE_EVERYTHING, str(tmp_path), umask], check=True, timeout=120)
    files = [
        tmp_path / "skills" / "Demo.npz",
        tmp_path / "trees" / "current_tree.yaml",
        tmp_path / "trees" / "current_tree.previous.yaml",
        tmp_path / "report" / "summary.md",
    ]
    modes = {path.name: oct(stat.S_IMODE(os.stat(path).st_mode)) for path in files}
    assert modes == {path.name: oct(expected) for path in files}
