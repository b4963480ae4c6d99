"""The real Sigma.7 through the Force Dimension SDK (``libdhd``), loaded with ctypes (the ``dhd`` backend).

Only the SDK's C API is used (``dhdc.h``): dhdOpen, dhdGetPositionAndOrientationFrame, dhdGetGripperAngleRad,
dhdEmulateButton, dhdGetButton, dhdEnableForce, dhdSetForceAndTorqueAndGripperForce, dhdErrorGetLastStr, dhdClose.
Every function takes the device ID last.
"""

import ctypes
import ctypes.util
from typing import Optional, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.haptics.device import DeviceBackend, DeviceReadError, DeviceSample, DeviceUnavailableError
from teleteach.haptics.guidance import Wrench

# Names the SDK's library goes by: the development link and the sonames of SDK 3.x releases.
DHD_LIBRARY_NAMES = ("libdhd.so", "libdhd.so.3")
DHD_ON = 1
DHD_OFF = 0


def load_dhd_library(path: str = "", names: Sequence[str] = DHD_LIBRARY_NAMES) -> ctypes.CDLL:
    """Loads ``libdhd`` from ``path`` or from the usual names on the library search path.

    Raises:
        DeviceUnavailableError: no library could be loaded; the message lists what was tried.
    """
    candidates = [path] if path else [*names, ctypes.util.find_library("dhd")]
    tried = []
    for candidate in candidates:
        if not candidate or candidate in tried:
            continue
        tried.append(candidate)
        try:
            library = ctypes.CDLL(candidate)
        except OSError:
            continue
        _declare_signatures(library)
        return library
    raise DeviceUnavailableError(
        f"Force Dimension SDK library not found (tried {', '.join(tried)}): install the SDK and put its lib folder "
        f"on LD_LIBRARY_PATH, or set the node's ~dhd/library param to the library's path"
    )


def _declare_signatures(library: ctypes.CDLL) -> None:
    double_pointer = ctypes.POINTER(ctypes.c_double)
    device_id = ctypes.c_byte
    signatures = {
        "dhdOpen": ([], ctypes.c_int),
        "dhdClose": ([device_id], ctypes.c_int),
        "dhdGetPositionAndOrientationFrame": (
            [double_pointer, double_pointer, double_pointer, ctypes.POINTER(ctypes.c_double * 9), device_id],
            ctypes.c_int,
        ),
        "dhdGetGripperAngleRad": ([double_pointer, device_id], ctypes.c_int),
        "dhdEmulateButton": ([ctypes.c_ubyte, device_id], ctypes.c_int),
        "dhdGetButton": ([ctypes.c_int, device_id], ctypes.c_int),
        "dhdEnableForce": ([ctypes.c_ubyte, device_id], ctypes.c_int),
        "dhdSetForceAndTorqueAndGripperForce": ([ctypes.c_double] * 7 + [device_id], ctypes.c_int),
        "dhdErrorGetLastStr": ([], ctypes.c_char_p),
    }
    for name, (arguments, result) in signatures.items():
        try:
            function = getattr(library, name)
        except AttributeError:
            raise DeviceUnavailableError(
                f"the loaded Force Dimension library {library._name} has no function {name}: is it libdhd?"
            ) from None
        function.argtypes = arguments
        function.restype = result


class DhdBackend(DeviceBackend):
    """A Sigma.7 (or any DHD device with a gripper) opened through the SDK.

    Args:
        library_path: explicit path of libdhd; empty = the usual names on the search path.
        native_button: let the SDK emulate the button from the gripper (dhdEmulateButton) and report it
            (dhdGetButton); False = teleteach's own click emulation, the same as the other backends.

    Raises:
        DeviceUnavailableError: the library or the device is missing.
    """

    moves_on_wall_clock = True  # the operator's hand moves it in real time, whatever clock ROS runs on

    def __init__(self, library_path: str = "", native_button: bool = False) -> None:
        self._dhd = load_dhd_library(library_path)
        self._id = self._dhd.dhdOpen()
        if self._id < 0:
            raise DeviceUnavailableError(f"no Force Dimension device found: dhdOpen failed ({self._last_error()})")
        self._native_button = native_button
        if native_button and self._dhd.dhdEmulateButton(DHD_ON, self._id) < 0:
            error = self._last_error()
            self.close()
            raise DeviceUnavailableError(f"the device does not support button emulation: {error}")
        if self._dhd.dhdEnableForce(DHD_ON, self._id) < 0:
            error = self._last_error()
            self.close()
            raise DeviceUnavailableError(f"the device does not accept forces (dhdEnableForce): {error}")
        self._x, self._y, self._z = ctypes.c_double(), ctypes.c_double(), ctypes.c_double()
        self._frame = (ctypes.c_double * 9)()
        self._gripper = ctypes.c_double()

    def _last_error(self) -> str:
        message: Optional[bytes] = self._dhd.dhdErrorGetLastStr()
        return message.decode(errors="replace") if message else "no error message"

    def read(self, time: float) -> DeviceSample:
        """Reads position, orientation frame, gripper angle (and the native button) from the device now."""
        status = self._dhd.dhdGetPositionAndOrientationFrame(
            ctypes.byref(self._x), ctypes.byref(self._y), ctypes.byref(self._z), ctypes.byref(self._frame), self._id
        )
        if status < 0:  # DHD_TIMEGUARD (1, "read too soon, cached value returned") is not an error
            raise DeviceReadError(f"dhdGetPositionAndOrientationFrame: {self._last_error()}")
        if self._dhd.dhdGetGripperAngleRad(ctypes.byref(self._gripper), self._id) < 0:
            raise DeviceReadError(f"dhdGetGripperAngleRad: {self._last_error()}")
        button = None
        if self._native_button:
            state = self._dhd.dhdGetButton(0, self._id)
            if state < 0:
                raise DeviceReadError(f"dhdGetButton: {self._last_error()}")
            button = state == DHD_ON
        rotation = Rotation.from_matrix(np.array(self._frame).reshape(3, 3))
        return DeviceSample(
            position=np.array([self._x.value, self._y.value, self._z.value]),
            orientation=rotation.as_quat(),
            gripper=self._gripper.value,
            button=button,
        )

    def render(self, wrench: Wrench) -> None:
        """Sends force, torque and gripper force (dhdSetForceAndTorqueAndGripperForce)."""
        force, torque = wrench.force, wrench.torque
        values = (*map(float, force), *map(float, torque), float(wrench.gripper))
        if self._dhd.dhdSetForceAndTorqueAndGripperForce(*values, self._id) < 0:
            raise DeviceReadError(f"dhdSetForceAndTorqueAndGripperForce: {self._last_error()}")

    def close(self) -> None:
        """Leaves the device without force, then closes the connection to it."""
        if self._id >= 0:
            self._dhd.dhdSetForceAndTorqueAndGripperForce(*([0.0] * 7), self._id)
            self._dhd.dhdEnableForce(DHD_OFF, self._id)
            self._dhd.dhdClose(self._id)
            self._id = -1
