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
