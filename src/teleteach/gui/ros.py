"""The window's own ROS side: the topics it publishes, its service calls off the GUI thread, the node's entry.

The tabs' topics are their adapters' (``gui/<tab>/ros.py``), the device's, the arm's and the tree's the worker's
(``gui/worker.py``); what the window itself says goes out here, stamped with ROS time.
"""

import threading

import rospy
from geometry_msgs.msg import PoseStamped
from PyQt5.QtCore import QObject, Qt, QTimer, pyqtSignal, pyqtSlot
from std_msgs.msg import Bool, Int8

from teleteach.core.active_tab import Tab
from teleteach.core.gui_config import GuiConfig
from teleteach.gui.guidance import guidance_fields
from teleteach.haptics.guidance import Guidance
from teleteach.msg import HapticGuidance, Selection
from teleteach.runtime.node import node_parameters, publish


class WindowTopics:
    """Every topic the window publishes itself, in one place (the worker sends the stiffness, the player the pose).

    The recording and shared-control flags start false, latched, so that a late subscriber knows.
    """

    def __init__(self):
        latched = {"queue_size": 1, "latch": True}
        self.active_tab = rospy.Publisher("teleteach/active_tab", Int8, **latched)
        self.pause = rospy.Publisher("behaviour_tree/pause", Bool, **latched)
        self.recording = rospy.Publisher("teleteach/recording", Bool, **latched)
        self.shared_control = rospy.Publisher("shared_control/enable", Bool, **latched)
        self.guidance = rospy.Publisher("sigma7/guidance", HapticGuidance, **latched)
        self.selection = rospy.Publisher("teleteach/selection", Selection, queue_size=20)
        self.equilibrium = rospy.Publisher("equilibrium_pose", PoseStamped, queue_size=10)
        publish(self.recording, Bool(False))
        publish(self.shared_control, Bool(False))

    def send_pause(self, paused: bool) -> None:
        """Pause or resume the tree (behaviour_tree/pause, latched)."""
        publish(self.pause, Bool(paused))

    def send_recording(self, recording: bool) -> None:
        """Say on teleteach/recording whether a tab records (latched)."""
        publish(self.recording, Bool(recording))

    def send_active_tab(self, index: int) -> None:
        """The tab now shown (teleteach/active_tab, latched)."""
        publish(self.active_tab, Int8(index))

    def send_selection(self, tab: Tab, step: str, choice: str) -> None:
        """A confirmed choice, for studies and bags (teleteach/Selection)."""
        message = Selection(tab=tab.name, step=step, choice=choice)
        message.header.stamp = rospy.Time.now()
        publish(self.selection, message)

    def send_guidance(self, guidance: Guidance) -> None:
        """What the device renders (teleteach/HapticGuidance)."""
        message = HapticGuidance(**guidance_fields(guidance))
        message.header.stamp = rospy.Time.now()
        publish(self.guidance, message)

    def close(self) -> None:
        """Publish no more: latched values of a closed window must not reach nodes that start later."""
        for publisher in vars(self).values():
            publisher.unregister()


class ServiceCaller(QObject):
    """Calls ROS services off the GUI thread; the answer (or the reason for failing) comes back as a signal.

    A call that has no answer after twice ``timeout`` (finding the service, then the call) is reported as failed at
    once; its thread is left to finish.
    """

    finished = pyqtSignal(str, bool, str, object)  # key, success, message, response
    _deliver = pyqtSignal(str, int, bool, str, object)  # from the calling thread to this object's thread

    def __init__(self, timeout: float):
        super().__init__()
        self.timeout = timeout
        self._pending = {}
        self._counter = 0
        self._deliver.connect(self._on_delivered, Qt.QueuedConnection)

    def call(self, key: str, service: str, service_class, request) -> None:
        """Start ``service(request)``; ``finished(key, ...)`` follows, from this object's thread."""
        self._counter += 1
        token = self._counter
        self._pending[key] = token
        threading.Thread(
            target=self._run, args=(key, token, service, service_class, request), daemon=True, name=f"call_{key}"
        ).start()
        # waiting for the service and the call itself may each take up to the timeout
        QTimer.singleShot(int(2 * self.timeout * 1000) + 200, lambda: self._expire(key, token, service))

    def busy(self, key: str) -> bool:
        """True while a call under ``key`` has neither answered nor timed out."""
        return key in self._pending

    def _expire(self, key: str, token: int, service: str) -> None:
        if self._pending.get(key) == token:
            del self._pending[key]
            self.finished.emit(key, False, f"{service}: no answer within {self.timeout:.1f} s", None)

    def _run(self, key, token, service, service_class, request) -> None:
        try:
            rospy.wait_for_service(service, timeout=self.timeout)
            response = rospy.ServiceProxy(service, service_class)(request)
            result = (True, "", response)
        except rospy.ROSException as error:
            result = (False, f"{service} is not available ({error})", None)
        except (rospy.ServiceException, OSError) as error:
            result = (False, f"{service} failed: {error}", None)
        self._deliver.emit(key, token, *result)

    @pyqtSlot(str, int, bool, str, object)
    def _on_delivered(self, key, token, success, message, response) -> None:
        if self._pending.get(key) != token:
            return
        del self._pending[key]
        self.finished.emit(key, success, message, response)


def log(text: str, warning: bool = False) -> None:
    """A line in the node's log (rosout)."""
    (rospy.logwarn if warning else rospy.loginfo)(text)


def gui_config() -> GuiConfig:
    """The GUI's parameters: ``config/gui.yaml``, each key overridden by the node's private parameter."""
    return GuiConfig.from_mapping(node_parameters("gui.yaml"))
