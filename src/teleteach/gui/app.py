"""The teaching GUI's main window (thesis Fig. 3, Appendix A): tabs, the worker thread and the ROS calls.

The window wires the worker's signals to the active tab, calls /change_tree, /behaviour_tree/add_skill and the
controller manager off the GUI thread (failures go to the status bar), pauses the tree while LOW-LEVEL teaching
runs, plays the kinematic trajectory while recording and turns a recording into a new skill. During a user study
(study/state, from ``rosrun teleteach study``) it shows the study's page instead of the tabs between trials
(teleteach.gui.study), and publishes every confirmed selection on teleteach/selection.
"""

import math
import pathlib
import sys
import time
from typing import List, Optional, Sequence, Tuple

import rospy
from geometry_msgs.msg import PoseStamped
from PyQt5.QtCore import QMetaObject, QPoint, QProcess, Qt, QThread, QTimer
from PyQt5.QtGui import QPainter, QPixmap
from PyQt5.QtWidgets import QApplication, QLabel, QMainWindow, QStackedWidget, QTabWidget, QVBoxLayout, QWidget
from std_msgs.msg import Bool, Int8
from std_srvs.srv import Trigger, TriggerRequest

from teleteach.core import skill_file
from teleteach.core.active_tab import Tab
from teleteach.core.datadir import data_dir
from teleteach.core.frames import Transform
from teleteach.core.gui_config import GuiConfig, GuiConfigError
from teleteach.core.study_phase import StudyView
from teleteach.core.trajectories import Trajectory
from teleteach.gui.ellipsoid import EllipsoidCommand
from teleteach.gui.guidance import GuidanceDesigner, HeldPose, guidance_fields
from teleteach.gui.high_level import ros as high_level_tab
from teleteach.gui.low_level import ros as low_level_tab
from teleteach.gui.recording import PathRecorder, StiffnessRecorder, unique_skill_name
from teleteach.gui.selection import REPAIR_CHOICE
from teleteach.gui.session import Action, TeachingSession
from teleteach.gui.shared_control import ros as shared_control_tab
from teleteach.gui.start import ros as start_tab
from teleteach.gui.study import Page, StudyScreen
from teleteach.gui.study_page import StudyPage
from teleteach.gui.teleop import ros as teleop_tab
from teleteach.gui.worker import DEVICE_LOST, RosWorker, ServiceCaller
from teleteach.haptics.guidance import Guidance
from teleteach.msg import HapticGuidance, Selection, TreeExecution
from teleteach.runtime.node import publish
from teleteach.srv import (
    AddSkill,
    AddSkillRequest,
    StudyInput,
    StudyInputRequest,
    SwitchController,
    SwitchControllerRequest,
)

SWITCH_SERVICE = "controller_manager/switch_controller"
# The window's tabs in their order (teleteach.core.active_tab.Tab): each one package's build(window) (gui/adapter.py)
TABS = (start_tab.build, high_level_tab.build, low_level_tab.build, shared_control_tab.build, teleop_tab.build)
LEARNING_GRACE_MS = 60000  # a DMP being learned as the window closes gets this long to join the library


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

    def close(self) -> None:
        """Publish no more: latched values of a closed window must not reach nodes that start later."""
        for publisher in vars(self).values():
            publisher.unregister()


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
        self.skills_dir = self.data_root / "skills"
        self.trajectory = Trajectory.load(config.trajectory)  # LOW-LEVEL's; a path taught in TELEOP replaces it
        self.path_recorder = PathRecorder()
        self.path_series: List[Trajectory] = []  # demonstrations of the path being taught, in its gap's frame
        self._learning: Optional[QProcess] = None  # learn_skill turning a taught path's stiffness into a DMP skill
        self.command = EllipsoidCommand(config)
        self.recorder = StiffnessRecorder()
        self.shared_recorder = StiffnessRecorder()
        self.library_names: List[str] = []
        self.saved_skills: List[str] = []
        self.teaching_target: Optional[Tuple[str, Transform]] = None  # the gap the recording places at
        self.session = TeachingSession()
        self.study = StudyScreen(config)
        self._tab = -1
        self._guidance = GuidanceDesigner(config)
        self._held_pose = HeldPose()
        self._device_sample = None
        self._sent_guidance: Optional[Guidance] = None
        self._guidance_sent_at = -math.inf
        self._arm_deadline = math.inf
        self._arm_timer = QTimer(self)  # while a session waits for the arm to be free
        self._arm_timer.timeout.connect(self._check_arm)

        self.topics = WindowTopics()
        self.player = low_level_tab.TrajectoryPlayer(self.trajectory, config.player_rate, self.topics.equilibrium)
        self.services = ServiceCaller(config.service_timeout)
        self.services.finished.connect(self._on_service)
        self.tabs = QTabWidget()
        self.parts = [build(self) for build in TABS]
        self.start_tab, self.high_level, self.low_level, self.shared_control, self.teleop = (
            part.widget for part in self.parts[: len(Tab)]
        )  # the tabs the window itself still talks to
        adapters = [part.adapter for part in self.parts if part.adapter is not None]
        self.worker = RosWorker(config, self.command, self.recorder, self.player.current, adapters=adapters)
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
        self.help_banner = _banner(
            "background: #d22828; color: white; font-size: 15pt; font-weight: bold; padding: 8px;"
        )
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
            Action.WAIT_FOR_ARM: self._wait_for_arm,
            Action.STOP_WAITING_FOR_ARM: self._stop_waiting_for_arm,
            Action.ANNOUNCE_HELP_ANSWERED: lambda: self.statusBar().showMessage(
                "help request answered: the tree resumes", 15000
            ),
            Action.IMPEDANCE_CONTROL: lambda: self._switch(controllers.impedance, controllers.position),
            Action.POSITION_CONTROL: lambda: self._switch(controllers.position, controllers.impedance),
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

    def _on_help(self, node_name: str, reason: str, suggestion: Sequence[str] = ()) -> None:
        self.carry_out(self.session.help_requested(node_name))
        self.high_level.set_repair(node_name, suggestion)
        if not node_name:  # the tree clears its request with an empty node name once answered
            self.help_banner.hide()
            return
        text = f"The robot asks for help: {node_name} failed ({reason}). Change the tree."
        if suggestion:
            text += f" Last time: {'; '.join(suggestion)}. HIGH-LEVEL: select \u201c{REPAIR_CHOICE}\u201d and click."
        self.help_banner.setText(text)
        self.help_banner.show()
        self.statusBar().showMessage(f"help requested by {node_name}: {reason}", 30000)

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
        self.publish_selection(Tab.START, "start", "tree")
        self.statusBar().showMessage("starting the tree...", 10000)

    def publish_selection(self, tab: Tab, step: str, choice: str) -> None:
        """A confirmed choice, for studies and bags (teleteach/Selection)."""
        message = Selection(tab=tab.name, step=step, choice=choice)
        message.header.stamp = rospy.Time.now()
        publish(self.topics.selection, message)

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
        message = HapticGuidance(**guidance_fields(guidance))
        message.header.stamp = rospy.Time.now()
        publish(self.topics.guidance, message)
        self._sent_guidance, self._guidance_sent_at = guidance, now

    # tabs -----------------------------------------------------------------------------------------
    def _on_tab_changed(self, index: int) -> None:
        if index == self._tab:
            return
        self._tab = index
        self.worker.reset_device_filter()
        for position, tab in enumerate(self._tab_widgets):
            tab.active = position == index
        publish(self.topics.active_tab, Int8(index))
        self.carry_out(self.session.tab_changed(index))
        # The worker hears the new tab last: a pose arriving while LOW-LEVEL opens must find the ellipsoid already
        # held, or it would set it to wherever the handle is (the soft takeover bypassed)
        self.worker.active_tab = index

    def set_recording(self, recording: bool) -> None:
        """Say on teleteach/recording whether a tab records (latched)."""
        publish(self.topics.recording, Bool(recording))

    def carry_out(self, actions) -> None:
        """Do what the teaching session says (teleteach.gui.session), in its order."""
        for action in actions:
            self._actions[action]()

    # LOW-LEVEL ------------------------------------------------------------------------------------
    def _wait_for_arm(self) -> None:
        """Hand the arm to the impedance controller once the tree's skill stopped and the arm rests (bounded)."""
        self._arm_deadline = time.monotonic() + self.config.arm_free_timeout
        self._show_controller("waiting for the arm to be free...")
        self._arm_timer.start(100)
        self._check_arm()

    def _stop_waiting_for_arm(self) -> None:
        self._arm_timer.stop()
        self._show_controller("-")

    def _check_arm(self) -> None:
        if not self._arm_timer.isActive():
            return
        free, why = self.worker.arm_free()
        if free:
            self._arm_timer.stop()
            self.carry_out(self.session.arm_freed())
        elif time.monotonic() > self._arm_deadline:
            self._arm_timer.stop()
            self.carry_out(self.session.arm_not_freed())
            text = (
                f"the arm was not free within {self.config.arm_free_timeout:g} s ({why}): the impedance controller was"
                " not started; go back to START and enter again"
            )
            self._show_controller(text)
            self.statusBar().showMessage(text, 30000)
        else:
            self._show_controller(f"waiting for the arm: {why}")

    def _show_controller(self, text: str) -> None:
        """What the arm's controller does, in the teaching tabs that show it."""
        for tab in (self.low_level, self.teleop):
            tab.controller_label.setText(f"controller: {text}")

    def _switch(self, start: str, stop: str) -> None:
        self._show_controller(f"switching to {start}...")
        request = SwitchControllerRequest(
            start_controllers=[start],
            stop_controllers=[stop],
            strictness=SwitchControllerRequest.STRICT,
            start_asap=False,
            timeout=0.0,
        )
        self.services.call("switch:" + start, SWITCH_SERVICE, SwitchController, request)

    def _pause_tree(self, paused: bool) -> None:
        publish(self.topics.pause, Bool(paused))

    def save_recording(
        self,
        recorder: StiffnessRecorder,
        kind: str,
        prefix: str,
        provenance: dict,
        target: Optional[Tuple[str, Transform]] = None,
        add: bool = True,
    ) -> Optional[pathlib.Path]:
        """A stopped recording -> skill file in data_dir()/skills (-> /behaviour_tree/add_skill).

        Returns the file, or None when it was not saved (the status bar says why).
        """
        name = unique_skill_name(prefix, self.library_names + self.saved_skills, self.skills_dir)
        try:
            skill = recorder.to_skill(
                name,
                self.config.rotational_stiffness,
                {"source": "teaching_gui", "recorded": time.time(), **provenance},
                kind=kind,
            )
            if target is not None:
                skill = skill.relative_to(*target)
            path = skill_file.save(skill, self.skills_dir / name)
        except skill_file.SkillFileError as error:
            hint = "" if len(recorder) >= 2 else " (no /cartesian_pose received? is robot_sim running?)"
            self.statusBar().showMessage(f"recording not saved: {error}{hint}", 15000)
            return None
        self.saved_skills.append(name)
        self.statusBar().showMessage(f"saved {name} ({len(skill.time)} samples) to {path}", 10000)
        if add:
            self.services.call(
                f"add_skill:{name}", "behaviour_tree/add_skill", AddSkill, AddSkillRequest(name, kind, str(path))
            )
        return path

    def learn_dmp(self, stiffness_skill: pathlib.Path) -> None:
        """learn_skill in the background: the DMP of a stiffness taught along a taught path joins the library."""
        if self._learning is not None and self._learning.state() != QProcess.NotRunning:
            name = stiffness_skill.stem  # one learning at a time: this demonstration joins the library as it is
            request = AddSkillRequest(name, "stiffness", str(stiffness_skill))
            self.services.call(f"add_skill:{name}", "behaviour_tree/add_skill", AddSkill, request)
            self.statusBar().showMessage(f"still learning the previous skill: {name} joins as a stiffness skill", 15000)
            return
        process = QProcess(self)
        process.setProcessChannelMode(QProcess.MergedChannels)
        name = f"{stiffness_skill.stem}_dmp"
        arguments = ["teleteach", "learn_skill", str(stiffness_skill), "--name", name, "--add"]
        process.finished.connect(lambda code, _status: self._on_learned(process, name, code))
        process.start("rosrun", [*arguments, "--data-dir", str(self.data_root)])
        self._learning = process
        self.statusBar().showMessage(f"learning {name} (a DMP skill) from {stiffness_skill.name}...", 15000)

    def _on_learned(self, process: QProcess, name: str, code: int) -> None:
        lines = bytes(process.readAll()).decode(errors="replace").strip().splitlines()
        last = lines[-1] if lines else "no output"
        text = f"{name} is in the skill library: {last}" if code == 0 else f"{name} was not learned: {last}"
        self.teleop.show_path(text, False)
        self.statusBar().showMessage(text, 30000)

    # service answers ------------------------------------------------------------------------------
    def _on_service(self, key: str, success: bool, message: str, response) -> None:
        if key == "change_tree":
            if success:
                text = response.message + (f" (new node {response.new_node_name})" if response.new_node_name else "")
                self.high_level.on_answer(response.success, text)
            else:
                self.high_level.on_answer(False, message)
                self.statusBar().showMessage(message, 15000)
        elif key.startswith("switch:"):
            controller = key.split(":", 1)[1]
            if success and response.ok:
                self._show_controller(f"{controller} active")
            else:
                reason = message or "the controller manager refused the switch"
                self._show_controller(f"switch to {controller} failed")
                self.statusBar().showMessage(f"switch to {controller} failed: {reason}", 15000)
        elif key == "start_tree":
            if success:
                self.statusBar().showMessage(f"the tree: {response.message}", 10000)
            else:
                self.statusBar().showMessage(f"the tree was not started: {message}", 15000)
        elif key == "study":
            self.study.answered(success and response.success, message if not success else response.message)
            if self.study.page is Page.STUDY:
                self.study_page.show_screen(self.study)
        elif key.startswith("add_skill:"):
            name = key.split(":", 1)[1]
            if success and response.success:
                text = f"{name} is in the skill library: a new button in HIGH-LEVEL"
            else:
                text = f"{name} was not added to the skill library: {response.message if success else message}"
            self.statusBar().showMessage(text, 15000)

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
            publish(self.topics.guidance, HapticGuidance(**guidance_fields(self._guidance.free())))
            self.carry_out(self.session.shutdown())
            self.player.stop()
            QMetaObject.invokeMethod(self.worker, "stop", Qt.BlockingQueuedConnection)
            self.thread.quit()
            self.thread.wait(3000)
            self.topics.close()
        self._finish_learning()

    def _finish_learning(self) -> None:
        """A DMP still being learned is learned to the end, not lost: Qt would kill its process with the window."""
        process = self._learning
        if process is None or process.state() == QProcess.NotRunning:
            return
        process.finished.disconnect()  # its answer has no window left to be shown in
        rospy.loginfo("waiting up to %.0f s for learn_skill to finish the DMP it learns", LEARNING_GRACE_MS / 1000)
        if process.waitForFinished(LEARNING_GRACE_MS):
            output = bytes(process.readAll()).decode(errors="replace").strip().splitlines()
            rospy.loginfo(output[-1] if output else f"learn_skill ended with exit status {process.exitCode()}")
        else:
            process.kill()
            process.waitForFinished(1000)
            rospy.logwarn("learn_skill did not finish in %.0f s and was stopped", LEARNING_GRACE_MS / 1000)


def run() -> int:
    """The node after rospy.init_node: params (``config/gui.yaml`` overridden by the private ones) -> window -> Qt loop.

    A bad parameter ends it with one line (exit status 2).
    """
    parameters = dict(rospy.get_param("~", {}))
    data_root = parameters.pop("data_dir", None)  # the launch's data directory (auto: $TELETEACH_DATA or the default)
    try:
        config = GuiConfig.load(**parameters)
    except GuiConfigError as error:
        rospy.logfatal(f"teaching_gui cannot start: {error}")
        return 2
    app = QApplication.instance() or QApplication(list(sys.argv[:1]))
    window = MainWindow(config, data_root=data_root)
    window.show()
    watchdog = QTimer()
    watchdog.timeout.connect(lambda: rospy.is_shutdown() and window.close())
    watchdog.start(200)  # also lets Python run its SIGINT handler while Qt waits
    app.aboutToQuit.connect(window.shutdown)
    return app.exec_()
