"""The dhd backend: refusals (no Force Dimension SDK on this machine, a library that is not libdhd, no device), and
its ctypes bindings run against test/data/fake_dhd.c, a C stand-in with the SDK's function signatures that records
the forces it receives."""

import ctypes
import ctypes.util
import pathlib
import subprocess

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.haptics.device import DeviceReadError, DeviceUnavailableError
from teleteach.haptics.dhd import DhdBackend, load_dhd_library
from teleteach.haptics.guidance import AxisGuidance, Guidance, GuidanceLimits, GuidanceRenderer, Wrench


def test_missing_sdk_is_one_clear_line_naming_the_library():
    assert ctypes.util.find_library("dhd") is None, "this test expects a machine without the Force Dimension SDK"
    with pytest.raises(DeviceUnavailableError) as caught:
        DhdBackend()
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith("Force Dimension SDK library not found (tried libdhd.so, libdhd.so.3)")
    assert "~dhd/library" in message


def test_explicit_library_path_that_does_not_exist(tmp_path):
    with pytest.raises(DeviceUnavailableError, match=f"tried {tmp_path / 'libdhd.so.3'}"):
        load_dhd_library(str(tmp_path / "libdhd.so.3"))


def test_a_library_that_is_not_libdhd_is_named():
    libm = ctypes.util.find_library("m")
    with pytest.raises(DeviceUnavailableError, match="has no function dhdOpen: is it libdhd?"):
        load_dhd_library(libm)


@pytest.fixture(scope="module")
def fake_dhd(tmp_path_factory):
    """test/data/fake_dhd.c compiled into a shared library with the SDK's function names and signatures."""
    source = pathlib.Path(__file__).resolve().parents[1] / "data" / "fake_dhd.c"
    library = tmp_path_factory.mktemp("fake_dhd") / "libdhd.so"
    subprocess.run(["cc", "-shared", "-fPIC", "-o", str(library), str(source), "-lm"], check=True)
    return str(library)


def test_no_device_plugged_in_is_one_clear_line(fake_dhd, monkeypatch):
    monkeypatch.setenv("FAKE_DHD_DEVICES", "0")
    with pytest.raises(DeviceUnavailableError) as caught:
        DhdBackend(fake_dhd)
    assert str(caught.value) == "no Force Dimension device found: dhdOpen failed (no device found)"


def test_reads_position_frame_and_gripper_through_ctypes(fake_dhd, monkeypatch):
    monkeypatch.setenv("FAKE_DHD_DEVICES", "1")
    backend = DhdBackend(fake_dhd)
    sample = backend.read(0.0)
    np.testing.assert_allclose(sample.position, [0.01, 0.02, 0.03])
    np.testing.assert_allclose(Rotation.from_quat(sample.orientation).as_rotvec(), [0.0, 0.0, 0.5], atol=1e-12)
    assert sample.gripper == pytest.approx(0.3)
    assert sample.button is None  # teleteach's own click emulation
    backend.close()


def test_native_button(fake_dhd, monkeypatch):
    monkeypatch.setenv("FAKE_DHD_DEVICES", "1")
    backend = DhdBackend(fake_dhd, native_button=True)
    assert backend.read(0.0).button is True
    backend.close()


def test_read_failure_carries_the_sdk_error(fake_dhd, monkeypatch):
    monkeypatch.setenv("FAKE_DHD_DEVICES", "1")
    backend = DhdBackend(fake_dhd)
    monkeypatch.setenv("FAKE_DHD_FAIL_READS", "1")
    with pytest.raises(
        DeviceReadError,
        match="^dhdGetPositionAndOrientationFrame: communication error between the host and the device$",
    ):
        backend.read(0.0)
    monkeypatch.setenv("FAKE_DHD_FAIL_READS", "0")
    np.testing.assert_allclose(backend.read(0.0).position, [0.01, 0.02, 0.03])
    backend.close()


def received(library_path):
    """What the stand-in library received: the 7 force values, whether forces are on, and how many commands came."""
    library = ctypes.CDLL(str(library_path))  # the same loaded library as the backend's: its state is shared
    values, enabled = (ctypes.c_double * 7)(), ctypes.c_int()
    count = library.fakeDhdReceived(values, ctypes.byref(enabled))
    return list(values), bool(enabled.value), count


def test_guidance_forces_reach_the_sdk_bounded_and_end_at_zero(fake_dhd, monkeypatch):
    monkeypatch.setenv("FAKE_DHD_DEVICES", "1")
    backend = DhdBackend(fake_dhd)
    assert received(fake_dhd)[1] is True  # dhdEnableForce(DHD_ON) when opened
    renderer = GuidanceRenderer(GuidanceLimits.from_yaml())
    hold = AxisGuidance("hold", centre=0.0, stiffness=1e4)
    renderer.set(Guidance(axes=(hold, hold, hold, AxisGuidance(), AxisGuidance(), AxisGuidance()), max_force=50.0), 0.0)
    sample = backend.read(0.0)  # the stand-in sits at (0.01, 0.02, 0.03) m: the springs ask for far more than 4 N
    wrench = renderer.wrench(0.3, sample.position, sample.orientation, np.zeros(3), np.zeros(3), sample.gripper)
    backend.render(wrench)
    values, _, count = received(fake_dhd)
    # Expect the node's 4 N cap along the direction back to the centre, as the SDK received it
    np.testing.assert_allclose(values[:3], -4.0 * np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0))
    assert values[3:] == [0.0, 0.0, 0.0, 0.0] and count >= 1
    backend.close()
    values, enabled, _ = received(fake_dhd)
    assert values == [0.0] * 7 and enabled is False  # closing leaves no force and disables forces


def test_a_force_the_device_refuses_is_a_read_error(fake_dhd, monkeypatch):
    monkeypatch.setenv("FAKE_DHD_DEVICES", "1")
    backend = DhdBackend(fake_dhd)
    monkeypatch.setenv("FAKE_DHD_FAIL_READS", "1")
    with pytest.raises(DeviceReadError, match="^dhdSetForceAndTorqueAndGripperForce: communication error"):
        backend.render(Wrench.zero())
    monkeypatch.setenv("FAKE_DHD_FAIL_READS", "0")
    backend.close()
