"""What each executable in nodes/ runs: its parameters beyond its yaml, how it is built, how it ends.

A file in nodes/ is its usage (the docstring, which ``--help`` prints) and one call of a function here with that text;
the function returns the process' exit status. Nothing heavy loads at this module's top: ``rosrun teleteach <node>
--help`` answers without numpy, pybullet or a master, and the pinned libraries are checked
(:func:`teleteach.runtime.node.start`) before any of them is imported.
"""

import argparse
import os
import sys
import typing

from teleteach.runtime.node import (
    exit_on_bad_parameter,
    init_node,
    node_parameters,
    since_process_start,
    start,
)

ExitStatus = typing.Optional[int]


def _one_blas_thread() -> None:
    """Before numpy loads: BLAS worker threads cost far more than they save on 6x7 matrices at 1 kHz."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def behaviour_tree(description: str) -> ExitStatus:
    """Tick the teaching tree and serve its edits until shutdown."""
    start("behaviour_tree", description, ("behaviour_tree.yaml", "tree_policy.yaml"))
    from teleteach.bt.ros import BehaviourTreeNode

    # Publishing a 1000-node log/tree after an edit is ~2 ms of pure Python; a short GIL switch interval keeps
    # /change_tree answers from waiting behind it (5 ms slices by default). Process-wide, so set here.
    sys.setswitchinterval(0.0005)
    exit_on_bad_parameter("behaviour_tree", BehaviourTreeNode.from_params).spin()
    return 0


def robot_sim(description: str) -> ExitStatus:
    """Run the simulation until shutdown, or print the robot's URDF (``--urdf``)."""
    _one_blas_thread()
    parser = argparse.ArgumentParser()
    parser.add_argument("--urdf", action="store_true", help="print the URDF of base + Panda and exit")
    parser.add_argument("--scene", default=None, help="scene file for --urdf (default: config/supermarket.yaml)")
    arguments = start("robot_sim", description, "robot_sim.yaml", parser=parser, init=False)
    if arguments.urdf:
        from teleteach.core.scene import load_scene
        from teleteach.sim.urdf import robot_description

        robot = load_scene(arguments.scene).robot
        print(robot_description(robot.mount_height, robot.base_size))
        return 0
    from teleteach.sim.ros import RobotSimNode

    init_node("robot_sim")
    exit_on_bad_parameter("robot_sim", RobotSimNode.from_params).spin()
    return 0


def skill_server(description: str) -> ExitStatus:
    """Serve the skills as actions until shutdown."""
    _one_blas_thread()
    start("skill_server", description, "skill_server.yaml")
    import rospy

    from teleteach.skills.ros import SkillServer

    exit_on_bad_parameter("skill_server", SkillServer.from_params)
    rospy.spin()
    return 0


def sigma7_node(description: str) -> ExitStatus:
    """Run the device until shutdown; status 1 with one line when it cannot start or its scenario failed."""
    start("sigma7_node", description, "device.yaml")
    import rospy

    from teleteach.haptics.device import DeviceUnavailableError
    from teleteach.haptics.ros import Sigma7Node

    try:
        node = Sigma7Node.from_params()
    except (ValueError, DeviceUnavailableError) as error:
        rospy.logfatal(f"sigma7_node cannot start: {error}")
        return 1
    node.spin()
    return 1 if node.failure else 0


def device_monitor(description: str) -> ExitStatus:
    """Listen to the device for the length of its scenario, then print what it published."""
    start("device_monitor", description, "device_monitor.yaml")
    from teleteach.haptics.ros import DeviceMonitorNode

    exit_on_bad_parameter("device_monitor", DeviceMonitorNode.from_params).run()
    return 0


def shared_control(description: str) -> ExitStatus:
    """Run the shared controller until shutdown."""
    start("shared_control", description, "shared_control.yaml")
    import rospy

    from teleteach.shared_control.ros import SharedControlNode

    exit_on_bad_parameter("shared_control", SharedControlNode.from_params)
    rospy.loginfo(f"shared_control: running {since_process_start():.2f} s after the process started")
    rospy.spin()
    return 0


def static_scene(description: str) -> ExitStatus:
    """Publish the scene file's scene until shutdown."""
    start("static_scene", description, "static_scene.yaml")
    import rospy

    from teleteach.perception.ros import StaticSceneNode

    exit_on_bad_parameter("static_scene", StaticSceneNode.from_params)
    rospy.spin()
    return 0


def ellipsoid_marker(description: str) -> ExitStatus:
    """Publish the stiffness ellipsoid's marker until shutdown."""
    start("ellipsoid_marker", description, "ellipsoid_marker.yaml")
    import rospy

    from teleteach.viz.ros import EllipsoidMarkerPublisher

    exit_on_bad_parameter("ellipsoid_marker", EllipsoidMarkerPublisher.from_params)
    rospy.spin()
    return 0


def scene_labels(description: str) -> ExitStatus:
    """Publish the scene as RViz draws it until shutdown."""
    start("scene_labels", description)
    import rospy

    from teleteach.viz.ros import SceneLabelsPublisher

    SceneLabelsPublisher()
    rospy.spin()
    return 0


def stiffness_bridge(description: str) -> ExitStatus:
    """Bridge the eigen-decomposed stiffness to the Franka controller's message until shutdown."""
    start("stiffness_bridge", description, "stiffness_bridge.yaml")
    import rospy

    from teleteach.control.franka_stiffness import StiffnessBridgeConfig
    from teleteach.control.ros import StiffnessBridgeNode

    def build():  # control stands below runtime: its node's parameters are read here
        return StiffnessBridgeNode(StiffnessBridgeConfig.from_mapping(node_parameters("stiffness_bridge.yaml")))

    exit_on_bad_parameter("stiffness_bridge", build)
    rospy.spin()
    return 0


def teaching_gui(description: str) -> ExitStatus:
    """Run the operator's window; status 1 with one line when there is no display."""
    start("teaching_gui", description, "gui.yaml", init=False)
    from teleteach.gui.display import display_problem

    problem = display_problem()
    if problem:
        print(f"teaching_gui cannot start: {problem}", file=sys.stderr)
        return 1
    import rospy

    from teleteach.gui.app import run
    from teleteach.gui.ros import gui_config

    init_node("teaching_gui")
    return run(exit_on_bad_parameter("teaching_gui", gui_config), rospy.is_shutdown)


def session_bag(description: str) -> ExitStatus:
    """Become ``rosbag record`` or ``rosbag play`` (exec), or print a one-line error (status 2)."""
    import rospy

    from teleteach.recording.bags import BagError, record_command, replay_command

    parser = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = parser.add_subparsers(dest="command", required=True)
    record = commands.add_parser("record", help="record the teaching topics")
    record.add_argument("--prefix", default="session", help="bag name prefix (default: session)")
    record.add_argument("--data-dir", default="", help="data directory (default: teleteach.core.datadir.data_dir())")
    replay = commands.add_parser("replay", help="replay a session bag")
    replay.add_argument("bag", help="session bag file")
    replay.add_argument("--visual", action="store_true", help="all topics with /clock, for RViz")
    replay.add_argument("--rate", type=float, default=1.0, help="playback speed factor")
    replay.add_argument("--delay", type=float, default=1.0, help="seconds between advertising and playing")
    replay.add_argument("--start", type=float, default=0.0, help="seconds into the bag to start from")
    arguments = parser.parse_args(rospy.myargv()[1:])
    remappings = [argument for argument in sys.argv[1:] if argument.startswith("__") and ":=" in argument]
    try:
        if arguments.command == "record":
            command = record_command(arguments.prefix, arguments.data_dir or None, namespace=rospy.get_namespace())
        else:
            command = replay_command(arguments.bag, arguments.visual, arguments.rate, arguments.delay, arguments.start)
    except (BagError, OSError) as error:
        print(f"session_bag: {error}", file=sys.stderr)
        return 2
    print("session_bag: " + " ".join(command), flush=True)
    os.execvp(command[0], command + remappings)


def report(description: str) -> ExitStatus:
    """Write a session bag's report and say where; status 2 with one line when the bag or the folder is bad."""
    from teleteach.recording.report import make_report
    from teleteach.recording.session import SessionError

    parser = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("bag", help="session bag (e.g. ~/.ros/teleteach/bags/session_<timestamp>.bag)")
    parser.add_argument("--out", default=None, help="output folder (default: <bag folder>/<bag stem>_report)")
    arguments = parser.parse_args()
    try:
        written = make_report(arguments.bag, arguments.out)
    except SessionError as error:
        print(f"report: error: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"report: error: cannot write the report: {error}", file=sys.stderr)
        return 2
    for path in written.figures.values():
        print(f"wrote {path}")
    for name, reason in written.skipped.items():
        print(f"skipped {name}: {reason}")
    print(f"wrote {written.summary}")
    return 0


def study_report(description: str) -> ExitStatus:
    """Write a study's report and say where; status 2 with one line when the folder holds no study data."""
    from teleteach.study.report import ReportError, make_report

    parser = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("study_dir", help="the study's folder: <data dir>/studies/<study name>")
    parser.add_argument("--out", default=None, help="where to write (default <study dir>/report)")
    arguments = parser.parse_args()
    try:
        written = make_report(arguments.study_dir, arguments.out)
    except ReportError as error:
        print(f"study_report: {error}", file=sys.stderr)
        return 2
    print(f"study_report: {written.folder / 'report.md'}")
    return 0
