"""The device's axes in the operator frame (x right, y away, z up): conventions, matrices, samples and wrenches."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.haptics.axes import AxisMapping, AxisMappingError
from teleteach.haptics.click import ClickDetector, ClickParameters
from teleteach.haptics.device import DeviceSample
from teleteach.haptics.guidance import Wrench
from teleteach.haptics.loop import DeviceLoop
from teleteach.haptics.twist import TwistEstimator

FORCE_DIMENSION = AxisMapping.from_config("force_dimension")


def sample(position, rotvec=(0.0, 0.0, 0.0)):
    return DeviceSample(np.array(position, float), Rotation.from_rotvec(rotvec).as_quat(), 0.25)


def test_the_force_dimension_frame_becomes_the_operators():
    # Expect: toward the operator (SDK +x) is the operator's -y, the SDK's right (+y) the operator's right (+x)
    np.testing.assert_allclose(FORCE_DIMENSION.to_operator(sample([0.01, 0.0, 0.0])).position, [0.0, -0.01, 0.0])
    np.testing.assert_allclose(FORCE_DIMENSION.to_operator(sample([0.0, 0.02, 0.03])).position, [0.02, 0.0, 0.03])
    # a handle rolled about the SDK's x (the axis toward the operator) turns about the operator's -y
    turned = FORCE_DIMENSION.to_operator(sample([0.0, 0.0, 0.0], [0.3, 0.0, 0.0]))
    np.testing.assert_allclose(Rotation.from_quat(turned.orientation).as_rotvec(), [0.0, -0.3, 0.0], atol=1e-12)
    # and the guidance's push to the operator's right reaches the device as a push along the SDK's +y
    np.testing.assert_allclose(FORCE_DIMENSION.to_device(Wrench(np.array([1.0, 0, 0]), np.zeros(3))).force, [0, 1, 0])


def test_operator_is_the_identity_and_a_matrix_is_taken_by_rows():
    identity = AxisMapping.from_config("operator")
    given = sample([0.01, 0.02, 0.03], [0.1, 0.2, 0.3])
    assert identity.to_operator(given) is given
    upside_down = AxisMapping.from_config([[1, 0, 0], [0, -1, 0], [0, 0, -1]])
    np.testing.assert_allclose(upside_down.to_operator(given).position, [0.01, -0.02, -0.03])


@pytest.mark.parametrize(
    "value, message",
    [
        ("sdk", "~axes/dhd: unknown convention 'sdk'; one of operator, force_dimension, or a 3x3 rotation matrix"),
        ([[1, 0], [0, 1]], "~axes/dhd: a 3x3 matrix of numbers (rows), got [[1, 0], [0, 1]] (or a convention name: "),
        ([[1, 0, 0], [0, 1, 0], [0, 0, 2]], "is not a rotation (orthonormal rows, determinant +1)"),
        ([[1, 0, 0], [0, 1, 0], [0, 0, -1]], "is not a rotation (orthonormal rows, determinant +1)"),
    ],
)
def test_a_bad_entry_is_refused_in_one_line(value, message):
    with pytest.raises(AxisMappingError) as error:
        AxisMapping.from_config(value, "~axes/dhd")
    assert message in str(error.value) and "\n" not in str(error.value)


class SdkFrameDevice:
    """A backend reporting in the Force Dimension frame; it keeps what it was told to render."""

    moves_on_wall_clock = False  # as DeviceBackend's default: its twist over the loop's stamps

    def __init__(self):
        self.rendered = []
        self.finished = False

    def read(self, time):
        return sample([0.0, 0.02, 0.0])  # 2 cm to the operator's right

    def missed_gripper(self):
        return ()

    def render(self, wrench):
        self.rendered.append(wrench)


def test_the_loop_publishes_the_operator_frame_and_renders_in_the_devices():
    device, published = SdkFrameDevice(), []

    class PushLeft:  # guidance of the operator frame: 1 N to the operator's left
        def wrench(self, *args):
            return Wrench(np.array([-1.0, 0.0, 0.0]), np.zeros(3))

        def drop(self):
            pass

    loop = DeviceLoop(
        device,
        published.append,
        clock=lambda: 0.0,
        click_detector=ClickDetector(ClickParameters.from_yaml()),
        twist_estimator=TwistEstimator(20.0),
        log_error=print,
        guidance=PushLeft(),
        axes=FORCE_DIMENSION,
    )
    loop.step()
    np.testing.assert_allclose(published[0].position, [0.02, 0.0, 0.0])
    np.testing.assert_allclose(device.rendered[0].force, [0.0, -1.0, 0.0])  # the SDK's left is its -y
