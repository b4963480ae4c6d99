"""The device monitor's summary: rpy from quaternions, counts, rates, ranges and click times."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from teleteach.core.rotations import quaternion_to_rpy
from teleteach.haptics.monitor import DeviceMonitor


@pytest.mark.parametrize("rpy", [(0.0, 0.0, 0.0), (0.5, -0.3, 0.9), (-1.0, 0.7, -0.2), (0.2, 1.2, 2.5)])
def test_quaternion_to_rpy_inverts_rz_ry_rx(rpy):
    quaternion = Rotation.from_euler("ZYX", rpy[::-1]).as_quat()  # intrinsic Z-Y-X = Rz(yaw) Ry(pitch) Rx(roll)
    np.testing.assert_allclose(quaternion_to_rpy(quaternion), rpy, atol=1e-12)


def test_summary_reports_counts_rates_ranges_and_clicks():
    monitor = DeviceMonitor(start_time=100.0)
    for index in range(1001):
        time = 100.0 + index * 0.001
        yaw = 0.5 * index / 1000
        monitor.on_pose(time, (0.05 * index / 1000, -0.01, 0.0), Rotation.from_euler("z", yaw).as_quat())
        monitor.on_twist(time, (0.05, 0.0, 0.0))
        monitor.on_gripper(time, 0.25)
        monitor.on_button(time, 300 <= index < 400 or 700 <= index < 800)
    summary = monitor.summary()
    assert "/sigma7/pose             1001 messages   1000.0 Hz" in summary
    assert "position x   +0.000 .. +0.050 m" in summary
    assert "yaw        +0.000 .. +0.500 rad" in summary
    assert "gripper    +0.250 .. +0.250 rad" in summary
    assert "clicks     2 at 0.300, 0.700 s after the scenario start" in summary
    assert monitor.click_times == pytest.approx([0.3, 0.7])


def test_summary_without_data():
    summary = DeviceMonitor().summary()
    assert "/sigma7/button              0 messages      0.0 Hz" in summary
    assert "position x   no data" in summary
    assert "clicks     0" in summary
