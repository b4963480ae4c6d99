"""Handing the arm over between the tree's position controller and the impedance controller the teaching tabs need.

Entering a teaching tab waits (bounded) until the tree's skill has stopped and the arm rests, then switches the
controllers through the controller manager, off the GUI thread; what the arm's controller does is shown in the tabs
that command it, a failure in the status bar too.
"""

import math
import time

from PyQt5.QtCore import QObject, QTimer

from teleteach.core.gui_config import GuiConfig
from teleteach.srv import SwitchController, SwitchControllerRequest

SWITCH_SERVICE = "controller_manager/switch_controller"


class ArmHandover(QObject):
    """The session's WAIT_FOR_ARM, STOP_WAITING_FOR_ARM, IMPEDANCE_CONTROL and POSITION_CONTROL (gui/session.py).

    Whether the arm may be taken now, and why not, is the worker's (``arm_free``); the answer goes back to the
    session; LOW-LEVEL and TELEOP show the controller (their ``controller_label``), the status bar a failure.
    """

    def __init__(self, window):
        super().__init__(window)
        self.window = window
        self.config: GuiConfig = window.config
        self.services = window.services
        self._deadline = math.inf
        self._timer = QTimer(self)  # while a session waits for the arm to be free
        self._timer.timeout.connect(self._check)
        self.services.finished.connect(self._on_switched)

    def _status(self, text: str, milliseconds: int) -> None:
        self.window.statusBar().showMessage(text, milliseconds)

    def wait(self) -> None:
        """Hand the arm to the impedance controller once the tree's skill stopped and the arm rests (bounded)."""
        self._deadline = time.monotonic() + self.config.arm_free_timeout
        self.show("waiting for the arm to be free...")
        self._timer.start(100)
        self._check()

    def stop_waiting(self) -> None:
        """The session left the tab before the arm was free: no handover."""
        self._timer.stop()
        self.show("-")

    def _check(self) -> None:
        if not self._timer.isActive():
            return
        window = self.window
        free, why = window.worker.arm_free()
        if free:
            self._timer.stop()
            window.carry_out(window.session.arm_freed())
        elif time.monotonic() > self._deadline:
            self._timer.stop()
            window.carry_out(window.session.arm_not_freed())
            text = (
                f"the arm was not free within {self.config.arm_free_timeout:g} s ({why}): the impedance controller was"
                " not started; go back to START and enter again"
            )
            self.show(text)
            self._status(text, 30000)
        else:
            self.show(f"waiting for the arm: {why}")

    def show(self, text: str) -> None:
        """What the arm's controller does, in the teaching tabs that show it."""
        for tab in (self.window.low_level, self.window.teleop):
            tab.controller_label.setText(f"controller: {text}")

    def switch(self, start: str, stop: str) -> None:
        """Start controller ``start`` and stop ``stop`` (the answer is shown when it comes)."""
        self.show(f"switching to {start}...")
        request = SwitchControllerRequest(
            start_controllers=[start],
            stop_controllers=[stop],
            strictness=SwitchControllerRequest.STRICT,
            start_asap=False,
            timeout=0.0,
        )
        self.services.call("switch:" + start, SWITCH_SERVICE, SwitchController, request)

    def _on_switched(self, key: str, success: bool, message: str, response) -> None:
        if not key.startswith("switch:"):
            return
        controller = key.split(":", 1)[1]
        if success and response.ok:
            self.show(f"{controller} active")
        else:
            reason = message or "the controller manager refused the switch"
            self.show(f"switch to {controller} failed")
            self._status(f"switch to {controller} failed: {reason}", 15000)
