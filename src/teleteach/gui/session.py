"""The teaching session as a state machine without Qt: what the GUI does on tab changes, recordings and help requests.

Events in (tab changes, recording toggles, the arm freed, help requests, the tree's state, shutdown), :class:`Action`
lists out, in the order the window must carry them out. The window only wires the events to this machine and the
actions to the widgets, the recorders and the ROS calls, so every rule below is tested without a display
(test/unit/test_gui_session.py):

- LOW-LEVEL, SHARED CONTROL and TELEOP are teaching tabs: entering one starts a session. The tree pauses at once, but
  the impedance controller takes the arm only once the arm is free (:meth:`TeachingSession.arm_freed`: the tree's
  running skill stopped and the arm is at rest): a skill's goal is never cut off by a controller switch. Leaving to
  a tab that is not a teaching tab ends the session: the position controller takes the arm back (if the impedance
  controller had it), then the tree resumes - unless it was waiting for its first start when the session began.
  Moving between teaching tabs keeps the session (and the arm).
- A recording runs in one teaching tab, on the impedance controller: a double click before the arm is free starts it
  as soon as it is (a second one cancels that). Leaving the tab, or shutting down, stops it and saves what was
  recorded. A stiffness demonstration (LOW-LEVEL) ends the session when it stops; a shared-control recording or a
  path (TELEOP) does not (the operator goes on in the tab, or teaches the path's stiffness in LOW-LEVEL) unless the tab
  is left for a tab that is not a teaching tab.
- The MPC drives the arm only while SHARED CONTROL is open and the impedance controller holds the arm: on when both
  hold, off first thing when the tab is left or the window closes. The same for the device in TELEOP.
- The operator answers a help request with tree edits in HIGH-LEVEL: leaving HIGH-LEVEL (except for LOW-LEVEL or
  TELEOP, where teaching continues the answer) resumes the tree.
- A tree that started paused waits for the operator's start gesture in START (:meth:`TeachingSession.start_requested`);
  the same gesture runs a tree that is done again, so a session goes on without a relaunch.
"""

import enum
from typing import List, Optional

from teleteach.core.active_tab import Tab

TEACHING_TABS = (Tab.LOW_LEVEL, Tab.SHARED_CONTROL, Tab.TELEOP)  # the tree pauses, the impedance controller drives
ANSWERING_TABS = (Tab.LOW_LEVEL, Tab.TELEOP)  # leaving HIGH-LEVEL for these continues the answer to a help request


class Recording(enum.Enum):
    """What is being recorded, if anything."""

    STIFFNESS = "stiffness"  # LOW-LEVEL: a stiffness demonstration along the predefined trajectory
    SHARED_CONTROL = "shared_control"  # SHARED CONTROL: the MPC's trajectory under a constant stiffness
    PATH = "path"  # TELEOP: the path the device moves the arm along, to teach stiffness along in LOW-LEVEL


class Arm(enum.Enum):
    """Which controller a teaching session has for the arm."""

    POSITION = "position"  # the position controller (the tree's skills); no session holds the arm
    WAITING = "waiting"  # a session waits for the tree's skill to stop and the arm to rest
    IMPEDANCE = "impedance"  # the session switched the arm to the impedance controller


class Action(enum.Enum):
    """What the window must do, in the order given."""

    ENTER_LOW_LEVEL = enum.auto()  # the LOW-LEVEL tab keeps its ellipsoid until the handle takes it over
    LEAVE_LOW_LEVEL = enum.auto()  # the LOW-LEVEL tab's own clean-up (mode display, deadbands)
    RESET_HIGH_LEVEL = enum.auto()  # the HIGH-LEVEL selection starts again at step 1
    PAUSE_TREE = enum.auto()
    RESUME_TREE = enum.auto()
    START_TREE = enum.auto()  # the operator's start of a tree that started paused or is done (behaviour_tree/start)
    ANNOUNCE_HELP_ANSWERED = enum.auto()  # tell the operator that the tree goes on after their edits
    WAIT_FOR_ARM = enum.auto()  # watch the tree and the arm until the arm is free (bounded), then call arm_freed
    STOP_WAITING_FOR_ARM = enum.auto()  # the session ended before the arm was free
    IMPEDANCE_CONTROL = enum.auto()  # switch the arm to the Cartesian impedance controller
    POSITION_CONTROL = enum.auto()  # switch it back to the joint trajectory controller
    START_STIFFNESS_RECORDING = enum.auto()  # recorder on, /teleteach/recording true, trajectory player on
    STOP_STIFFNESS_RECORDING = enum.auto()  # recorder off, /teleteach/recording false, trajectory player off
    SAVE_STIFFNESS_SKILL = enum.auto()  # the demonstration becomes a skill of the library
    SHARED_CONTROL_ON = enum.auto()  # the MPC drives the arm from the device (/shared_control/enable true)
    SHARED_CONTROL_OFF = enum.auto()  # it stops publishing the arm's reference
    START_SHARED_RECORDING = enum.auto()
    STOP_SHARED_RECORDING = enum.auto()
    SAVE_SHARED_SKILL = enum.auto()
    TELEOP_ON = enum.auto()  # the device moves the arm's equilibrium (from where the arm is)
    TELEOP_OFF = enum.auto()  # it stops: the arm holds the last equilibrium
    START_PATH_RECORDING = enum.auto()
    STOP_PATH_RECORDING = enum.auto()
    SAVE_PATH = enum.auto()  # the path joins its target's demonstrations; LOW-LEVEL teaches along their mean


DRIVERS = {  # the tabs where something else than the tree drives the arm's equilibrium: (on, off)
    Tab.SHARED_CONTROL: (Action.SHARED_CONTROL_ON, Action.SHARED_CONTROL_OFF),
    Tab.TELEOP: (Action.TELEOP_ON, Action.TELEOP_OFF),
}
TAB_RECORDINGS = {Tab.SHARED_CONTROL: Recording.SHARED_CONTROL, Tab.TELEOP: Recording.PATH}
KEPT_RECORDINGS = {  # recordings after which the session goes on: stop, then keep
    Recording.SHARED_CONTROL: (Action.STOP_SHARED_RECORDING, Action.SAVE_SHARED_SKILL),
    Recording.PATH: (Action.STOP_PATH_RECORDING, Action.SAVE_PATH),
}


class TeachingSession:
    """The state of the operator's teaching.

    The open tab, whether a session holds the arm (and with which controller), what is recorded or waits to be, whether
    the robot's help request is open, whether the tree still waits for its first start and whether it is done.
    """

    def __init__(self):
        self.tab: Optional[Tab] = None
        self.session = False
        self.arm = Arm.POSITION
        self.recording: Optional[Recording] = None
        self.pending_recording: Optional[Recording] = None  # asked for before the arm was free
        self.help_open = False
        self.tree_waiting = False  # the tree started paused and nobody started it yet
        self.tree_done = False  # the tree ran to its end: the start gesture runs it again
        self._resume_on_end = True

    def tab_changed(self, index: int) -> List[Action]:
        """The operator opened the tab ``index``; a tab beyond ``Tab`` (an ABOUT tab, say) is one no rule concerns."""
        tab = Tab(index) if index in iter(Tab) else index
        if tab == self.tab:
            return []
        previous, self.tab = self.tab, tab
        actions: List[Action] = []
        if previous == Tab.LOW_LEVEL:
            actions.append(Action.LEAVE_LOW_LEVEL)
            if self.recording == Recording.STIFFNESS:
                actions += self._stop_stiffness_recording()  # leaving mid-recording keeps what was recorded
            elif self.session and tab not in TEACHING_TABS:
                actions += self._end_session()
        if previous in DRIVERS:
            if self.arm == Arm.IMPEDANCE:
                actions.append(DRIVERS[previous][1])
            if self.recording == TAB_RECORDINGS[previous]:
                actions += self._stop_kept_recording(end_session=tab not in TEACHING_TABS)
            elif self.session and tab not in TEACHING_TABS:
                actions += self._end_session()
        self.pending_recording = None  # a recording asked for in the tab that was left is not wanted any more
        if previous == Tab.HIGH_LEVEL and tab not in ANSWERING_TABS and self.help_open:
            actions += [Action.RESUME_TREE, Action.ANNOUNCE_HELP_ANSWERED]
        if tab == Tab.HIGH_LEVEL:
            actions.append(Action.RESET_HIGH_LEVEL)
        elif tab == Tab.LOW_LEVEL:
            actions.append(Action.ENTER_LOW_LEVEL)
        if tab in TEACHING_TABS and not self.session:
            actions += self._begin_session()
        if self.arm == Arm.IMPEDANCE:
            actions += self._arm_actions_of(tab)
        return actions

    def arm_freed(self) -> List[Action]:
        """The tree's skill has stopped and the arm rests: the impedance controller may take it."""
        if self.arm != Arm.WAITING:
            return []
        self.arm = Arm.IMPEDANCE
        actions = [Action.IMPEDANCE_CONTROL, *self._arm_actions_of(self.tab)]
        pending, self.pending_recording = self.pending_recording, None
        if pending is not None:
            actions += self._start_recording(pending)
        return actions

    def arm_not_freed(self) -> List[Action]:
        """The arm did not become free in time: the session keeps the tree paused, the arm stays where it was."""
        if self.arm == Arm.WAITING:
            self.arm = Arm.POSITION
        self.pending_recording = None
        return []

    def toggle_stiffness_recording(self) -> List[Action]:
        """LOW-LEVEL's double click: start a demonstration, or stop and save it (which ends the session)."""
        if self.recording == Recording.STIFFNESS:
            return self._stop_stiffness_recording()
        return self._ask_for_recording(Recording.STIFFNESS)

    def recording_refused(self) -> List[Action]:
        """The demonstration could not start (its target is not perceived): no recording, the session goes on."""
        self.recording = None
        return []

    def toggle_shared_recording(self) -> List[Action]:
        """SHARED CONTROL's double click: start recording, or stop and save (the session goes on in the tab)."""
        if self.recording == Recording.SHARED_CONTROL:
            return self._stop_kept_recording(end_session=False)
        return self._ask_for_recording(Recording.SHARED_CONTROL)

    def toggle_path_recording(self) -> List[Action]:
        """TELEOP's double click: start recording the path, or stop and keep it (the session goes on)."""
        if self.recording == Recording.PATH:
            return self._stop_kept_recording(end_session=False)
        return self._ask_for_recording(Recording.PATH)

    def help_requested(self, node_name: str) -> List[Action]:
        """The tree asks for help about ``node_name``; an empty name closes the request."""
        self.help_open = bool(node_name)
        return []

    def tree_state_changed(self, waiting: bool, done: bool) -> List[Action]:
        """The tree says whether it waits for its first start, or is done (TreeExecution WAITING, COMPLETED)."""
        self.tree_waiting, self.tree_done = waiting, done
        return []

    def start_requested(self) -> List[Action]:
        """The operator's start gesture in START: starts a tree that waits for it or runs a done one again."""
        if self.tab != Tab.START or not (self.tree_waiting or self.tree_done):
            return []
        self.tree_waiting = self.tree_done = False
        return [Action.START_TREE]

    def shutdown(self) -> List[Action]:
        """The window closes: save a running recording and give the arm back to the position controller."""
        self.pending_recording = None
        actions = [DRIVERS[self.tab][1]] if self.arm == Arm.IMPEDANCE and self.tab in DRIVERS else []
        if self.recording == Recording.STIFFNESS:
            return actions + self._stop_stiffness_recording()
        if self.recording is not None:
            return actions + self._stop_kept_recording(end_session=True)
        return actions + (self._end_session() if self.session else [])

    @staticmethod
    def _arm_actions_of(tab: Optional[Tab]) -> List[Action]:
        """What drives the impedance controller's equilibrium in ``tab`` once the arm is the session's."""
        return [DRIVERS[tab][0]] if tab in DRIVERS else []

    def _ask_for_recording(self, recording: Recording) -> List[Action]:
        """Start now if the impedance controller holds the arm, else once it does (asking again cancels that)."""
        actions = [] if self.session else self._begin_session()
        if self.arm == Arm.IMPEDANCE:
            return actions + self._start_recording(recording)
        self.pending_recording = None if self.pending_recording == recording else recording
        return actions

    def _start_recording(self, recording: Recording) -> List[Action]:
        self.recording = recording
        return [
            {
                Recording.STIFFNESS: Action.START_STIFFNESS_RECORDING,
                Recording.SHARED_CONTROL: Action.START_SHARED_RECORDING,
                Recording.PATH: Action.START_PATH_RECORDING,
            }[recording]
        ]

    def _begin_session(self) -> List[Action]:
        """The tree pauses; the impedance controller takes the arm once it is free (thesis III-A)."""
        self.session = True
        self.arm = Arm.WAITING
        self._resume_on_end = not self.tree_waiting
        return [Action.PAUSE_TREE, Action.WAIT_FOR_ARM]

    def _end_session(self) -> List[Action]:
        """The position controller takes the arm back (if it was taken), then the tree runs again."""
        self.session = False
        arm, self.arm = self.arm, Arm.POSITION
        self.pending_recording = None
        actions = {Arm.IMPEDANCE: [Action.POSITION_CONTROL], Arm.WAITING: [Action.STOP_WAITING_FOR_ARM]}.get(arm, [])
        return actions + ([Action.RESUME_TREE] if self._resume_on_end else [])

    def _stop_stiffness_recording(self) -> List[Action]:
        self.recording = None
        return [Action.STOP_STIFFNESS_RECORDING, Action.SAVE_STIFFNESS_SKILL, *self._end_session()]

    def _stop_kept_recording(self, end_session: bool) -> List[Action]:
        """Stop and keep a recording after which the operator goes on (SHARED CONTROL's, TELEOP's path)."""
        actions = list(KEPT_RECORDINGS[self.recording])
        self.recording = None
        return actions + (self._end_session() if end_session else [])
