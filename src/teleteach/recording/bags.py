"""Which topics a teaching session records, and the rosbag commands that record and replay it.

A session bag holds everything needed to re-run or plot a teaching session (thesis Appendix C.2 recorded
"the stiffness matrices and the Cartesian end-effector positions ... using the rosbag package"). Replaying only
the device topics into a live system re-runs the session on the robot: the GUI turns the same device input into
the same tree edits and stiffness commands.
"""

import pathlib
import re
from typing import List, Optional, Sequence, Union

from teleteach.core.datadir import data_dir

DEVICE_TOPICS = ("sigma7/pose", "sigma7/twist", "sigma7/gripper_angle", "sigma7/button")
"""The haptic device's input: all a replay feeds into a live system."""

TEACHING_TOPICS = (
    *DEVICE_TOPICS,
    "teleteach/active_tab",
    "teleteach/recording",
    "eigenvalues",
    "eigenvectors",
    "equilibrium_pose",
    "cartesian_pose",
    "behaviour_tree/log/tree",
    "behaviour_tree/help_request",
    "shared_control/state",
    "shared_control/operator_command",
    "joy",
    "shared_control/clutch",
    "shared_control/obstacle",
    "shared_control/task",
    "joint_states",
    "tf",
    "tf_static",
    "force_torque_ext",
    "teleteach/scene",
    "teleteach/true_scene",
    "robot_sim/base_error",
)
"""Everything a session bag records (the scene too, so that a visual replay shows the shelf and the products; in a
simulation the true scene and the base's errors, so that the run is judged from the world; the GUI's recording flag,
so that learn_skill takes each demonstration on its own; the shared controller's input (a joystick's too), task and
obstacle, so that a wipe's measures can be computed again from the bag).

Relative names: the recorder records them in its namespace (``/eigenvalues`` at the root, where the offline
readers, teleteach.recording.session and teleteach.learning.bag, expect them).
"""

BAG_MAGIC = b"#ROSBAG V2.0\n"
"""First bytes of every ROS 1 bag (format 2.0)."""

_PREFIX = re.compile(r"^[A-Za-z0-9_.-]+$")


class BagError(ValueError):
    """A bag path or a recording option that cannot work; the message says which and why."""


def record_command(
    prefix: str = "session",
    data_directory: Optional[Union[str, pathlib.Path]] = None,
    extra_topics: Sequence[str] = (),
    namespace: str = "/",
) -> List[str]:
    """The ``rosbag record`` command line writing ``<data dir>/bags/<prefix>_<YYYY-MM-DD-HH-MM-SS>.bag``.

    Creates the bags folder (rosbag record does not). rosbag adds the timestamp itself (``-o``). The teaching topics
    are named in ``namespace`` (the recorder's), as absolute names: rosbag writes a relative name into the bag as it
    was given, where readers would not find it.
    """
    if not _PREFIX.match(prefix):
        raise BagError(f"bag prefix {prefix!r} must be letters, digits, '_', '.' or '-' (no path)")
    bags = data_dir(data_directory) / "bags"
    base = "/" + namespace.strip("/") + "/" if namespace.strip("/") else "/"
    topics = [base + topic for topic in TEACHING_TOPICS]
    topics += [topic for topic in extra_topics if topic not in topics]
    return ["rosbag", "record", "-o", str(bags / prefix), *topics]


def check_bag(path: Union[str, pathlib.Path]) -> pathlib.Path:
    """Return ``path`` if it is a readable file that starts like a ROS 1 bag, else raise :class:`BagError`."""
    path = pathlib.Path(path).expanduser()
    if not path.is_file():
        raise BagError(f"bag file {path} does not exist")
    try:
        with path.open("rb") as stream:
            head = stream.read(len(BAG_MAGIC))
    except OSError as error:
        raise BagError(f"cannot read bag file {path}: {error.strerror}") from error
    if head != BAG_MAGIC:
        raise BagError(f"{path} is not a ROS 1 bag (it does not start with '#ROSBAG V2.0')")
    return path


def replay_command(
    bag: Union[str, pathlib.Path], visual: bool = False, rate: float = 1.0, delay: float = 1.0, start: float = 0.0
) -> List[str]:
    """The ``rosbag play`` command line replaying a session bag.

    Args:
        bag: the session bag.
        visual: False: only the device topics (to re-run the session on a live system);
            True: every topic with /clock from the bag (to watch the session in RViz; needs /use_sim_time).
        rate: playback speed factor.
        delay: seconds to wait after advertising, so that subscribers connect before the first message.
        start: seconds into the bag to start from.
    """
    path = check_bag(bag)
    for name, value, lowest in (("rate", rate, 1e-6), ("delay", delay, 0.0), ("start", start, 0.0)):
        if not value >= lowest or value == float("inf"):
            raise BagError(f"replay {name} must be a finite number >= {lowest:g}, got {value}")
    command = ["rosbag", "play", str(path), "-r", repr(float(rate)), "-d", repr(float(delay)), "-s", repr(float(start))]
    if visual:
        return [*command, "--clock"]
    return [*command, "--topics", *(f"/{topic}" for topic in DEVICE_TOPICS)]  # as a bag recorded at the root names them
