"""A participant's data, resumable: ``<data dir>/studies/<study>/<participant>/``.

Layout::

    plan.json                      the session's steps (written at the first start; a resume must find the same)
    study.yaml                     the study file as it was at the first start
    trials/<step>/result.json      a finished trial (written last and atomically: its presence means "done")
    trials/<step>/trial.bag        the trial's bag, stiffness.csv, scenario.yaml (scripted), parameters.yaml,
                                   launch.log, data/ (the trial's own data directory: trees, skills)
    questionnaires/<step>.json     a condition's answers (atomic)
    crashed/<step>_<time>/         what a trial that never finished left (kept, never overwritten)
    runner.pid                     the process running this participant, while it runs

A trial that crashed loses only itself: the next start with ``--resume`` sets its folder aside and runs it again.
"""

import dataclasses
import json
import os
import pathlib
import shutil
import time
from typing import Any, Dict, List, Optional

from teleteach.core.datadir import atomic_write_text, data_dir
from teleteach.study.ordering import QUESTIONNAIRE, Step, session_plan
from teleteach.study.schema import Study

RESULT = "result.json"


class SessionRefusedError(RuntimeError):
    """A session that must not start (complete data, data without --resume, another runner, a changed study)."""


def study_folder(study: Study, root: Optional[pathlib.Path] = None) -> pathlib.Path:
    """``<data dir>/studies/<study name>``."""
    return data_dir(root) / "studies" / study.name


def _step(data: Dict[str, Any]) -> Step:
    return Step(**{field.name: data[field.name] for field in dataclasses.fields(Step)})


def _process_alive(pid: int) -> bool:
    """Whether ``pid`` runs a study runner (a recycled pid of another program does not count)."""
    try:
        command = pathlib.Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
    except OSError:
        return False
    return b"study" in command


class ParticipantStore:
    """One participant's folder: the plan, which steps are done, and atomic writes of their results."""

    def __init__(self, study: Study, participant: str, root: Optional[pathlib.Path] = None):
        self.study = study
        self.participant = participant
        self.folder = study_folder(study, root) / participant
        self.plan: List[Step] = session_plan(study, participant)

    # the session's start -----------------------------------------------------------------------------------
    def open(self, resume: bool) -> None:
        """Check that this session may run, then write the plan (first start) and take the runner's lock.

        Raises:
            SessionRefusedError: with one line saying what to do (``--resume``, or a new participant id).
        """
        plan_file = self.folder / "plan.json"
        if plan_file.is_file():
            saved = json.loads(plan_file.read_text())
            steps = [_step(item) for item in saved["steps"]]
            if steps != self.plan:
                raise SessionRefusedError(
                    f"{self.participant} began {self.study.name} with another plan ({plan_file}): the study file "
                    "changed since; restore it, or use a new --participant id"
                )
            done = len(self.done())
            if done == len(self.plan):
                raise SessionRefusedError(
                    f"{self.participant} has complete data for {self.study.name} in {self.folder}: "
                    "use a new --participant id"
                )
            if not resume:
                raise SessionRefusedError(
                    f"{self.participant} already has data for {self.study.name} ({done} of {len(self.plan)} steps "
                    f"done, {self.folder}): continue with --resume, or use a new --participant id"
                )
        elif resume:
            raise SessionRefusedError(
                f"{self.participant} has nothing to resume in {self.folder}: start without --resume"
            )
        self._lock()
        if not plan_file.is_file():
            atomic_write_text(self.folder / "study.yaml", self.study.source.read_text())
            plan = {
                "study": self.study.name,
                "participant": self.participant,
                "study_sha256": self.study.digest,
                "created": time.strftime("%Y-%m-%dT%H:%M:%S"),
                "steps": [step.to_dict() for step in self.plan],
            }
            atomic_write_text(plan_file, json.dumps(plan, indent=2) + "\n")

    def _lock(self) -> None:
        lock = self.folder / "runner.pid"
        try:
            pid = int(lock.read_text().strip())
        except (OSError, ValueError):
            pid = None
        if pid is not None and pid != os.getpid() and _process_alive(pid):
            raise SessionRefusedError(f"another study runner (pid {pid}) is running {self.participant} ({self.folder})")
        atomic_write_text(lock, f"{os.getpid()}\n")

    def close(self) -> None:
        """Release the lock."""
        lock = self.folder / "runner.pid"
        try:
            if int(lock.read_text().strip()) == os.getpid():
                lock.unlink()
        except (OSError, ValueError):
            pass

    # progress ---------------------------------------------------------------------------------------------
    def step_folder(self, step: Step) -> pathlib.Path:
        """Where a trial's files go."""
        return self.folder / "trials" / step.key

    def questionnaire_file(self, step: Step) -> pathlib.Path:
        """Where a questionnaire's answers go."""
        return self.folder / "questionnaires" / f"{step.key}.json"

    def is_done(self, step: Step) -> bool:
        """Whether a step's result was written."""
        if step.kind == QUESTIONNAIRE:
            return self.questionnaire_file(step).is_file()
        return (self.step_folder(step) / RESULT).is_file()

    def done(self) -> List[Step]:
        """The steps with a result."""
        return [step for step in self.plan if self.is_done(step)]

    def pending(self) -> List[Step]:
        """The steps still to run, in order."""
        return [step for step in self.plan if not self.is_done(step)]

    # writing ----------------------------------------------------------------------------------------------
    def begin_trial(self, step: Step) -> pathlib.Path:
        """A fresh folder for the trial; what an unfinished earlier attempt left is moved to ``crashed/``."""
        folder = self.step_folder(step)
        if folder.exists():
            target = self.folder / "crashed" / f"{step.key}_{time.strftime('%Y%m%d-%H%M%S')}"
            suffix = 1
            while target.exists():
                suffix += 1
                target = target.with_name(f"{target.name}_{suffix}")
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.move(str(folder), str(target))
        folder.mkdir(parents=True)
        return folder

    def finish_trial(self, step: Step, result: Dict[str, Any]) -> pathlib.Path:
        """Write the trial's result (atomically, last): from now on the trial is done."""
        path = self.step_folder(step) / RESULT
        atomic_write_text(path, json.dumps(result, indent=2, sort_keys=True) + "\n")
        return path

    def save_questionnaire(self, step: Step, answers: Dict[str, Any]) -> pathlib.Path:
        """Write a condition's answers (atomically)."""
        path = self.questionnaire_file(step)
        atomic_write_text(path, json.dumps(answers, indent=2, sort_keys=True) + "\n")
        return path
