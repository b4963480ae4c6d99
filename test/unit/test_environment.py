"""The dependencies import together, with the versions the project pins, and the message contract holds."""

import importlib

import numpy
import pytest


@pytest.mark.parametrize(
    "module",
    [
        "numpy",
        "scipy.linalg",
        "casadi",
        "pybullet",
        "py_trees",
        "rosbags.rosbag1",
        "yaml",
        "matplotlib",
        "rospy",
        "actionlib",
        "tf2_ros",
        "PyQt5.QtWidgets",
        "PyQt5.QtOpenGL",
        "OpenGL.GL",
    ],
)
def test_dependency_imports(module):
    importlib.import_module(module)


def test_numpy_is_debians():
    # Debian's compiled scipy needs numpy 1.x (see requirements.txt).
    assert numpy.__version__.startswith("1.")
    import scipy.linalg

    assert scipy.linalg.eigh(numpy.eye(2))[0].tolist() == [1.0, 1.0]


def test_controller_manager_messages_are_wire_compatible():
    from teleteach.srv import ListControllers, SwitchController

    assert SwitchController._md5sum == "b29a7abc673b2c54c14b54e50f8d06a5"
    assert ListControllers._md5sum == "1341feb2e63fa791f855565d0da950d8"


def test_gripper_actions_are_wire_compatible_with_franka_gripper():
    # franka_gripper's md5sums (franka_ros noetic): a real franka_gripper_node takes the skills' goals unchanged.
    from teleteach.msg import (
        GraspActionGoal,
        GraspGoal,
        GraspResult,
        HomingActionGoal,
        MoveActionGoal,
        MoveGoal,
        StopActionGoal,
    )

    assert GraspActionGoal._md5sum == "7bd1a6e7f94ef15bb6dd05cb170e7909"
    assert MoveActionGoal._md5sum == "f8907a1e7bb902f2e4c7db8e1cf3d24f"
    assert GraspGoal._md5sum == "627a0f0b10ad0c919fbd62b0b3427e63"
    assert MoveGoal._md5sum == "d16050a0fe85f1c2cb8347c99678362e"
    assert GraspResult._md5sum == "45872d25d65c97743cc71afc6d4e884d"
    # Homing and Stop have empty goals: the same md5sum as any empty goal, and a result like Grasp's
    assert HomingActionGoal._md5sum == StopActionGoal._md5sum


def test_all_contract_types_are_generated():
    from teleteach.msg import (  # noqa: F401
        Behaviour,
        BehaviourTree,
        ControllerState,
        ExecuteSkillAction,
        HardwareInterfaceResources,
        HelpRequest,
        SharedControlState,
        SkillLibrary,
    )
    from teleteach.srv import AddSkill, ChangeTree  # noqa: F401

    assert ChangeTree._request_class.__slots__ == [
        "node_name",
        "operation",
        "index",
        "parent",
        "node_type",
        "parameter",
    ]
    assert Behaviour.RUNNING == 2 and Behaviour.SEQUENCE == 2
