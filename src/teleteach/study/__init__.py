"""User studies with teleteach: a study file, the trials of each participant, the questionnaire and the numbers.

``schema`` reads and validates a study file (``config/studies/<name>.yaml``), ``ordering`` counterbalances it over
participants, ``goals`` judges each task from the world, ``metrics`` measures each trial, ``questionnaire`` holds
NASA-TLX and Likert items, ``trial`` is a trial's state machine (``phase`` its phases, shared with the GUI and the
device node), ``storage`` keeps a participant's data resumable and atomic, ``scripted`` makes the scripted
participant's device input, ``report`` aggregates a study; the ROS layer is ``ros`` and ``runner`` runs a
participant's session (``rosrun teleteach study``).
"""
