"""learn_skill on a session bag learns each LOW-LEVEL recording on its own, never the replay of a taught skill.

The bags are written here with rosbags' ROS 1 writer as `full.launch record:=true` writes them: each topic under the
node that publishes it (the connection's callerid), /teleteach/active_tab and /teleteach/recording latched.
"""

import numpy as np
import pytest
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore
from scipy.spatial.transform import Rotation

from teleteach.core import skill_file
from teleteach.learning.command import main

STORE = get_typestore(Stores.ROS1_NOETIC)
TYPES = STORE.types
START, LOW_LEVEL = 1_700_000_000.0, 2  # [s] the session's first stamp; /teleteach/active_tab's LOW-LEVEL
GUI, SKILLS, SIMULATION = "/teaching_gui", "/skill_server", "/robot_sim"
PRESET = (404.0, 404.0, 2006.0)  # [N/m] the GUI's ellipsoid in LOW-LEVEL before the operator records


def demonstrated(phase):
    """The operator's stiffness over a recording, phase 0..1: X stiffened from 400 to 2000 N/m in its middle third."""
    ramp = np.clip(3.0 * phase - 1.0, 0.0, 1.0)
    return (404.0 + 1600.0 * ramp, 404.0, 2006.0)


def header(t, frame="base_link"):
    seconds = START + t
    stamp = TYPES["builtin_interfaces/msg/Time"](sec=int(seconds), nanosec=int(round((seconds % 1) * 1e9)) % 10**9)
    return TYPES["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=frame)


def pose(t, x):
    point = TYPES["geometry_msgs/msg/Point"](x=x, y=0.0, z=0.5)
    orientation = TYPES["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
    return TYPES["geometry_msgs/msg/PoseStamped"](
        header=header(t), pose=TYPES["geometry_msgs/msg/Pose"](position=point, orientation=orientation)
    )


def stiffness(t, values, yaw=0.0):
    vector = TYPES["geometry_msgs/msg/Vector3"](x=values[0], y=values[1], z=values[2])
    x, y, z, w = Rotation.from_euler("z", yaw).as_quat()
    quaternion = TYPES["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)
    return (
        ("/eigenvalues", TYPES["geometry_msgs/msg/Vector3Stamped"](header=header(t), vector=vector)),
        ("/eigenvectors", TYPES["geometry_msgs/msg/QuaternionStamped"](header=header(t), quaternion=quaternion)),
    )


def write_session_bag(path, tabs, recordings=(), replays=(), flag=True, end=24.0):
    """A teaching session's bag.

    Args:
        tabs: (time [s], tab) of /teleteach/active_tab: the GUI streams the stiffness at 50 Hz while LOW-LEVEL is open.
        recordings: (start, end) [s] of LOW-LEVEL recordings: the operator's profile (:func:`demonstrated`), the
            GUI's trajectory player on /equilibrium_pose at 100 Hz, and (with ``flag``) /teleteach/recording.
        replays: (start, end) [s] where the tree replays a taught skill: the skill server's stiffness (stiff,
            turned 45 degrees) and /equilibrium_pose at 100 Hz.
    """
    messages = []  # (time [s], callerid, topic, message)
    for step in range(int(end * 100) + 1):
        t = step / 100.0
        messages.append((t, SIMULATION, "/cartesian_pose", pose(t, 0.4 + 0.005 * t)))
        tab = [value for time, value in tabs if time <= t][-1]
        recording = next(((a, b) for a, b in recordings if a <= t <= b), None)
        if tab == LOW_LEVEL and step % 2 == 0:
            values = PRESET if recording is None else demonstrated((t - recording[0]) / (recording[1] - recording[0]))
            messages += [(t, GUI, topic, message) for topic, message in stiffness(t, values)]
        if recording is not None:
            messages.append((t, GUI, "/equilibrium_pose", pose(t, 0.45)))
        if any(a <= t <= b for a, b in replays):
            messages += [(t, SKILLS, topic, message) for topic, message in stiffness(t, (2500.0, 300.0, 2500.0), 0.8)]
            messages.append((t, SKILLS, "/equilibrium_pose", pose(t, 0.5)))
    messages += [(t, GUI, "/teleteach/active_tab", TYPES["std_msgs/msg/Int8"](data=tab)) for t, tab in tabs]
    if flag:
        flags = [(0.0, False)] + [(t, on) for a, b in recordings for t, on in ((a, True), (b + 0.001, False))]
        messages += [(t, GUI, "/teleteach/recording", TYPES["std_msgs/msg/Bool"](data=on)) for t, on in flags]
    with Writer(path) as writer:
        connections = {}
        for t, callerid, topic, message in sorted(messages, key=lambda row: row[0]):
            key = (callerid, topic)
            if key not in connections:
                latched = int(topic.startswith("/teleteach/"))
                connections[key] = writer.add_connection(
                    topic, message.__msgtype__, typestore=STORE, callerid=callerid, latching=latched
                )
            writer.write(
                connections[key], int(round((START + t) * 1e9)), STORE.serialize_ros1(message, message.__msgtype__)
            )
    return path


def learned_files(data):
    return sorted(path.name for path in (data / "skills").glob("*.npz"))


@pytest.mark.parametrize("flag", [True, False], ids=["recording_flag", "bag_before_the_flag"])
def test_a_session_is_learned_from_its_recording_not_from_the_replay_after_it(tmp_path, capsys, flag):
    # LOW-LEVEL 2-10.5 s, recorded 4-10 s; the tree replays the taught skill 14-20 s, in LOW-LEVEL again from 12 s
    tabs = [(0.0, 0), (2.0, LOW_LEVEL), (10.5, 0), (12.0, LOW_LEVEL), (21.0, 0)]
    path = write_session_bag(tmp_path / "session.bag", tabs, [(4.0, 10.0)], [(14.0, 20.0)], flag=flag)
    assert main([str(path), "--data-dir", str(tmp_path), "--name", "Taught"]) == 0
    output = capsys.readouterr().out
    # Expect one demonstration: the recording, 6 s, learned from its own samples only
    assert learned_files(tmp_path) == ["Taught.npz"]
    learned = skill_file.load(tmp_path / "skills" / "Taught.npz")
    assert learned.duration == pytest.approx(6.0, abs=0.05)
    source = learned.provenance["learned_from"]
    assert (source["demonstration"], source["demonstrations"]) == (1, 1)
    assert (source["start"], source["end"]) == (pytest.approx(4.0, abs=0.02), pytest.approx(10.0, abs=0.02))
    error = learned.provenance["reproduction_error"]
    assert error["max_of_stiffness"] < 0.1, error  # the whole session joined: a jump to the replay's stiffness
    np.testing.assert_allclose(np.diag(learned.stiffness[0]), demonstrated(0.0), rtol=0.02)
    np.testing.assert_allclose(np.diag(learned.stiffness[-1]), demonstrated(1.0), rtol=0.02)
    assert "from demonstration 1 of" in output and "4.0-10.0 s into the bag" in output
    assert ("/teleteach/recording in the LOW-LEVEL tab" if flag else "has no /teleteach/recording") in output
    assert "reproduction error (same duration and goal): mean" in output


def test_two_recordings_are_two_demonstrations(tmp_path, capsys):
    tabs = [(0.0, 0), (2.0, LOW_LEVEL), (10.5, 0), (12.0, LOW_LEVEL), (17.5, 0)]
    path = write_session_bag(tmp_path / "two.bag", tabs, [(4.0, 10.0), (13.0, 17.0)], [(19.0, 23.0)])
    assert main([str(path), "--data-dir", str(tmp_path)]) == 0
    output = capsys.readouterr().out
    # Expect both listed with their times, each learned on its own and its error reported
    assert "holds 2 demonstrations" in output
    assert "demonstration 1: 4.0-10.0 s into the bag (6.0 s)" in output
    assert "demonstration 2: 13.0-17.0 s into the bag (4.0 s)" in output
    assert output.count("reproduction error") == 2
    assert learned_files(tmp_path) == ["two_dmp_1.npz", "two_dmp_2.npz"]
    for number, duration in ((1, 6.0), (2, 4.0)):
        learned = skill_file.load(tmp_path / "skills" / f"two_dmp_{number}.npz")
        assert learned.name == f"two_dmp_{number}"
        assert learned.duration == pytest.approx(duration, abs=0.05)
        assert learned.provenance["learned_from"]["demonstration"] == number
        assert learned.provenance["reproduction_error"]["max_of_stiffness"] < 0.1
        assert (tmp_path / "skills" / f"two_dmp_{number}.png").is_file()
    # Expect --demonstration to learn the one it names, under the plain name
    assert main([str(path), "--data-dir", str(tmp_path), "--demonstration", "2", "--name", "Second"]) == 0
    output = capsys.readouterr().out
    assert "learned Second from demonstration 2 of" in output
    # Expect the way to the session's figures named
    assert f"the session's figures (tree edits, stiffness, rotation): rosrun teleteach report {path}" in output
    assert skill_file.load(tmp_path / "skills" / "Second.npz").duration == pytest.approx(4.0, abs=0.05)


@pytest.mark.parametrize("flag", [True, False], ids=["recording_flag", "bag_before_the_flag"])
def test_a_session_without_a_recording_gives_one_clear_line_and_writes_nothing(tmp_path, capsys, flag):
    # the operator opened LOW-LEVEL without recording; the tree replayed a skill, partly while LOW-LEVEL was open
    tabs = [(0.0, 0), (2.0, LOW_LEVEL), (8.0, 0), (14.0, LOW_LEVEL), (18.0, 0)]
    path = write_session_bag(tmp_path / "none.bag", tabs, [], [(10.0, 16.0)], flag=flag)
    assert main([str(path), "--data-dir", str(tmp_path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and "holds no demonstration to learn from" in captured.err
    assert not list((tmp_path / "skills").iterdir())


def test_demonstration_numbers_outside_the_bag_are_refused(tmp_path, capsys):
    tabs = [(0.0, 0), (2.0, LOW_LEVEL), (10.5, 0)]
    path = write_session_bag(tmp_path / "one.bag", tabs, [(4.0, 10.0)], end=12.0)
    assert main([str(path), "--data-dir", str(tmp_path), "--demonstration", "2"]) == 2
    assert "--demonstration 2: bag" in capsys.readouterr().err
    skill = tmp_path / "skills" / "Taught.npz"
    assert main([str(skill), "--data-dir", str(tmp_path), "--demonstration", "1"]) == 2
    assert "not a .bag" in capsys.readouterr().err
    assert not list((tmp_path / "skills").iterdir())
