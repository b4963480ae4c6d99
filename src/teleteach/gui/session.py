"""The teaching session as a state machine without Qt: what the GUI does on tab changes, recordings and help requests.

Events in (tab changes, recording toggles, help requests, shutdown), :class:`Action` lists out, in the order the
window must carry them out. The window only wires the events to this machine and the actions to the widgets, the
recorders and the ROS calls, so every rule below is tested without a display (test/unit/test_gui_session.py):

- LOW-LEVEL and SHARED CONTROL are teaching tabs: entering one starts a session (the tree pauses, the impedance
  controller takes the arm); leaving to a tab that is not a teaching tab ends it (position controller, tree resumes).
- A recording runs in one teaching tab; leaving that tab, or shutting down, stops it and saves what was recorded.
  A stiffness demonstration (LOW-LEVEL) ends the session when it stops; a shared-control recording does not
  (the operator goes on in the tab) unless the tab is left for a tab that is not a teaching tab.
- The MPC drives the arm only while SHARED CONTROL is open: on when the tab opens (after the session began), off
  first thing when it is left or the window closes.
- The operator answers a help request with tree edits in HIGH-LEVEL: leaving HIGH-LEVEL (except for LOW-LEVEL,
  where teaching continues the answer) resumes the tree.
"""

import enum
from typing import List, Optional

from teleteach.active_tab import Tab

TEACHING_TABS = (Tab.LOW_LEVEL, Tab.SHARED_CONTROL)  # the tree pauses and the impedance controller drives the arm


class Recording(enum.Enum):
    """What is being recorded, if anything."""

    STIFFNESS = "stiffness"  # LOW-LEVEL: a stiffness demonstration along the predefined trajectory
    SHARED_CONTROL = "shared_control"  # SHARED CONTROL: the MPC's trajectory under a constant stiffness


class Action(enum.Enum):
    """What the window must do, in the order given."""

    LEAVE_LOW_LEVEL = enum.auto()  # the LOW-LEVEL tab's own clean-up (mode display, deadbands)
    RESET_HIGH_LEVEL = enum.auto()  # the HIGH-LEVEL selection starts again at step 1
    PAUSE_TREE = enum.auto()
    RESUME_TREE = enum.auto()
    ANNOUNCE_HELP_ANSWERED = enum.auto()  # tell the operator that the tree goes on after their edits
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


class TeachingSession:
    """The state of the operator's teaching.

    The open tab, whether a session holds the arm, what is recorded, and whether the robot's help request is open.
    """

    def __init__(self):
        self.tab: Optional[Tab] = None
        self.session = False
        self.recording: Optional[Recording] = None
        self.help_open = False

    def tab_changed(self, index: int) -> List[Action]:
        """The operator opened the tab ``index``."""
        tab = Tab(index)
        if tab == self.tab:
            return []
        previous, self.tab = self.tab, tab
        actions: List[Action] = []
        if previous == Tab.LOW_LEVEL:
            actions.append(Action.LEAVE_LOW_LEVEL)
            if self.recording == Recording.STIFFNESS:
                actions += self._stop_stiffness_recording()  # leaving mid-recording keeps what was recorded
            elif self.session and tab != Tab.SHARED_CONTROL:
                actions += self._end_session()
        if previous == Tab.SHARED_CONTROL:
            actions.append(Action.SHARED_CONTROL_OFF)
            if self.recording == Recording.SHARED_CONTROL:
                actions += self._stop_shared_recording(end_session=tab != Tab.LOW_LEVEL)
            elif self.session and tab != Tab.LOW_LEVEL:
                actions += self._end_session()
        if previous == Tab.HIGH_LEVEL and tab != Tab.LOW_LEVEL and self.help_open:
            actions += [Action.RESUME_TREE, Action.ANNOUNCE_HELP_ANSWERED]
        if tab == Tab.HIGH_LEVEL:
            actions.append(Action.RESET_HIGH_LEVEL)
        elif tab in TEACHING_TABS and not self.session:
            actions += self._begin_session()
        if tab == Tab.SHARED_CONTROL:
            actions.append(Action.SHARED_CONTROL_ON)
        return actions

    def toggle_stiffness_recording(self) -> List[Action]:
        """LOW-LEVEL's double click: start a demonstration, or stop and save it (which ends the session)."""
        if self.recording == Recording.STIFFNESS:
            return self._stop_stiffness_recording()
        actions = [] if self.session else self._begin_session()
        self.recording = Recording.STIFFNESS
        return [*actions, Action.START_STIFFNESS_RECORDING]

    def recording_refused(self) -> List[Action]:
        """The demonstration could not start (its target is not perceived): no recording, the session goes on."""
        self.recording = None
        return []

    def toggle_shared_recording(self) -> List[Action]:
        """SHARED CONTROL's double click: start recording, or stop and save (the session goes on in the tab)."""
        if self.recording == Recording.SHARED_CONTROL:
            return self._stop_shared_recording(end_session=False)
        actions = [] if self.session else self._begin_session()
        self.recording = Recording.SHARED_CONTROL
        return [*actions, Action.START_SHARED_RECORDING]

    def help_requested(self, node_name: str) -> List[Action]:
        """The tree asks for help about ``node_name``; an empty name closes the request."""
        self.help_open = bool(node_name)
        return []

    def shutdown(self) -> List[Action]:
        """The window closes: save a running recording and give the arm back to the position controller."""
        actions = [Action.SHARED_CONTROL_OFF] if self.tab == Tab.SHARED_CONTROL else []
        if self.recording == Recording.STIFFNESS:
            return actions + self._stop_stiffness_recording()
        if self.recording == Recording.SHARED_CONTROL:
            return actions + self._stop_shared_recording(end_session=True)
        return actions + (self._end_session() if self.session else [])

    def _begin_session(self) -> List[Action]:
        """The tree pauses and the impedance controller takes the arm (thesis III-A)."""
        self.session = True
        return [Action.PAUSE_TREE, Action.IMPEDANCE_CONTROL]

    def _end_session(self) -> List[Action]:
        """The position controller takes the arm back, then the tree runs again."""
        self.session = False
        return [Action.POSITION_CONTROL, Action.RESUME_TREE]

    def _stop_stiffness_recording(self) -> List[Action]:
        self.recording = None
        return [Action.STOP_STIFFNESS_RECORDING, Action.SAVE_STIFFNESS_SKILL, *self._end_session()]

    def _stop_shared_recording(self, end_session: bool) -> List[Action]:
        self.recording = None
        actions = [Action.STOP_SHARED_RECORDING, Action.SAVE_SHARED_SKILL]
        return actions + (self._end_session() if end_session else [])
