"""Whether a window can open here, asked before Qt is: Qt aborts the process without a display it can reach.

Without it, Qt prints "could not connect to display", suggests reinstalling the application and aborts (exit -6), and
the rest of a launch runs on as if the operator had a window. Asking Xlib first gives one line that says what to do.
"""

import ctypes
import ctypes.util
import os


def display_problem() -> str:
    """Why no window can open on this machine's display ("" when one can: Wayland, or an X server that answers)."""
    if os.environ.get("WAYLAND_DISPLAY"):
        return ""
    display = os.environ.get("DISPLAY", "")
    if not display:
        return "no display: DISPLAY is not set (run it on a desktop, with ssh -X, or under xvfb-run; headless:=true)"
    library = ctypes.util.find_library("X11")
    if library is None:
        return ""  # no Xlib to ask: let Qt try
    xlib = ctypes.CDLL(library)
    xlib.XOpenDisplay.restype = ctypes.c_void_p
    xlib.XOpenDisplay.argtypes = [ctypes.c_char_p]
    xlib.XCloseDisplay.argtypes = [ctypes.c_void_p]
    handle = xlib.XOpenDisplay(display.encode())
    if not handle:
        return f"cannot open the display {display}: is its X server running, and may this user use it (xhost)?"
    xlib.XCloseDisplay(handle)
    return ""
