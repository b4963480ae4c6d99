"""The rosbag command lines of record.launch and replay.launch, and their refusal of bad input."""

import pytest
from session_bags import write_session

from teleteach.recording.bags import DEVICE_TOPICS, TEACHING_TOPICS, BagError, record_command, replay_command


def test_record_command_writes_timestamped_bags_into_the_data_directory(tmp_path):
    command = record_command("lesson_1", tmp_path / "data")
    assert command[:4] == ["rosbag", "record", "-o", str(tmp_path / "data" / "bags" / "lesson_1")]
    assert (tmp_path / "data" / "bags").is_dir()  # rosbag record does not create it
    assert command[4:] == [f"/{topic}" for topic in TEACHING_TOPICS]  # the root's names
    assert set(DEVICE_TOPICS) <= set(TEACHING_TOPICS)
    teaching = ("eigenvalues", "eigenvectors", "behaviour_tree/log/tree", "tf_static", "teleteach/active_tab")
    for topic in (*teaching, "teleteach/recording"):  # the GUI's tab and recording flag mark each demonstration
        assert topic in TEACHING_TOPICS
    # a recorder in a namespace records that namespace's topics, named in full in the bag
    inside = record_command("lesson_1", tmp_path / "data", namespace="/robot_2/")
    assert inside[4:] == [f"/robot_2/{topic}" for topic in TEACHING_TOPICS]


def test_record_command_uses_the_environments_data_directory(tmp_path, monkeypatch):
    monkeypatch.setenv("TELETEACH_DATA", str(tmp_path / "env_data"))
    assert record_command()[3] == str(tmp_path / "env_data" / "bags" / "session")


@pytest.mark.parametrize("prefix", ["", "../escape", "a/b", "with space"])
def test_record_prefix_must_be_a_plain_name(tmp_path, prefix):
    with pytest.raises(BagError, match="bag prefix"):
        record_command(prefix, tmp_path)


def test_replay_commands(tmp_path):
    bag = write_session(tmp_path / "s.bag", duration=0.1)
    device = replay_command(bag, rate=2.0, delay=0.5)
    recorded = ["/sigma7/pose", "/sigma7/twist", "/sigma7/gripper_angle", "/sigma7/button"]  # a root bag's names
    assert device == ["rosbag", "play", str(bag), "-r", "2.0", "-d", "0.5", "-s", "0.0", "--topics", *recorded]
    assert replay_command(bag, visual=True)[-1] == "--clock" and "--topics" not in replay_command(bag, visual=True)


@pytest.mark.parametrize(
    ("arguments", "reason"),
    [
        ({"rate": 0.0}, "rate must be"),
        ({"rate": float("nan")}, "rate must be"),
        ({"delay": -1.0}, "delay must be"),
        ({"start": float("inf")}, "start must be"),
    ],
)
def test_replay_refuses_bad_options(tmp_path, arguments, reason):
    bag = write_session(tmp_path / "s.bag", duration=0.1)
    with pytest.raises(BagError, match=reason):
        replay_command(bag, **arguments)


def test_replay_refuses_missing_and_foreign_files(tmp_path):
    with pytest.raises(BagError, match="does not exist"):
        replay_command(tmp_path / "missing.bag")
    (tmp_path / "notes.bag").write_text("not a bag")
    with pytest.raises(BagError, match="is not a ROS 1 bag"):
        replay_command(tmp_path / "notes.bag")
