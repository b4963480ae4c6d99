"""Where a participant's session stands, as a state machine without ROS: phases, the participant's inputs, the end.

PREPARING (the trial's system starts) -> INSTRUCTIONS (the task is explained; the start gesture starts it) ->
RUNNING (the world is judged) -> DONE (goal met, or time up) -> the next trial's PREPARING, or QUESTIONNAIRE after a
condition's last trial -> ... -> FINISHED. The participant's inputs (the start gesture, the answers) come from the
GUI's thread, the judgements from the runner's: every method takes the lock. An input outside its phase, or answers
that do not fit the items, are refused with the reason and change nothing.
"""

import dataclasses
import threading
from typing import Dict, Optional, Sequence, Tuple

from teleteach.core.questionnaire import AnswerError, check_answers
from teleteach.core.study_phase import Phase, StudyView
from teleteach.study.goals import Judgement
from teleteach.study.ordering import Step
from teleteach.study.schema import Study


class StudyFlow:
    """The session's phase and the inputs it accepts."""

    def __init__(self, study: Study, participant: str, trials: int):
        self.study = study
        self.participant = participant
        self.trials = trials
        self._lock = threading.Lock()
        self._phase = Phase.PREPARING
        self._step: Optional[Step] = None
        self._started: Optional[float] = None
        self._ended: Optional[float] = None
        self._status = ""
        self._success = False
        self._answers: Optional[Dict[str, float]] = None

    @property
    def phase(self) -> Phase:
        """The current phase."""
        with self._lock:
            return self._phase

    def _enter(self, phase: Phase, step: Optional[Step]) -> None:
        self._phase, self._step = phase, step
        self._started = self._ended = None
        self._status, self._success, self._answers = "", False, None

    def preparing(self, step: Step) -> None:
        """The system of ``step`` is starting."""
        with self._lock:
            self._enter(Phase.PREPARING, step)

    def instructions(self, step: Step) -> None:
        """The system is up: explain the task and wait for the start gesture."""
        with self._lock:
            self._enter(Phase.INSTRUCTIONS, step)

    def start(self, now: float) -> Tuple[bool, str]:
        """The start gesture (GUI); the trial's clock starts at ``now`` [s]."""
        with self._lock:
            if self._phase != Phase.INSTRUCTIONS:
                return False, f"no trial waits for its start (phase {self._phase.name})"
            self._phase, self._started = Phase.RUNNING, now
            return True, f"trial {self._step.trial} started"

    @property
    def started(self) -> Optional[float]:
        """When the running trial started [s], or None."""
        with self._lock:
            return self._started

    def update(self, now: float, judgement: Judgement) -> bool:
        """RUNNING: the world's latest judgement; True once the trial is DONE (goal met, or its time is up)."""
        with self._lock:
            if self._phase == Phase.DONE:
                return True
            if self._phase != Phase.RUNNING:
                return False
            self._status = judgement.status
            timeout = self.study.task(self._step.task).timeout
            if judgement.met or now - self._started >= timeout:
                self._phase, self._ended, self._success = Phase.DONE, now, judgement.met
                if not judgement.met:
                    self._status = f"time is up ({timeout:g} s): {judgement.status}"
                return True
            return False

    def abort(self, now: float, reason: str) -> None:
        """The trial cannot go on (its system died): DONE without success, saying why."""
        with self._lock:
            if self._phase == Phase.RUNNING:
                self._phase, self._ended, self._success, self._status = Phase.DONE, now, False, reason

    @property
    def outcome(self) -> Tuple[bool, float, str]:
        """DONE: (goal met, task time [s], the last status)."""
        with self._lock:
            return self._success, (self._ended or 0.0) - (self._started or 0.0), self._status

    def questionnaire(self, step: Step) -> None:
        """Ask the questionnaire of ``step``'s condition."""
        with self._lock:
            self._enter(Phase.QUESTIONNAIRE, step)

    def answer(self, names: Sequence[str], values: Sequence[float]) -> Tuple[bool, str]:
        """The participant's answers (GUI): taken when they fit the items, else refused saying why."""
        with self._lock:
            if self._phase != Phase.QUESTIONNAIRE:
                return False, f"no questionnaire is open (phase {self._phase.name})"
            if self._answers is not None:
                return False, "the answers were already taken"
            try:
                self._answers = check_answers(self.study.questionnaire, names, values)
            except AnswerError as error:
                return False, str(error)
            return True, f"{len(self._answers)} answers taken"

    @property
    def answers(self) -> Optional[Dict[str, float]]:
        """The answers taken, or None."""
        with self._lock:
            return None if self._answers is None else dict(self._answers)

    def finish(self) -> None:
        """Nothing is left."""
        with self._lock:
            self._enter(Phase.FINISHED, None)

    def view(self, now: float) -> StudyView:
        """What the participant's screen should show now."""
        with self._lock:
            view = StudyView(self._phase, self.study.name, self.participant, trials=self.trials)
            step = self._step
            if step is None:
                return view
            condition = self.study.condition(step.condition)
            view = dataclasses.replace(view, condition=condition.name, condition_label=condition.label)
            if self._phase == Phase.QUESTIONNAIRE:
                return dataclasses.replace(view, items=self.study.questionnaire)
            if not step.task:
                return view  # preparing a questionnaire's system
            task = self.study.task(step.task)
            elapsed = 0.0
            if self._started is not None:
                elapsed = (self._ended if self._ended is not None else now) - self._started
            return dataclasses.replace(
                view,
                task=task.name,
                title=task.title,
                instructions=task.instructions,
                trial=step.trial,
                elapsed=elapsed,
                timeout=task.timeout,
                status=self._status,
                success=self._success,
            )
