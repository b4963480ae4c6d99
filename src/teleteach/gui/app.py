"""The teaching GUI's main window (thesis Fig. 3, Appendix A): tabs, the worker thread and the ROS calls.

The window wires the worker's signals to the active tab, calls /change_tree, /behaviour_tree/add_skill and the
controller manager off the GUI thread (failures go to the status bar), pauses the tree while LOW-LEVEL teaching
runs, plays the kinematic trajectory while recording and turns a recording into a new skill. During a user study
(study/state, from ``rosrun teleteach study``) it shows the study's page instead of the tabs between trials
(teleteach.gui.study), and publishes every confirmed selection on teleteach/selection.
"""

import math
import sys
import time
from typing import Callable, List, Optional, Sequence, Tuple

from PyQt5.QtCore import QMetaObject, QPoint, Qt, QThread, QTimer
from PyQt5.QtGui import QPainter, QPixmap
from PyQt5.QtWidgets import QApplication, QLabel, QMainWindow, QStackedWidget, QTabWidget, QVBoxLayout, QWidget
from std_srvs.srv import Trigger, TriggerRequest

from teleteach.core.active_tab import Tab
from teleteach.core.datadir import data_dir
from teleteach.core.frames import Transform
from teleteach.core.gui_config import GuiConfig
from teleteach.core.study_phase import StudyView
from teleteach.core.trajectories import Trajectory
from teleteach.gui.arm_handover import ArmHandover
from teleteach.gui.ellipsoid import EllipsoidCommand
from teleteach.gui.guidance import GuidanceDesigner, HeldPose
from teleteach.gui.high_level import ros as high_level_tab
from teleteach.gui.low_level import ros as low_level_tab
from teleteach.gui.proposal import HelpRequestView
from teleteach.gui.recording import PathRecorder, StiffnessRecorder
from teleteach.gui.ros import ServiceCaller, WindowTopics, log
from teleteach.gui.session import Action, TeachingSession
from teleteach.gui.shared_control import ros as shared_control_tab
from teleteach.gui.start import ros as start_tab
from teleteach.gui.study import Page, StudyScreen
from teleteach.gui.study_page import StudyPage
from teleteach.gui.taught_skills import TaughtSkills
from teleteach.gui.teleop import ros as teleop_tab
from teleteach.gui.worker import DEVICE_LOST, RosWorker
from teleteach.haptics.guidance import Guidance
from teleteach.msg import TreeExecution
from teleteach.srv import StudyInput, StudyInputRequest

# The window's tabs in their order (teleteach.core.active_tab.Tab): each one package's build(window) (gui/adapter.py)
TABS = (start_tab.build, high_level_tab.build, low_level_tab.build, shared_control_tab.build, teleop_tab.build)
HELP_STYLE = "background: #d22828; color: white; font-size: 15pt; font-weight: bold; padding: 8px;"  # the robot asks
APPLIED_STYLE = "background: #e65100; color: white; font-size: 15pt; font-weight: bold; padding: 8px;"  # it acted


def _banner(style: str) -> QLabel:
    """A coloured line across the window, hidden until it has something to say; long texts wrap."""
    banner = QLabel()
    banner.setWordWrap(True)  # a long status must not widen the window beyond the screen
    banner.setStyleSheet(style)
    banner.hide()
    return banner


class MainWindow(QMainWindow):
    """START / HIGH-LEVEL / LOW-LEVEL / SHARED CONTROL / TELEOP tabs."""

    def __init__(self, config: GuiConfig, data_root=None):
        super().__init__()
        self.config = config
        self.data_root = data_dir(data_root)
        self.trajectory = Trajectory.load(config.trajectory)  # LOW-LEVEL's; a path taught in TELEOP replaces it
        self.path_recorder = PathRecorder()
        self.path_series: List[Trajectory] = []  # demonstrations of the path being taught, in its gap's frame
        self.command = EllipsoidCommand(config)
        self.recorder = StiffnessRecorder()
        self.shared_recorder = StiffnessRecorder()
        self.library_names: List[str] = []
        self.teaching_target: Optional[Tuple[str, Transform]] = None  # the gap the recording places at
        self.session = TeachingSession()
        self.study = StudyScreen(config)
        self._tab = -1
        self._guidance = GuidanceDesigner(config)
        self._held_pose = HeldPose()
        self._device_sample = None
        self._sent_guidance: Optional[Guidance] = None
        self._guidance_sent_at = -math.inf

        self.topics = WindowTopics()
        self.player = low_level_tab.TrajectoryPlayer(self.trajectory, config.player_rate, self.topics.equilibrium)
        self.services = ServiceCaller(config.service_timeout)
        self.services.finished.connect(self._on_service)
        self.skills = TaughtSkills(self, log)
        self.tabs = QTabWidget()
        self.parts = [build(self) for build in TABS]
        self.start_tab, self.high_level, self.low_level, self.shared_control, self.teleop = (
            part.widget for part in self.parts[: len(Tab)]
        )  # the tabs the window itself still talks to
        adapters = [part.adapter for part in self.parts if part.adapter is not None]
        self.worker = RosWorker(config, self.command, self.recorder, self.player.current, adapters=adapters)
        self.arm = ArmHandover(self)
        self._build_window()
        self._actions = self._session_actions()
        self._start_worker()
        self.tabs.setCurrentIndex(config.initial_tab)
        self._on_tab_changed(config.initial_tab)
        self._guidance_timer = QTimer(self)  # 20 Hz: a new step or mode is felt at once, the same one is refreshed
        self._guidance_timer.timeout.connect(self._send_guidance)
        self._guidance_timer.start(50)

    def _build_window(self) -> None:
        """The banners, the five tabs (or the study's page) and the status bar."""
        config = self.config
        self.setWindowTitle("teleteach: teleoperated teaching")
        self.resize(1180, 880)
        central = QWidget()
        column = QVBoxLayout(central)
        self.help_banner = _banner(HELP_STYLE)
        self._help_request = HelpRequestView("")
        self._veto_deadline = 0.0  # [s] time.monotonic() when the veto window of an applied proposal closes
        self._veto_countdown = QTimer(self)
        self._veto_countdown.timeout.connect(self._show_help)
        self.study_banner = _banner(
            "background: #1a237e; color: white; font-size: 14pt; font-weight: bold; padding: 6px;"
        )
        column.addWidget(self.study_banner)
        column.addWidget(self.help_banner)
        self._tab_widgets: List[QWidget] = []
        for part in self.parts:
            self.add_tab(part.widget, part.title)
        self.tabs.currentChanged.connect(self._on_tab_changed)
        self.tabs.setStyleSheet("QTabBar::tab { min-width: 170px; min-height: 28px; font-weight: bold; }")
        self.study_page = StudyPage(config.study_start_radius, config.device_range)
        self.pages = QStackedWidget()
        self.pages.addWidget(self.tabs)
        self.pages.addWidget(self.study_page)
        column.addWidget(self.pages)
        self.setCentralWidget(central)
        self.health_label = QLabel()
        self.statusBar().addPermanentWidget(self.health_label)
        self.tree_label = QLabel("tree: -")
        self.statusBar().addPermanentWidget(self.tree_label)

    def _start_worker(self) -> None:
        """The ROS worker in its own thread; its signals reach the window and the tabs in the GUI thread."""
        self.thread = QThread(self)
        self.thread.setObjectName("ros_worker")
        self.worker.moveToThread(self.thread)
        self.thread.started.connect(self.worker.start)
        queued = Qt.QueuedConnection
        self.worker.device_changed.connect(self._on_device, queued)
        self.worker.clicked.connect(self._on_click, queued)
        self.worker.gripper_opened.connect(self._on_gripper_opened, queued)
        self.worker.tree_received.connect(self.high_level.on_tree, queued)
        self.worker.library_received.connect(self._on_library, queued)
        self.worker.help_requested.connect(self._on_help, queued)
        self.worker.health.connect(self._on_health, queued)
        self.worker.study_state.connect(self._on_study_state, queued)
        self.worker.execution_changed.connect(self._on_execution, queued)
        self.thread.start()

    def _session_actions(self):
        """What each of the teaching session's actions (teleteach.gui.session) does here."""
        controllers = self.config.controller_names
        actions = {
            Action.PAUSE_TREE: lambda: self._pause_tree(True),
            Action.RESUME_TREE: lambda: self._pause_tree(False),
            Action.START_TREE: self._start_tree,
            Action.WAIT_FOR_ARM: self.arm.wait,
            Action.STOP_WAITING_FOR_ARM: self.arm.stop_waiting,
            Action.ANNOUNCE_HELP_ANSWERED: lambda: self.statusBar().showMessage(
                "help request answered: the tree resumes", 15000
            ),
            Action.IMPEDANCE_CONTROL: lambda: self.arm.switch(controllers.impedance, controllers.position),
            Action.POSITION_CONTROL: lambda: self.arm.switch(controllers.position, controllers.impedance),
        }
        for part in self.parts:
            actions.update(part.actions)
        return actions

    def add_tab(self, tab: QWidget, title: str) -> int:
        """Append a tab; returns its index.

        The tab needs an ``active`` attribute and an ``on_click(stamp)`` slot, ``on_device(sample)`` if it uses the
        device's position; only the active tab receives them.
        """
        self._tab_widgets.append(tab)
        return self.tabs.addTab(tab, title)

    # signals from the worker -----------------------------------------------------------------
    def _active_tab_widget(self):
        """The tab that was active when the signal arrived (a click that switches tabs must not act twice)."""
        return self._tab_widgets[self._tab] if 0 <= self._tab < len(self._tab_widgets) else None

    def _on_device(self, sample) -> None:
        self._device_sample = sample
        if self.study.page is Page.STUDY:
            self.study.on_device(sample)
            self.study_page.show_screen(self.study)
            return
        tab = self._active_tab_widget()
        if tab is not None and hasattr(tab, "on_device"):
            tab.on_device(sample)

    def _on_click(self, stamp: float) -> None:
        # the click comes at once, the position at device_ui_rate: act on where the device is now (a first click
        # may otherwise arrive before any position, and choose nothing)
        latest = self.worker.latest_sample()
        if latest is not None and latest is not self._device_sample:
            self._on_device(latest)
        if self.study.page is Page.STUDY:
            submission = self.study.on_click()
            if submission is not None:
                request = StudyInputRequest(submission.kind, list(submission.names), list(submission.values))
                self.services.call("study", "study/input", StudyInput, request)
            self.study_page.show_screen(self.study)
            return
        tab = self._active_tab_widget()
        if tab is not None:
            tab.on_click(stamp)

    def _on_gripper_opened(self) -> None:
        if self.study.page is Page.STUDY:
            return  # the study's page has no tabs to return from
        if self._tab != Tab.START:
            self.tabs.setCurrentIndex(Tab.START)

    def _on_library(self, library: Sequence) -> None:
        self.library_names = [skill.name for skill in library]
        self.high_level.on_library(library)

    def _on_help(self, help_request: HelpRequestView) -> None:
        """The robot asks (with its proposal preselected in HIGH-LEVEL), or applied its proposal, or was answered."""
        self.carry_out(self.session.help_requested(help_request.node_name))
        self.high_level.set_help(help_request)
        self._help_request = help_request
        self._veto_deadline = time.monotonic() + help_request.veto_left
        self.help_banner.setStyleSheet(APPLIED_STYLE if help_request.applied else HELP_STYLE)
        self._show_help()
        if help_request.veto_left > 0.0:
            self._veto_countdown.start(250)
        if help_request.applied:
            self.statusBar().showMessage(f"the robot applied its proposal for {help_request.node_name}", 30000)
        elif help_request.node_name:
            self.statusBar().showMessage(f"help requested by {help_request.node_name}: {help_request.reason}", 30000)

    def _show_help(self) -> None:
        """The banner with what is left of the veto window now (the countdown stops at its end)."""
        left = max(0.0, self._veto_deadline - time.monotonic())
        if left == 0.0:
            self._veto_countdown.stop()
        text = self._help_request.banner(left)
        self.help_banner.setText(text)
        self.help_banner.setVisible(bool(text))

    # user study ---------------------------------------------------------------------------------------
    def _on_study_state(self, status: StudyView) -> None:
        """The study's page between trials, the tabs with a banner while one runs."""
        self.study.on_status(status)
        study_page = self.study.page is Page.STUDY
        self.pages.setCurrentWidget(self.study_page if study_page else self.tabs)
        if study_page:
            self.study_page.show_screen(self.study)
        banner = self.study.banner()
        self.study_banner.setText(banner)
        self.study_banner.setVisible(bool(banner))

    def _on_execution(self, state: int, message: str) -> None:
        """The tree's execution (teleteach/TreeExecution): START and the status bar show it."""
        waiting, done = state == TreeExecution.WAITING, state == TreeExecution.COMPLETED
        self.carry_out(self.session.tree_state_changed(waiting, done))
        self.start_tab.show_tree(waiting, message, done)
        self.tree_label.setText(f"tree: {message}")
        self.tree_label.setStyleSheet("color: #bf360c; font-weight: bold;" if waiting else "")

    def _start_tree(self) -> None:
        """The start gesture: a tree that started paused, or is done, runs (behaviour_tree/start: an event)."""
        self.services.call("start_tree", "behaviour_tree/start", Trigger, TriggerRequest())
        self.topics.send_selection(Tab.START, "start", "tree")
        self.statusBar().showMessage("starting the tree...", 10000)

    def _on_health(self, problems: str) -> None:
        self.health_label.setText(problems)
        self.health_label.setStyleSheet("color: #d22828;" if problems else "")
        for part in self.parts:
            if hasattr(part.widget, "show_device_lost"):
                part.widget.show_device_lost(DEVICE_LOST in problems)

    # haptic guidance ----------------------------------------------------------------------------------
    def current_guidance(self) -> Guidance:
        """What the device should render for the current tab, step and mode (teleteach.gui.guidance)."""
        if self.study.page is Page.STUDY:
            return self._guidance.free()  # the study's own page: the same feel in every condition
        if self._tab == Tab.START:
            return self._guidance.start()
        if self._tab == Tab.HIGH_LEVEL:
            return self._guidance.high_level(self.high_level.flow)
        if self._tab == Tab.LOW_LEVEL:
            mode = self.command.mode
            return self._guidance.low_level(mode, self._held_pose.at((Tab.LOW_LEVEL, mode), self._device_sample))
        return self._guidance.free()

    def _send_guidance(self) -> None:
        """Publish the guidance when it changed, and again every ``guidance_refresh`` (the device drops stale ones)."""
        guidance = self.current_guidance()
        now = time.monotonic()
        if guidance == self._sent_guidance and now - self._guidance_sent_at < self.config.guidance_refresh:
            return
        self.topics.send_guidance(guidance)
        self._sent_guidance, self._guidance_sent_at = guidance, now

    # tabs -----------------------------------------------------------------------------------------
    def _on_tab_changed(self, index: int) -> None:
        if index == self._tab:
            return
        self._tab = index
        self.worker.reset_device_filter()
        for position, tab in enumerate(self._tab_widgets):
            tab.active = position == index
        self.topics.send_active_tab(index)
        self.carry_out(self.session.tab_changed(index))
        # The worker hears the new tab last: a pose arriving while LOW-LEVEL opens must find the ellipsoid already
        # held, or it would set it to wherever the handle is (the soft takeover bypassed)
        self.worker.active_tab = index

    def carry_out(self, actions) -> None:
        """Do what the teaching session says (teleteach.gui.session), in its order."""
        for action in actions:
            self._actions[action]()

    def _pause_tree(self, paused: bool) -> None:
        self.topics.send_pause(paused)

    # service answers ------------------------------------------------------------------------------
    def _on_service(self, key: str, success: bool, message: str, response) -> None:
        if key == "change_tree":
            if success:
                text = response.message + (f" (new node {response.new_node_name})" if response.new_node_name else "")
                self.high_level.on_answer(response.success, text)
            else:
                self.high_level.on_answer(False, message)
                self.statusBar().showMessage(message, 15000)
        elif key == "start_tree":
            if success:
                self.statusBar().showMessage(f"the tree: {response.message}", 10000)
            else:
                self.statusBar().showMessage(f"the tree was not started: {message}", 15000)
        elif key == "study":
            self.study.answered(success and response.success, message if not success else response.message)
            if self.study.page is Page.STUDY:
                self.study_page.show_screen(self.study)

    def screenshot(self) -> QPixmap:
        """The window as the operator sees it (``grab()`` misses the text the GL view paints over its views)."""
        pixmap = self.grab()
        view = self.low_level.view
        if view.isVisible():
            painter = QPainter(pixmap)
            painter.drawImage(view.mapTo(self, QPoint(0, 0)), view.grabFramebuffer())
            painter.end()
        return pixmap

    # shutdown -------------------------------------------------------------------------------------
    def closeEvent(self, event) -> None:  # noqa: N802 - Qt's name
        """Save a running recording, give the robot back, stop the worker cooperatively."""
        self.shutdown()
        super().closeEvent(event)

    def shutdown(self) -> None:
        """Idempotent: what closing the window does.

        The device is left without guidance (no force), the window's topics end, a DMP being learned is waited for.
        """
        if self.thread.isRunning():
            self._guidance_timer.stop()
            self.topics.send_guidance(self._guidance.free())
            self.carry_out(self.session.shutdown())
            self.player.stop()
            QMetaObject.invokeMethod(self.worker, "stop", Qt.BlockingQueuedConnection)
            self.thread.quit()
            self.thread.wait(3000)
            self.topics.close()
        self.skills.finish_learning()


def run(config: GuiConfig, stopped: Callable[[], bool]) -> int:
    """The window of ``config`` in Qt's loop, closed once ``stopped()`` (the node's shutdown); its exit status."""
    app = QApplication.instance() or QApplication(list(sys.argv[:1]))
    window = MainWindow(config, data_root=config.data_dir)
    window.show()
    watchdog = QTimer()
    watchdog.timeout.connect(lambda: stopped() and window.close())
    watchdog.start(200)  # also lets Python run its SIGINT handler while Qt waits
    app.aboutToQuit.connect(window.shutdown)
    return app.exec_()
