"""The main job's pieces that need no ROS: outcome checks, scenario files, process handling."""

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest
import yaml
from conftest import ROOT
from py_trees.common import Status
from scipy.spatial.transform import Rotation

from teleteach.core.frames import Transform
from teleteach.core.skill_file import Skill, save
from teleteach.gui.device import scale_to_index
from teleteach.gui.selection import OPERATIONS
from teleteach.haptics.click import ClickParameters
from teleteach.haptics.scenario import check_clicks, load_scenario
from teleteach.run import outcome
from teleteach.run.thesis import RVIZ_STARTS, ThesisRun, options_for
from teleteach.runtime.processes import (
    ProcessError,
    Processes,
    StageScreenshots,
    closed_bag,
    free_port,
    full_launch,
    master_pid,
    own_master,
    parent_pid,
    required_death,
    screenshot,
    scripted_device,
    start_xvfb,
)

SCENARIOS = [
    "thesis_III_B",
    "thesis_III_C",
    "thesis_III_D",
    "thesis_III_E",
    "thesis_full",
    "remembered_repair",
    "learned_repairs",
]


def recorded_skill(kx_insertion=2100.0, ky_alignment=2200.0):
    """A perpendicular placement as the GUI records it: 100 Hz, K diagonal, the three phases."""
    time = np.arange(0.0, 12.0, 0.01)
    kx = np.where(time < 9.0, 400.0, kx_insertion)
    ky = np.where((time >= 3.5) & (time < 5.0), ky_alignment, np.where(time >= 5.0, 1800.0, 400.0))
    stiffness = np.array([np.diag([x, y, 2000.0]) for x, y in zip(kx, ky)])
    pose = np.tile([0.5, 0.0, 0.8, 1.0, 0.0, 0.0, 0.0], (len(time), 1))
    return Skill("DemonstratedPlace_1", "stiffness", time + 100.0, stiffness, pose, pose)


def test_stiffness_phases_of_a_perpendicular_placement():
    phases = outcome.stiffness_phases(recorded_skill())
    assert (phases.approach_x, phases.approach_y) == (400.0, 400.0)
    assert phases.alignment_ratio == pytest.approx(5.5)
    assert phases.insertion_ratio == pytest.approx(5.25)
    assert phases.check() == []


def test_stiffness_phases_flag_missing_stiffening():
    problems = outcome.stiffness_phases(recorded_skill(kx_insertion=400.0, ky_alignment=800.0)).check()
    assert problems == [
        "Y stiffness in alignment only 2.0x the approach's",
        "X stiffness in insertion only 1.0x the approach's",
    ]


def test_stiffness_phases_refuse_a_short_recording():
    skill = recorded_skill()
    pose = skill.equilibrium_pose[:70]
    short = Skill(skill.name, skill.kind, skill.time[:70], skill.stiffness[:70], pose, pose)
    with pytest.raises(ValueError, match="no samples in 3-5 s"):
        outcome.stiffness_phases(short)


def test_alignment_axis_yaw_follows_the_turned_ellipsoid():
    skill = recorded_skill()
    assert outcome.alignment_axis_yaw(skill) == pytest.approx(90.0)  # III-C: Y stiffened along base Y
    turn = Rotation.from_euler("z", -45.0, degrees=True).as_matrix()
    turned = np.array([turn @ k @ turn.T for k in skill.stiffness])
    pose = skill.equilibrium_pose
    skill = Skill(skill.name, skill.kind, skill.time, turned, pose, pose)
    assert outcome.alignment_axis_yaw(skill, "angled_45") == pytest.approx(45.0)  # III-D: principal Y turned


def test_a_skill_in_its_targets_frame_is_read_in_the_base_it_was_taught_from(tmp_path):
    # III-D stored relative to gap_1, which stood turned -45 degrees in front of the base: the ellipsoid stiffened
    # along the shelf is along the gap's Y in the file, and at 45 degrees in the base the operator taught in
    base = recorded_skill()
    turn = Rotation.from_euler("z", -45.0, degrees=True).as_matrix()
    turned = np.array([turn @ k @ turn.T for k in base.stiffness])
    skill = Skill(base.name, base.kind, base.time, turned, base.equilibrium_pose, base.equilibrium_pose)
    gap_in_base = (0.6, 0.1, 0.72, *Rotation.from_euler("z", -45.0, degrees=True).as_quat())
    stored = skill.relative_to("gap_1", Transform.from_pose(gap_in_base))
    assert outcome.alignment_axis_yaw(stored, "angled_45") != pytest.approx(45.0, abs=5.0)
    assert outcome.alignment_axis_yaw(outcome.as_taught(stored), "angled_45") == pytest.approx(45.0)
    path = save(stored, tmp_path / "DemonstratedPlace_1")
    problems, seen = outcome.check_iii_c(str(path), "angled_45", stiffer_insertion=False)
    assert seen["alignment_axis_yaw_deg"] == pytest.approx(45.0)


def test_one_check_per_experiment_says_what_is_missing(tmp_path):
    initial = ("LookToShelf", "PlaceItem", "Idle")
    removed, inserted = outcome.expected_sequences(initial, "PlaceItem", "Taught_1", 1)
    # III-B: the removal must have happened at some point
    assert outcome.check_iii_b([initial, removed, inserted], removed, "PlaceItem") == []
    assert outcome.check_iii_b([initial], removed, "PlaceItem") == [
        "the tree never was ['LookToShelf', 'Idle'] (III-B)"
    ]
    assert outcome.check_iii_b([initial], initial, None) == []
    # III-C: a readable skill with the three phases
    path = save(recorded_skill(), tmp_path / "taught")
    problems, seen = outcome.check_iii_c(str(path), "perpendicular", stiffer_insertion=True)
    assert problems == [] and seen["alignment_ratio"] == pytest.approx(5.5)
    assert outcome.check_iii_c(None, "perpendicular", True)[0] == ["no skill was taught (III-C)"]
    broken = tmp_path / "broken.npz"
    broken.write_bytes(b"no skill")
    assert outcome.check_iii_c(str(broken), "perpendicular", True)[0][0].startswith("taught skill unreadable: ")
    # III-D: the stiffest axis within 5 degrees of the expected direction
    assert outcome.check_iii_d(43.0, 45.0) == [] and outcome.check_iii_d(90.0, None) == []
    assert outcome.check_iii_d(90.0, 45.0) == ["stiffest horizontal axis at 90 deg after alignment, not 45"]
    # III-E: inserted where the dial said, and run successfully by the tree
    assert outcome.check_iii_e(inserted, inserted, "Taught_1", Status.SUCCESS, "placed", inserted=True) == []
    assert outcome.check_iii_e(removed, inserted, "Taught_1", None, "", inserted=True) == [
        "final tree ['LookToShelf', 'Idle'], expected ['LookToShelf', 'Taught_1', 'Idle'] (III-E)",
        "the taught skill Taught_1 did not succeed on the robot (never run: )",
    ]
    failed = outcome.check_iii_e(inserted, inserted, "Taught_1", Status.FAILURE, "product_pick_2 ended", True)
    assert failed == ["the taught skill Taught_1 did not succeed on the robot (FAILURE: product_pick_2 ended)"]


def test_run_summary_is_written_as_json_and_in_words():
    summary = outcome.RunSummary(
        folder="/data/runs/1",
        problems=[],
        finished=True,
        bag="run.bag",
        tree_initial=["A"],
        tree_changes=[["A"]],
        tree_edits=[],
        tree_final=["A", "Taught_1"],
        expected_after_iii_b=["A"],
        expected_after_iii_e=["A", "Taught_1"],
        taught_skills=[{"name": "Taught_1", "file": "skills/Taught_1.npz"}],
        taught_skill_result={"status": "SUCCESS", "message": "replayed Taught_1"},
        stiffness_phases=None,
        alignment_ratio=None,
        insertion_ratio=None,
        alignment_axis_yaw_deg=None,
        placements=[
            {
                "product": "product_pick_2",
                "gap": "gap_2",
                "distance_m": 0.004,
                "upright": True,
                "by_skill": "Taught_1",
                "neighbours_max_move_m": 0.001,
            }
        ],
        help_requests=[(12.0, "PickItem", "product_pick_1 is not on the table")],
        help_time_s=41.5,
        tabs=[],
        screenshots=[],
        screenshot_errors=[],
        figures=[],
        timings_wall_s={},
    )
    data = json.loads(summary.to_json())
    assert data["passed"] is True and data["placements"][0]["by_skill"] == "Taught_1"
    text = summary.to_markdown()
    assert text.startswith("# Thesis run: PASSED")
    assert "- skill taught: Taught_1 (skills/Taught_1.npz); run by the tree: succeeded" in text
    placed = "- product product_pick_2: on the shelf in gap_2, upright, 4.0 mm from the nearest gap's centre, put there"
    assert placed + " by Taught_1" in text
    assert "- help request: PickItem: product_pick_1 is not on the table" in text
    assert "- from the first help request to the tree going on: 42 s (ROS time)" in text
    summary.problems.append("product_pick_2 did not end on the shelf (expected in gap_2)")
    assert summary.to_markdown().startswith("# Thesis run: FAILED")
    assert "- PROBLEM: product_pick_2 did not end on the shelf (expected in gap_2)" in summary.to_markdown()


def test_options_follow_the_scenario():
    full = options_for(ROOT / "config" / "scenarios" / "thesis_full.yaml")
    assert (full.removed, full.insert_index, full.trajectory) == ("PlaceItem", 8, "perpendicular")
    assert full.placements == (("product_pick_1", "gap_1", None), ("product_pick_2", "gap_2", outcome.TAUGHT_SKILL))
    assert full.skills == ROOT / "config" / "skills.yaml"
    angled = options_for(ROOT / "config" / "scenarios" / "thesis_III_D.yaml", timeout=10.0)
    assert angled.tree == ROOT / "config" / "scenarios" / "thesis_III_D_tree.yaml" and angled.tree.is_file()
    assert (angled.trajectory, angled.removed, angled.insert_index, angled.timeout) == ("angled_45", None, 8, 10.0)
    assert not angled.stiffer_insertion and angled.alignment_yaw == 45.0
    assert angled.placements == full.placements
    teach = options_for(ROOT / "config" / "scenarios" / "teach_placement.yaml")
    assert teach.tree.is_file() and teach.skills.is_file() and (teach.removed, teach.insert_index) == (None, None)
    assert teach.placements[1] == ("product_pick_2", "gap_2", "PlaceTaught2")
    assert (teach.phases, teach.taught_used_by) == ("teach_placement", "PlaceTaught2")


def test_a_placetaught_leaf_must_have_placed_with_the_taught_skill():
    used = "with Taught_1_dmp: replayed Taught_1_dmp (dmp) relative to gap_2 (taught at gap_1): ..."
    assert outcome.check_taught_used("Taught_1_dmp", "PlaceTaught2", Status.SUCCESS, used) == []
    assert outcome.check_taught_used("Taught_1_dmp", None, None, "") == []  # nothing to check
    other = "with Other_dmp: replayed Other_dmp (dmp) relative to gap_2"
    assert outcome.check_taught_used("Taught_1_dmp", "PlaceTaught2", Status.SUCCESS, other) == [
        f"PlaceTaught2 did not place with the taught skill Taught_1_dmp (SUCCESS: {other})"
    ]
    assert outcome.check_taught_used("Taught_1_dmp", "PlaceTaught2", None, "") == [
        "PlaceTaught2 did not place with the taught skill Taught_1_dmp (never run: )"
    ]


def test_the_operators_time_runs_from_the_first_help_request_to_the_last_close():
    asked = [(10.0, "PlaceTaught", "no taught skill"), (50.0, "PlaceTaught", "no taught skill")]
    assert outcome.help_time(asked, [40.0, 95.5]) == 85.5
    assert outcome.help_time(asked, [40.0]) is None  # the last one still open
    assert outcome.help_time([], []) is None


def test_tree_sequences_and_edits():
    initial = ("LookToShelf", "PickItem", "MoveBase", "PlaceItem", "DropItem", "Idle")
    removed, inserted = outcome.expected_sequences(initial, "PlaceItem", "Taught_1", 3)
    assert removed == ("LookToShelf", "PickItem", "MoveBase", "DropItem", "Idle")
    assert inserted == ("LookToShelf", "PickItem", "MoveBase", "Taught_1", "DropItem", "Idle")
    changes = outcome.sequence_changes([initial, initial, removed, removed, inserted])
    assert changes == [initial, removed, inserted]
    assert outcome.describe_edit(initial, removed) == "removed PlaceItem"
    assert outcome.describe_edit(removed, inserted) == "inserted Taught_1 at index 3"
    assert outcome.describe_edit(initial, inserted) == "removed PlaceItem; inserted Taught_1 at index 3"


@pytest.mark.parametrize("name", SCENARIOS)
def test_thesis_scenarios_are_valid_and_click_as_the_device_node_does(name):
    scenario = load_scenario(ROOT / "config" / "scenarios" / f"{name}.yaml")
    check_clicks(scenario, ClickParameters(**yaml.safe_load((ROOT / "config" / "device.yaml").read_text())["click"]))
    clicks = scenario.click_times()
    gaps = np.diff(clicks)
    # Expect: clicks are either a double click (0.35 s) or single clicks the GUI cannot pair (>= 1.5 s)
    assert all(gap == pytest.approx(0.35) or gap >= 1.5 - 1e-9 for gap in gaps), list(zip(clicks, gaps))


def test_thesis_full_drives_the_gui_to_the_expected_buttons():
    scenario = load_scenario(ROOT / "config" / "scenarios" / "thesis_full.yaml")
    gui = yaml.safe_load((ROOT / "config" / "gui.yaml").read_text())
    by_time = {frame.time: frame for frame in scenario.keyframes}
    reach, turn = gui["device_range"], gui["device_angle_range"]
    # III-B: PlaceItem is button 4 of 23 (PauseCondition, 10 leaves, 10 skills and 2 conditions of the library),
    # "remove" the lowest of 4 operations (the GUI's own slider mapping)
    assert scale_to_index(by_time[3.5].position[0], reach, 23) == 4
    assert OPERATIONS[scale_to_index(by_time[6.0].position[1], reach, len(OPERATIONS))] == "remove"
    # III-E: the new skill is the last of 23 buttons (PlaceItem gone, the new skill added), "insert" the operation,
    # index 8 of 10 slots (after MoveBase2, which drives to gap_2)
    assert scale_to_index(by_time[34.1].position[0], reach, 23) == 22
    assert OPERATIONS[scale_to_index(by_time[36.1].position[1], reach, len(OPERATIONS))] == "insert"
    assert scale_to_index(by_time[38.1].rpy[0], turn, 10) == 8


def test_learned_repairs_drives_the_gui_to_the_expected_buttons():
    scenario = load_scenario(ROOT / "config" / "scenarios" / "learned_repairs.yaml")
    reach = yaml.safe_load((ROOT / "config" / "gui.yaml").read_text())["device_range"]
    by_time = {frame.time: frame for frame in scenario.keyframes}
    # First request: 18 buttons (PauseCondition, the tree's 5 leaves, the library's 12); HIGH-LEVEL entered on button 4,
    # PickTea is button 1 (leaving the preselected proposal), "remove" the lowest of 4 operations
    assert scale_to_index(by_time[1.5].position[0], reach, 18) == 4
    assert scale_to_index(by_time[3.5].position[0], reach, 18) == 1
    assert OPERATIONS[scale_to_index(by_time[5.5].position[1], reach, len(OPERATIONS))] == "remove"
    # Second request: the click where HIGH-LEVEL was entered confirms the preselected proposal
    assert list(by_time[14.5].position) == list(by_time[12.5].position)


@pytest.mark.system
def test_free_port_and_xvfb_on_a_display_it_picked(tmp_path):
    port = free_port()
    assert 1024 < port < 65536
    processes = Processes()
    try:
        display = start_xvfb(processes)
        # Expect an X server that answers on the display it reported: a screenshot of it works
        assert screenshot(display, tmp_path / "screen.png") is None
        assert (tmp_path / "screen.png").stat().st_size > 0
    finally:
        processes.stop_all()


def wait_for(path, timeout=20.0):
    deadline = time.monotonic() + timeout
    while not path.is_file() and time.monotonic() < deadline:
        time.sleep(0.05)
    return path.is_file()


@pytest.mark.system
def test_each_stage_is_pictured_after_its_delay_then_its_latest_state_while_it_lasts(tmp_path):
    processes = Processes()
    stage = {"name": None}
    try:
        shots = StageScreenshots(start_xvfb(processes), tmp_path, "gui", lambda: stage["name"], delay=0.3, period=0.5)
        time.sleep(1.0)
        assert list(tmp_path.iterdir()) == []  # no stage yet: nothing worth a picture
        stage["name"] = "start"
        assert wait_for(tmp_path / "gui_01_start.png")
        assert wait_for(tmp_path / "gui_01_start_latest.png")
        stage["name"] = None
        time.sleep(0.5)
        stage["name"] = "low_level"
        assert wait_for(tmp_path / "gui_02_low_level.png")
        shots.stop()
        shots.take(tmp_path / "gui_final.png")
    finally:
        processes.stop_all()
    assert {path.name for path in tmp_path.iterdir()} <= {
        "gui_01_start.png",
        "gui_01_start_latest.png",
        "gui_02_low_level.png",
        "gui_02_low_level_latest.png",
        "gui_final.png",
    }
    assert (tmp_path / "gui_final.png").stat().st_size > 0 and shots.errors == []


def test_without_a_display_nothing_is_pictured(tmp_path):
    shots = StageScreenshots("", tmp_path, "screen", lambda: "running", delay=0.0, period=0.1)
    time.sleep(0.3)
    shots.take(tmp_path / "final.png")
    shots.stop()
    assert list(tmp_path.iterdir()) == [] and shots.errors == []


@pytest.mark.system
def test_an_rviz_that_dies_is_started_again_and_the_run_says_what_each_start_did(tmp_path, monkeypatch):
    programs = tmp_path / "bin"
    programs.mkdir()
    (programs / "rviz").write_text(f"#!/bin/sh\necho started >> {tmp_path / 'starts'}\nexit 3\n")
    (programs / "rviz").chmod(0o755)
    monkeypatch.setenv("PATH", f"{programs}:{os.environ['PATH']}")
    said = []
    run = ThesisRun(options_for(ROOT / "config" / "scenarios" / "thesis_full.yaml", data_root=tmp_path), said.append)
    try:
        missing = run.rviz_view()
    finally:
        run.experiment.close()
    # Expect: RViz started twice, each end told with its exit code, no picture
    assert (tmp_path / "starts").read_text().count("started") == RVIZ_STARTS == 2
    assert missing.startswith("rviz.png: start 1: RViz exited (code 3)"), missing
    assert "start 2: RViz exited (code 3)" in missing, missing
    assert len(said) == 2 and not (run.folder / "rviz.png").exists()


@pytest.mark.system
def test_own_master_moves_to_another_port_when_someone_else_took_the_probed_one(tmp_path):
    processes = Processes()
    env = dict(os.environ, ROS_LOG_DIR=str(tmp_path))
    roscore = lambda port: processes.start(f"roscore_{port}", ["roscore", "-p", str(port)], env=env)  # noqa: E731
    try:
        taken, other = own_master(roscore, processes.stop)
        ports = iter([taken])

        def start_on_taken_port_first(port):
            # The race: a port probed free is bound by somebody else before our roscore binds it
            return roscore(next(ports, port))

        port, ours = own_master(start_on_taken_port_first, processes.stop)
        # Expect the second master on a port of its own, started by our roscore; the other master untouched
        assert port != taken
        assert parent_pid(master_pid(f"http://localhost:{port}")) == ours.pid
        assert parent_pid(master_pid(f"http://localhost:{taken}")) == other.pid
    finally:
        processes.stop_all()


def test_own_master_says_why_when_the_starter_keeps_failing():
    processes = Processes()
    with pytest.raises(ProcessError, match="the last time it exited with 3"):
        own_master(lambda port: processes.start("fails", [sys.executable, "-c", "exit(3)"]), processes.stop, attempts=2)


def test_processes_stop_politely_and_refuse_missing_programs(tmp_path):
    processes = Processes()
    script = (
        "import signal, sys, time; signal.signal(signal.SIGINT, lambda *_: sys.exit(7)); "
        "print('ready', flush=True); time.sleep(60)"
    )
    first = processes.start("first", [sys.executable, "-c", script], tmp_path / "first.log")
    second = processes.start("second", [sys.executable, "-c", "import time; time.sleep(60)"])
    deadline = time.monotonic() + 30.0
    while "ready" not in (tmp_path / "first.log").read_text() and time.monotonic() < deadline:
        time.sleep(0.05)
    processes.stop_all()
    assert first.returncode == 7  # ended politely by SIGINT
    assert second.returncode is not None
    with pytest.raises(ProcessError, match="not installed"):
        processes.start("missing", ["no-such-program-teleteach"])


def test_run_thesis_refuses_a_bad_scenario(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("keyframes: [{t: 0.0}]\n")
    result = subprocess.run(
        [str(ROOT / "nodes" / "run_thesis"), "--scenario", str(bad), "--data-dir", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert result.returncode == 2, result.stdout + result.stderr
    assert "run_thesis: error:" in result.stdout and "bad.yaml" in result.stdout


def launch_nodes(*args, display=":0"):
    """The nodes full.launch would start with these args (roslaunch --nodes parses it without running anything), on
    a machine whose DISPLAY is ``display`` ("": none), whatever the test run's is (RViz's default follows it)."""
    env = {key: value for key, value in os.environ.items() if key != "DISPLAY"}
    result = subprocess.run(
        ["roslaunch", "--nodes", "teleteach", "full.launch", *args],
        capture_output=True,
        text=True,
        check=True,
        env=dict(env, DISPLAY=display) if display else env,
    )
    return {line.strip() for line in result.stdout.splitlines() if line.startswith("/")}


def test_full_launch_includes_the_parts_by_its_args():
    everything = {"/robot_sim", "/robot_state_publisher", "/skill_server", "/behaviour_tree", "/teaching_gui"}
    everything |= {"/sigma7_node", "/ellipsoid_marker", "/scene_labels", "/rviz", "/shared_control"}
    assert launch_nodes() == everything
    assert launch_nodes(display="") == everything - {"/rviz"}  # RViz by default only where there is a display
    assert launch_nodes("shared_control:=false") == everything - {"/shared_control"}
    # the device on another machine of the same ROS network (docs/real_robot.md: several machines)
    assert launch_nodes("device_node:=false") == everything - {"/sigma7_node"}
    # headless: no RViz (the ellipsoid marker and the scene's labels stay for bags and a later RViz, as run_thesis'
    # own RViz); record: the session recorder
    assert launch_nodes("headless:=true", "record:=true") == everything - {"/rviz"} | {"/session_recorder"}
    # a real robot: no simulation (franka_control.launch brings robot_state_publisher); the skill servers and the
    # stiffness bridge to the variable impedance controller run, and static_scene when there is no perception
    real = everything - {"/robot_sim", "/robot_state_publisher", "/teaching_gui", "/rviz"} | {"/stiffness_bridge"}
    assert launch_nodes("real_robot:=true", "gui:=false", "rviz:=false") == real
    assert launch_nodes("real_robot:=true", "gui:=false", "rviz:=false", "static_scene:=true") == real | {
        "/static_scene"
    }


@pytest.mark.parametrize(
    "args, required",
    [([], True), (["device:=scenario"], False), (["device:=scenario", "device_required:=true"], True)],
)
def test_the_device_node_ends_the_launch_for_an_operator_s_own_device_or_when_asked(args, required):
    import roslaunch.config
    import roslaunch.xmlloader

    config = roslaunch.config.ROSLaunchConfig()
    argv = ["roslaunch", "headless:=true", *args]  # roslaunch's command line: what the loader reads the args from
    roslaunch.xmlloader.XmlLoader().load(str(ROOT / "launch" / "full.launch"), config, argv=argv, verbose=False)
    (device,) = [node for node in config.nodes if node.name == "sigma7_node"]
    assert device.required is required


def test_a_scripted_system_s_command_line_reaches_its_device_node(tmp_path):
    import roslaunch.config
    import roslaunch.xmlloader

    scenario = tmp_path / "operator.yaml"
    command = full_launch({**scripted_device(scenario, 250.0), "headless": True, "data_dir": tmp_path}, port=11999)
    assert command[:5] == ["roslaunch", "-p", "11999", "teleteach", "full.launch"]
    assert "headless:=true" in command and "device_required:=true" in command
    result = subprocess.run(["roslaunch", "--dump-params", *command[3:]], capture_output=True, text=True, check=True)
    params = yaml.safe_load(result.stdout)
    assert (params["/sigma7_node/backend"], params["/sigma7_node/scenario"]) == ("scenario", str(scenario))
    assert params["/sigma7_node/rate"] == 250
    config = roslaunch.config.ROSLaunchConfig()
    argv = ["roslaunch", *command[5:]]
    roslaunch.xmlloader.XmlLoader().load(str(ROOT / "launch" / "full.launch"), config, argv=argv, verbose=False)
    (device,) = [node for node in config.nodes if node.name == "sigma7_node"]
    assert device.required  # a scripted operator that fails its script ends the system


def test_the_real_time_factor_reaches_the_simulation_only_when_asked(tmp_path):
    scenario = ROOT / "config" / "scenarios" / "thesis_III_D.yaml"
    default = ThesisRun(options_for(scenario, data_root=tmp_path)).launch_arguments()
    assert "real_time_factor" not in default  # config/controllers.yaml's
    faster = ThesisRun(options_for(scenario, data_root=tmp_path, real_time_factor=2.0)).launch_arguments()
    assert faster["real_time_factor"] == "2"
    assert {name: value for name, value in faster.items() if name not in ("real_time_factor", "record_prefix")} == {
        name: value for name, value in default.items() if name != "record_prefix"
    }
    command = full_launch(faster, port=11999)
    result = subprocess.run(["roslaunch", "--dump-params", *command[3:]], capture_output=True, text=True, check=True)
    assert yaml.safe_load(result.stdout)["/robot_sim/real_time_factor"] == 2
    refused = subprocess.run(
        [str(ROOT / "nodes" / "run_thesis"), "--real-time-factor", "-1", "--data-dir", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert refused.returncode == 2 and "--real-time-factor must be 0" in refused.stderr, refused.stderr


def test_a_bag_is_taken_once_rosbag_closed_it(tmp_path):
    bags = tmp_path / "bags"
    bags.mkdir()
    (bags / "trial_1.bag.active").write_bytes(b"recording")
    assert closed_bag(bags, "trial", tmp_path, timeout=0.3) is None  # still open: nothing to take
    (bags / "trial_1.bag.active").rename(bags / "trial_1.bag")
    (bags / "session_2.bag").write_bytes(b"another recorder's")
    assert closed_bag(bags, "trial", tmp_path, timeout=5.0, name="trial.bag") == tmp_path / "trial.bag"
    assert (tmp_path / "trial.bag").read_bytes() == b"recording"
    assert sorted(path.name for path in bags.iterdir()) == ["session_2.bag"]
    assert closed_bag(bags, "session", tmp_path, timeout=5.0) == tmp_path / "session_2.bag"  # its own name


def test_full_launch_passes_its_args_to_the_parts():
    result = subprocess.run(
        ["roslaunch", "--dump-params", "teleteach", "full.launch", "headless:=true", "double_click_window:=1.2"],
        capture_output=True,
        text=True,
        check=True,
    )
    params = yaml.safe_load(result.stdout)
    assert params["/teaching_gui/double_click_window"] == 1.2
    assert params["/teaching_gui/repaint_rate"] == 5
    assert params["/sigma7_node/backend"] == "virtual"
    assert params["/behaviour_tree/resume"] is False
    # shared control reads the device and waits for the GUI's SHARED CONTROL tab to switch it on
    assert params["/shared_control/input"] == "twist" and params["/shared_control/enabled"] is False


# What roslaunch wrote when a scripted operator's wait failed: another node's ERROR line first, roslaunch's colours
LAUNCH_LOG_OF_A_FAILED_SCENARIO = (
    "\x1b[1mprocess[sigma7_node-9]: started with pid [4242]\x1b[0m\n"
    "[ERROR] [1795692682.1, 48.7]: skill_server: Got a goal the arm cannot reach\n"
    "[INFO] [1795692682.3, 49.0]: published 41000 cycles at 238.0 Hz on average\n"
    "[FATAL] [1795692682.5, 49.1]: sigma7_node: scenario failed: config/scenarios/thesis_full.yaml:212: "
    "keyframes[17].wait: still waiting after 30 s for recording true\n"
    "\x1b[31m================================================================================"
    "REQUIRED process [sigma7_node-9] has died!\n"
    "process has died [pid 4242, exit code 1, cmd /devel/lib/teleteach/sigma7_node __name:=sigma7_node].\n"
    "Initiating shutdown!\n\x1b[0m"
    "[teaching_gui-7] killing on exit\n"
)


def test_a_required_death_is_told_by_the_node_its_exit_code_and_its_last_words():
    assert required_death(LAUNCH_LOG_OF_A_FAILED_SCENARIO) == (
        "sigma7_node died (exit code 1): sigma7_node: scenario failed: config/scenarios/thesis_full.yaml:212: "
        "keyframes[17].wait: still waiting after 30 s for recording true"
    )
    # Expect a node killed without a word to be named with its exit code alone, not with another node's error
    killed = LAUNCH_LOG_OF_A_FAILED_SCENARIO.replace("[FATAL]", "[INFO]").replace("exit code 1", "exit code -9")
    assert required_death(killed) == "sigma7_node died (exit code -9)"
    # Expect a node that names itself only in an ERROR line to be quoted from it; a FATAL line of another node last
    erring = killed.replace("skill_server: Got", "sigma7_node: lost")
    assert required_death(erring) == "sigma7_node died (exit code -9): sigma7_node: lost a goal the arm cannot reach"
    fatal_elsewhere = killed.replace("[ERROR] [1795692682.1, 48.7]: skill_server", "[FATAL] [1795692682.1, 48.7]: gui")
    assert required_death(fatal_elsewhere) == "sigma7_node died (exit code -9): gui: Got a goal the arm cannot reach"
    # Expect nothing when roslaunch ended without a required death (Ctrl-C, or a normal end)
    assert required_death(LAUNCH_LOG_OF_A_FAILED_SCENARIO.split("\x1b[31m")[0]) == ""
