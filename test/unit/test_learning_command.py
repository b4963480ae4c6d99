"""The learn_skill command end to end (a real subprocess), and its one-line errors on bad input."""

import json
import os
import pathlib
import signal
import subprocess
import sys

import numpy as np
import pytest

from teleteach.core import skill_file
from teleteach.learning import spd
from teleteach.learning.command import advice, main
from teleteach.learning.skill import LearningParameters
from teleteach.learning.synthetic import placement_demo
from teleteach.runtime.processes import own_roscore

ROOT = pathlib.Path(__file__).resolve().parents[2]
COMMAND = ROOT / "nodes" / "learn_skill"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def run(*arguments, env=None):
    return subprocess.run(
        [str(COMMAND), *map(str, arguments)], capture_output=True, text=True, timeout=120, env=env, check=False
    )


@pytest.fixture
def data(tmp_path):
    skill, _, _ = placement_demo(angle=45.0, duration=20.0, gui_rate=4.0, seed=5)
    skill.name = "Demo"
    skill_file.save(skill, tmp_path / "skills" / "Demo.npz")
    return tmp_path


def write_raw_skill(path, time, stiffness, count=None):
    """A skill file written without validation (what a broken recorder or a hand edit could leave)."""
    count = len(time) if count is None else count
    pose = np.tile([0.4, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0], (count, 1))
    meta = json.dumps({"name": "Broken", "kind": "stiffness", "rotational_stiffness": 30.0, "provenance": {}})
    np.savez(path, time=time, stiffness=stiffness, equilibrium_pose=pose, cartesian_pose=pose, meta=np.array(meta))
    return path


def test_learn_skill_end_to_end_on_a_skill_file(data):
    result = run("Demo", "--data-dir", data, "--duration", 15, "--goal-stiffness", 400, 900, 1200)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    assert "saved" in result.stdout and "Demo_dmp.npz" in result.stdout
    learned = skill_file.load(data / "skills" / "Demo_dmp.npz")
    assert learned.kind == "dmp" and learned.name == "Demo_dmp"
    assert learned.duration == pytest.approx(15.0)
    assert np.linalg.eigvalsh(learned.stiffness)[:, 0].min() > 0
    goal = np.array(learned.provenance["goal_stiffness"])
    assert spd.distance(learned.stiffness[-1], goal) < 0.05
    np.testing.assert_allclose(np.sort(np.linalg.eigvalsh(goal)), [400.0, 900.0, 1200.0], rtol=1e-9)
    assert learned.provenance["reproduction_error"]["max_relative"] <= 0.15
    plot = data / "skills" / "Demo_dmp.png"
    assert plot.read_bytes()[:8] == PNG_MAGIC
    # the learned file is refused a second time unless forced, and stays as it was
    before = (data / "skills" / "Demo_dmp.npz").read_bytes()
    again = run("Demo", "--data-dir", data)
    assert again.returncode == 2
    assert again.stderr.strip().count("\n") == 0 and "exists" in again.stderr
    assert (data / "skills" / "Demo_dmp.npz").read_bytes() == before


def test_add_without_a_running_system_says_so_and_keeps_the_saved_skill(data):
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:9")  # nothing listens on the discard port
    result = run(data / "skills" / "Demo.npz", "--data-dir", data, "--name", "Added", "--add", "--timeout", 1, env=env)
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert "/behaviour_tree/add_skill" in result.stderr and "no ROS master" in result.stderr
    assert skill_file.load(data / "skills" / "Added.npz").kind == "dmp"


def stop(process):
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGINT)
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=10)


@pytest.mark.system
def test_add_puts_the_learned_skill_into_the_running_behaviour_tree_library(data):
    env = dict(os.environ)
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "start_new_session": True, "env": env}

    def start_roscore(command, uri):
        env["ROS_MASTER_URI"] = uri
        return subprocess.Popen(command, **quiet)

    _, roscore = own_roscore(start_roscore, stop, host="127.0.0.1")
    tree = None
    try:
        early = run("Demo", "--data-dir", data, "--name", "Early", "--add", "--timeout", 1, env=env)
        # Expect a master without the behaviour tree to be reported as exactly that
        assert early.returncode == 2 and "Traceback" not in early.stderr
        assert "/behaviour_tree/add_skill is not available" in early.stderr
        tree = subprocess.Popen(
            [sys.executable, str(ROOT / "nodes" / "behaviour_tree"), f"_data_dir:={data}", "_startup_timeout:=0"],
            **quiet,
        )
        result = run("Demo", "--data-dir", data, "--add", "--timeout", 60, env=env)
        assert result.returncode == 0, result.stderr
        assert "added to the BT library" in result.stdout
        echo = subprocess.run(
            ["rostopic", "echo", "-n", "1", "/behaviour_tree/skill_library"],
            capture_output=True,
            text=True,
            timeout=60,
            env=env,
            check=False,
        )
        # Expect the library to list the learned skill as a dmp skill with its file
        assert "Demo_dmp" in echo.stdout and "dmp" in echo.stdout, echo.stdout + echo.stderr
        assert str(data / "skills" / "Demo_dmp.npz") in echo.stdout
    finally:
        if tree is not None:
            stop(tree)
        stop(roscore)


def test_a_non_spd_skill_file_gives_a_one_line_error_from_the_command(tmp_path):
    times = np.arange(20) * 0.1
    stiffness = np.tile(np.eye(3) * 500.0, (20, 1, 1))
    stiffness[7] = np.diag([500.0, -1.0, 500.0])
    path = write_raw_skill(tmp_path / "bad.npz", times, stiffness)
    result = run(path, "--data-dir", tmp_path)
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "not positive definite at sample 7" in lines[0]
    assert not list((tmp_path / "skills").glob("*"))


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda p: write_raw_skill(p, np.arange(3) * 0.1, np.tile(np.eye(3), (3, 1, 1))), "too few samples: 3"),
        (
            lambda p: write_raw_skill(p, np.array([0.0, 0.1, 0.3, 0.2, 0.4, 0.5]), np.tile(np.eye(3), (6, 1, 1))),
            "not strictly increasing at sample 3",
        ),
        (lambda p: p.write_bytes(b"garbage"), "cannot be read"),
        (lambda p: None, "does not exist"),
    ],
)
def test_bad_input_gives_one_clear_line_and_exit_code_2(tmp_path, capsys, make, message):
    path = tmp_path / "input.npz"
    make(path)
    assert main([str(path), "--data-dir", str(tmp_path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and message in captured.err
    assert not list((tmp_path / "skills").glob("*"))


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--duration", "-3"], "duration must be finite and > 0"),
        (["--goal-stiffness", "100", "0", "100"], "--goal-stiffness needs three finite values > 0"),
        (["--name", "not a name"], "must be an identifier"),
        (["--smoothing", "-1"], "smoothing width must be finite and >= 0"),
        (["--alpha-z", "0"], "alpha_z must be finite and > 0"),
    ],
)
def test_bad_options_are_rejected_before_anything_is_written(data, capsys, arguments, message):
    assert main(["Demo", "--data-dir", str(data), *arguments]) == 2
    assert message in capsys.readouterr().err
    assert sorted(path.name for path in (data / "skills").iterdir()) == ["Demo.npz"]


def test_a_bag_whose_stiffness_shares_stamps_is_learned_from(tmp_path):
    """Under simulated time the GUI (200 Hz) publishes faster than /clock ticks: consecutive commands share a stamp."""
    import rosbag
    from session_bags import eigenvalues_message, eigenvectors_message, pose_message, stamp

    bag_path = tmp_path / "session_sim_time.bag"
    clock_period = 0.008  # [s] a /clock slower than the GUI's 5 ms, as on a loaded machine
    with rosbag.Bag(str(bag_path), "w") as bag:
        for step in range(int(8.0 * 200)):
            t = step / 200.0
            ticked = np.floor(t / clock_period) * clock_period
            bag.write("/eigenvalues", eigenvalues_message(400.0 + 200.0 * t, 800.0, 1500.0, t=ticked), stamp(t))
            bag.write("/eigenvectors", eigenvectors_message(0.0, t=ticked), stamp(t))
            if step % 2 == 0:
                bag.write("/cartesian_pose", pose_message(0.4 + 0.02 * t, t=ticked), stamp(t))
    env = dict(os.environ, TELETEACH_DATA=str(tmp_path / "data"))
    result = run(bag_path, "--name", "FromSimTime", env=env)
    # Expect a learned skill, not "stiffness times are not strictly increasing (non-monotonic)"
    assert result.returncode == 0, result.stdout + result.stderr
    learned = skill_file.load(tmp_path / "data" / "skills" / "FromSimTime.npz")
    assert learned.stiffness[0, 0, 0] == pytest.approx(400.0, rel=0.05)
    assert learned.stiffness[-1, 0, 0] == pytest.approx(2000.0, rel=0.05)


def test_a_constant_demonstration_reports_an_error_that_means_something(tmp_path):
    """A constant stiffness reproduced exactly printed "mean 141.42 %" (an error divided by a spread of rounding)."""
    skill, _, _ = placement_demo(angle=0.0, duration=6.0, gui_rate=4.0, seed=2)
    skill.stiffness[:] = np.diag([800.0, 1200.0, 1500.0])
    skill.name = "Constant"
    path = skill_file.save(skill, tmp_path / "skills" / "Constant.npz")
    result = run(path, "--name", "ConstantDmp", env=dict(os.environ, TELETEACH_DATA=str(tmp_path)))
    assert result.returncode == 0, result.stderr
    line = next(line for line in result.stdout.splitlines() if "reproduction error" in line)
    mean = float(line.split("mean ")[1].split(" %")[0])
    assert mean < 1.0 and "(the demonstration is constant)" in line, line


def test_a_skill_taught_along_a_teleoperated_path_keeps_its_spread_stretched_with_the_duration(tmp_path):
    skill, _, _ = placement_demo(angle=45.0, duration=20.0, gui_rate=4.0, seed=5)
    skill.name = "AlongPath"
    skill.provenance.update(path_demonstrations=3, path_spread=[0.0, 0.02, 0.01], path_spread_time=[0.0, 5.0, 10.0])
    skill_file.save(skill, tmp_path / "skills" / "AlongPath.npz")
    result = run("AlongPath", "--data-dir", tmp_path, "--duration", 2 * skill.duration)
    assert result.returncode == 0, result.stderr
    learned = skill_file.load(tmp_path / "skills" / "AlongPath_dmp.npz")
    # Expect the replay's confidence to read the path's spread where the learned skill is, twice as long
    assert learned.provenance["path_demonstrations"] == 3
    assert learned.provenance["path_spread"] == [0.0, 0.02, 0.01]
    np.testing.assert_allclose(learned.provenance["path_spread_time"], [0.0, 10.0, 20.0], rtol=1e-6)


def error_of(mean, largest):
    return {"mean_of_stiffness": mean, "max_of_stiffness": largest, "spread": 0.3}


def test_advice_says_what_alarming_numbers_mean_and_what_to_change():
    """The issue's run: 15 samples over a 78 s recording, max 94 % at a step, a small mean."""
    parameters = LearningParameters.from_yaml()
    lines = advice(15, 78.0, error_of(0.021, 0.9399), parameters)
    assert lines == [
        "15 stiffness samples in 78.0 s: a sample is a change of the ellipsoid (or the end of a hold), so few samples "
        "mean the stiffness was held most of the time; the skill holds it too",
        "max error 94 % is where the stiffness stepped: 6 basis functions per second round a step over about 0.17 s, "
        "and the mean, 2.1 %, is what a replay follows; --basis-per-second 12 rounds steps less",
        "the demonstration lasted 78.0 s: a recording runs from one double click to the next, also after the "
        "trajectory ended, and a replay lasts as long; --duration S replays it in S seconds",
    ]
    # Expect a poor fit named as such, and nothing to say of a dense, short, close one
    assert advice(100, 12.0, error_of(0.08, 0.5), parameters) == [
        "mean error 8.0 % of the stiffness: the DMP does not follow this demonstration closely; try "
        "--basis-per-second 12 (now 6) or less --smoothing (now 0.05 s)"
    ]
    assert advice(100, 12.0, error_of(0.004, 0.057), parameters) == []


def test_learning_a_skill_file_says_which_recording_it_learned_from(data):
    result = run("Demo", "--data-dir", data)
    assert result.returncode == 0, result.stderr
    assert f"learned Demo_dmp from {data / 'skills' / 'Demo.npz'}, all of its stiffness recording (" in result.stdout
    assert "advice" not in result.stdout  # a dense 20 s demonstration reproduced within 6 %
