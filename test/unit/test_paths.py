"""The one lookup of the package's files: in the checkout, and in an install space found through ROS_PACKAGE_PATH."""

import importlib.util
import shutil
import subprocess
import sys

from conftest import ROOT

from teleteach.core.paths import config_file, share_dir


def test_in_the_checkout_the_files_lie_beside_src():
    assert share_dir() == ROOT
    assert config_file("scenarios", "thesis_full.yaml").is_file()


def load_copy(path):
    spec = importlib.util.spec_from_file_location("installed_paths", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_in_an_install_space_ros_package_path_finds_the_share_directory(tmp_path, monkeypatch):
    module = tmp_path / "lib" / "python3" / "dist-packages" / "teleteach" / "core" / "paths.py"
    module.parent.mkdir(parents=True)
    shutil.copy(ROOT / "src" / "teleteach" / "core" / "paths.py", module)
    share = tmp_path / "share" / "teleteach"
    (share / "config").mkdir(parents=True)
    shutil.copy(ROOT / "package.xml", share / "package.xml")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "share"))
    installed = load_copy(module)
    assert installed.share_dir() == share
    assert installed.config_file("tree.yaml") == share / "config" / "tree.yaml"


def test_without_either_it_says_what_to_source(tmp_path):
    module = tmp_path / "paths.py"
    shutil.copy(ROOT / "src" / "teleteach" / "core" / "paths.py", module)
    code = (
        f"import importlib.util as u; s = u.spec_from_file_location('p', {str(module)!r}); m = u.module_from_spec(s); "
    )
    code += "s.loader.exec_module(m); m.share_dir()"
    result = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env={"ROS_PACKAGE_PATH": str(tmp_path)},
        check=False,
    )
    assert result.returncode != 0
    assert (
        "PackageFilesError: teleteach's files (config/, launch/) are not found: source the workspace" in result.stderr
    )
