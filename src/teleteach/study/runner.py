"""One participant's session of a study: every pending trial on a fresh system, the questionnaires, the data.

``rosrun teleteach study <study.yaml> --participant P07 [--resume] [--device dhd|virtual|scenario]`` (or
``roslaunch teleteach full.launch study:=<study.yaml> participant:=P07``). Each trial runs on a system of its own:
``full.launch`` with the trial's condition loaded last as node parameters, its own data directory and a bag, so
that every trial starts from the same world (the tree as configured, the products on the table) and the condition's
parameters reach the nodes the way every parameter does, when they start. The study node itself (this process, a
ROS node on one master for the whole session) shows the GUI the instructions, waits for the start gesture, judges
the goal from the world, ends the trial, asks the questionnaire after a condition's last trial, and writes each
result atomically (:mod:`teleteach.study.storage`). A crash loses at most the trial that ran: ``--resume`` goes on
with it. The processes it starts stop when it dies, however it dies.
"""

import dataclasses
import functools
import json
import pathlib
import subprocess
import time
from typing import Any, Callable, Dict, List, Optional

import yaml

from teleteach.core.datadir import atomic_write_text, data_dir
from teleteach.core.gui_config import GuiConfig
from teleteach.core.paths import config_file
from teleteach.core.scene import load_scene
from teleteach.core.study_phase import Phase
from teleteach.recording.bags import record_command
from teleteach.runtime.experiment import Experiment, SystemEndedError
from teleteach.runtime.processes import (
    ProcessError,
    StageScreenshots,
    closed_bag,
    full_launch,
    scripted_device,
)
from teleteach.study.metrics import TrialMetrics
from teleteach.study.ordering import QUESTIONNAIRE, Step, participant_number
from teleteach.study.parameters import parameters_file
from teleteach.study.schema import Study
from teleteach.study.scripted import compose
from teleteach.study.storage import ParticipantStore
from teleteach.study.trial import StudyFlow

DEVICES = ("dhd", "virtual", "scenario")
STUDY_TOPICS = (
    "/study/state",
    "/teleteach/selection",
    "/sigma7/guidance",
    "/sigma7/force",
    "/behaviour_tree/pause",
    "/teleteach/recording",
)
"""Recorded into each trial's bag besides the teaching topics (teleteach.recording.bags.TEACHING_TOPICS). Resolved
names, like those: rosbag keeps a topic's name as given, and a bag's readers look for the resolved one."""
KEEP_PARAMETERS = ("roslaunch", "rosdistro", "rosversion", "run_id", "study")
"""Parameter namespaces that outlive a trial's system (the master's own, and the study node's)."""


class TrialError(RuntimeError):
    """A trial could not run to its end (its system did not come up in time): it stays unfinished, resumable.

    A trial whose system died raises :class:`teleteach.runtime.experiment.SystemEndedError`, also resumable.
    """


@dataclasses.dataclass(frozen=True)
class RunnerSettings:
    """config/study.yaml (units there)."""

    prepare_timeout: float
    end_screen: float
    status_rate: float
    judge_rate: float
    contact_threshold: float
    stop_grace: float
    scripted_device_rate: float
    screenshot_delay: float

    @classmethod
    def load(cls, path: Optional[pathlib.Path] = None) -> "RunnerSettings":
        """Read ``config/study.yaml`` (every value is required: the yaml is their one home)."""
        values = yaml.safe_load((path or config_file("study.yaml")).read_text()) or {}
        names = [field.name for field in dataclasses.fields(cls)]
        missing = [name for name in names if name not in values]
        unknown = sorted(set(values) - set(names))
        if missing or unknown:
            missing_text, unknown_text = ", ".join(missing) or "-", ", ".join(unknown) or "-"
            raise ValueError(f"config/study.yaml: missing {missing_text}; unknown {unknown_text}")
        return cls(**{name: float(values[name]) for name in names})


@dataclasses.dataclass(frozen=True)
class RunnerOptions:
    """How this session runs: the device, resuming, where the data goes, the ROS master and the display."""

    device: str = "virtual"  # dhd | virtual | scenario (the scripted participant)
    resume: bool = False
    data_root: Optional[pathlib.Path] = None
    use_running_master: bool = False  # True: the master of ROS_MASTER_URI (full.launch study:=); else our own
    headless: bool = False  # no RViz, GUI repaints capped (always so on an X server of our own)
    screenshots: bool = False  # each phase of each trial pictured into its folder

    def __post_init__(self):
        if self.device not in DEVICES:
            raise ValueError(f"--device must be one of {', '.join(DEVICES)}, got {self.device!r}")


class StudyRunner:
    """Runs the pending steps of one participant; :meth:`run` returns the exit status (0: the session is complete)."""

    def __init__(
        self,
        study: Study,
        participant: str,
        options: RunnerOptions,
        settings: Optional[RunnerSettings] = None,
        say: Callable[[str], None] = functools.partial(print, flush=True),
    ):
        self.study = study
        self.participant = participant
        self.options = options
        self.settings = settings or RunnerSettings.load()
        self.say = say
        self.number = participant_number(study, participant)
        self.store = ParticipantStore(study, participant, options.data_root)
        self.experiment = Experiment(self.store.folder, data_dir(options.data_root))
        self.scene = load_scene() if any(task.goal.placement for task in study.tasks) else None
        self.gui = GuiConfig.load()
        self._ros = None
        self._flow: Optional[StudyFlow] = None

    # the session ----------------------------------------------------------------------------------------------
    def run(self) -> int:
        """Check, then run every pending step; processes are stopped whatever happens."""
        self.store.open(self.options.resume)  # refuses (SessionRefusedError) before anything starts
        try:
            return self._run()
        finally:
            self.experiment.close()
            self.store.close()

    def _run(self) -> int:
        pending = self.store.pending()
        trials = sum(1 for step in self.store.plan if step.kind != QUESTIONNAIRE)
        self.say(
            f"study {self.study.name}: participant {self.participant} (number {self.number}), "
            f"{len(pending)} of {len(self.store.plan)} steps to run, data in {self.store.folder}"
        )
        self._start_ros(trials)
        index = 0
        while index < len(pending):
            step = pending[index]
            following = pending[index + 1] if index + 1 < len(pending) else None
            asks = following is not None and following.kind == QUESTIONNAIRE and following.condition == step.condition
            if step.kind == QUESTIONNAIRE:
                self._questionnaire_alone(step)
                index += 1
            else:
                self._trial(step, following if asks else None)
                index += 2 if asks else 1
        self._flow.finish()
        self._ros.publish()
        self.say(f"study {self.study.name}: {self.participant} complete ({self.store.folder})")
        return 0

    def _start_ros(self, trials: int) -> None:
        """A master of our own (unless one runs for us), an X server if there is no display, the study node."""
        if self.experiment.own_display():
            self.options = dataclasses.replace(self.options, headless=True)
            self.say(f"study: started Xvfb on {self.experiment.display}")
        if not self.options.use_running_master:
            self.experiment.own_roscore()
        from teleteach.study.ros import StudyRos

        self.experiment.join("study")
        self._flow = StudyFlow(self.study, self.participant, trials)
        self._ros = StudyRos(self._flow)

    # a trial ------------------------------------------------------------------------------------------------
    def _trial(self, step: Step, questionnaire: Optional[Step]) -> None:
        """Run ``step`` on a fresh system; then ``questionnaire`` on the same one (the GUI is up)."""
        task = self.study.task(step.task)
        folder = self.store.begin_trial(step)
        parameters = self._prepare(step, questionnaire, folder)
        metrics = TrialMetrics(task.intended, self.settings.contact_threshold)
        self._ros.begin_trial(task.goal, self.scene, metrics)
        self._ros.pause_tree(task.pause_tree != "never")
        launch = self._launch(step, folder)
        recorder = shots = None
        try:
            recorder = self._wait_until_ready(folder)
            seen = self._parameters_seen(parameters)
            self._flow.instructions(step)
            self._ros.publish()
            shots = self._screenshots(folder)
            self._wait_for_start()
            if task.pause_tree == "instructions":
                self._ros.pause_tree(False)
            self.say(f"study: trial {step.trial} started")
            self._run_until_done()
            success, task_time, status = self._flow.outcome
            self.say(f"study: trial {step.trial} {'done' if success else 'NOT done'} in {task_time:.1f} s: {status}")
            time.sleep(self.settings.end_screen)
            self._ros.end_trial()
            self._ros.pause_tree(True)
            bag = self._stop_recorder(recorder, folder)
            recorder = None
            atomic_write_text(folder / "stiffness.csv", metrics.stiffness_csv())
            result = self._result(step, (success, task_time, status), parameters, seen, bag, metrics)
            self.store.finish_trial(step, result)
            if questionnaire is not None:
                self._ask(questionnaire)
        finally:
            if shots is not None:
                shots.stop()
            if recorder is not None:
                self.experiment.stop(recorder, grace=10.0)
            self.experiment.stop(launch, grace=self.settings.stop_grace)
            self._ros.end_trial()

    def _prepare(self, step: Step, questionnaire: Optional[Step], folder: pathlib.Path) -> Dict[str, Any]:
        """Announce the trial, leave on the master only what outlives it and write its parameters (and script).

        Returns the trial's parameters: the nodes of its fresh system read them when they start.
        """
        task = self.study.task(step.task)
        self.say(f"study: trial {step.trial} ({step.key}): {task.title}, condition {step.condition}")
        parameters = self._fresh_parameters(step, folder)
        if self.options.device == "scenario":
            self._write_script(step, questionnaire is not None, folder)
        return parameters

    def _write_script(self, step: Step, asks: bool, folder: pathlib.Path) -> None:
        """The scripted participant's scenario (and questionnaire answers if ``asks``) into the trial's folder."""
        scripted = compose(
            self.study, self.participant, step, asks, self.gui.device_range, self.settings.prepare_timeout
        )
        atomic_write_text(folder / "scenario.yaml", scripted.scenario)
        if scripted.answers is not None:
            atomic_write_text(folder / "scripted_answers.json", json.dumps(scripted.answers, indent=2) + "\n")

    def _result(self, step: Step, outcome, parameters, seen, bag: Optional[pathlib.Path], metrics) -> Dict[str, Any]:
        """The trial's stored result: the step, its outcome (success, time [s], status), the parameters, the metrics."""
        success, task_time, status = outcome
        return {
            "study": self.study.name,
            "participant": self.participant,
            "step": step.key,
            "position": step.position,
            "trial": step.trial,
            "condition": step.condition,
            "task": step.task,
            "repetition": step.repetition,
            "success": success,
            "outcome": "goal met" if success else "time up",
            "status": status,
            "task_time_s": round(task_time, 3),
            "timeout_s": self.study.task(step.task).timeout,
            "device": self.options.device,
            "parameters": parameters,
            "parameters_seen": seen,
            "bag": bag.name if bag else None,
            "finished": time.strftime("%Y-%m-%dT%H:%M:%S"),
            **metrics.summary(),
        }

    def _parameters(self, step: Step) -> Dict[str, Any]:
        """The node parameters of the trial: the scripted participant's (with its seed), then the condition's."""
        parameters: Dict[str, Any] = {}
        if self.options.device == "scenario":
            parameters.update(self.study.scripted.parameters)
            parameters["sigma7_node/hand/seed"] = self.number
        parameters.update(self.study.condition(step.condition).parameters)
        return parameters

    def _launch(self, step: Step, folder: pathlib.Path) -> subprocess.Popen:
        task = self.study.task(step.task)
        arguments = self._system(folder, scenario=folder / "scenario.yaml")
        arguments.update({**self.study.system, **task.system})
        return self.experiment.start(
            "roslaunch", full_launch(arguments), folder / "launch.log", data_root=folder / "data", watched=True
        )

    def _system(self, folder: pathlib.Path, scenario: pathlib.Path) -> Dict[str, Any]:
        """full.launch's arguments every system of the session gets.

        The device (a scripted one plays ``scenario``), headless or not, the folder's own data directory and the
        trial's parameters, loaded last.
        """
        arguments: Dict[str, Any] = {"device": self.options.device}
        if self.options.device == "virtual":
            arguments["start_paused"] = False  # a trial's tree runs from its start, as with every other device
        if self.options.device == "scenario":
            arguments.update(scripted_device(scenario, self.settings.scripted_device_rate))
        arguments.update(
            headless=self.options.headless,
            data_dir=folder / "data",
            study_parameters=folder / "parameters.yaml",
        )
        return arguments

    def _wait_until_ready(self, folder: pathlib.Path) -> subprocess.Popen:
        """Until the tree, the GUI and the device are up; then the recorder, until its bag is open."""
        from teleteach.study.ros import not_ready

        deadline = time.monotonic() + self.settings.prepare_timeout
        waiting = ["the behaviour tree"]

        def ready() -> bool:
            waiting[:] = not_ready(self._ros.trees_heard)
            return not waiting

        if not self.experiment.wait_until(ready, self.settings.prepare_timeout):
            missing = ", ".join(waiting)
            raise TrialError(f"the trial's system was not up after {self.settings.prepare_timeout:g} s ({missing})")
        command = record_command("trial", folder / "data", STUDY_TOPICS)
        recorder = self.experiment.start("rosbag record", command, folder / "record.log", data_root=folder / "data")
        bags = folder / "data" / "bags"

        def opened() -> bool:
            if recorder.poll() is not None:
                raise TrialError(f"rosbag record ended before it opened the trial's bag (see {folder / 'record.log'})")
            return bool(list(bags.glob("trial_*.bag.active")))

        if not self.experiment.wait_until(opened, max(0.0, deadline - time.monotonic()), poll=0.1):
            raise TrialError(f"rosbag record did not open the trial's bag (see {folder / 'record.log'})")
        return recorder

    def _parameters_seen(self, parameters: Dict[str, Any]) -> Dict[str, Any]:
        from teleteach.study.ros import parameters_seen

        return parameters_seen(parameters)

    def _wait_for_start(self) -> None:
        """Until the start gesture; bounded only for the scripted participant (a person may take their time)."""
        deadline = time.monotonic() + self.settings.prepare_timeout

        def started() -> bool:
            if self._flow.phase != Phase.INSTRUCTIONS:
                return True
            if self.options.device == "scenario" and time.monotonic() > deadline:
                raise TrialError(f"the scripted participant did not start within {self.settings.prepare_timeout:g} s")
            self._ros.publish()
            return False

        self.experiment.wait_until(started, None, poll=1.0 / self.settings.status_rate)

    def _run_until_done(self) -> None:
        """Judge the goal until it is met or the time is up; the live status goes out at status_rate."""
        period = 1.0 / self.settings.judge_rate
        published = 0.0
        while True:
            now = time.monotonic()
            why = self.experiment.ended()
            if why:
                self._flow.abort(now, why)
                self._ros.publish()
                raise SystemEndedError(why)
            done = self._flow.update(now, self._ros.judgement())
            if done or now - published >= 1.0 / self.settings.status_rate:
                self._ros.publish()
                published = now
            if done:
                return
            time.sleep(period)

    def _stop_recorder(self, recorder: subprocess.Popen, folder: pathlib.Path) -> Optional[pathlib.Path]:
        """Close the bag (SIGINT: rosbag's wrapper passes it on) and move it into the trial's folder as trial.bag."""
        self.experiment.stop(recorder, grace=15.0)
        bag = closed_bag(folder / "data" / "bags", "trial", folder, timeout=20.0, name="trial.bag")
        if bag is None:
            self.say(f"study: WARNING: no bag was closed for {folder.name} (see record.log)")
        return bag

    # questionnaires ---------------------------------------------------------------------------------------------
    def _ask(self, step: Step) -> None:
        """The condition's questionnaire in the GUI of the trial that just ended; the answers are stored."""
        self._flow.questionnaire(step)
        self._ros.publish()
        self.say(f"study: questionnaire after condition {step.condition}")
        timeout = self.settings.prepare_timeout + 120.0 if self.options.device == "scenario" else None
        if not self.experiment.wait_until(lambda: self._flow.answers is not None, timeout, poll=0.1):
            raise TrialError(f"the scripted participant did not answer the questionnaire after {step.condition}")
        answers = self._flow.answers
        self.store.save_questionnaire(
            step,
            {
                "study": self.study.name,
                "participant": self.participant,
                "condition": step.condition,
                "step": step.key,
                "position": step.position,
                "answers": answers,
                "items": [dataclasses.asdict(item) for item in self.study.questionnaire],
                "finished": time.strftime("%Y-%m-%dT%H:%M:%S"),
            },
        )
        self.say(f"study: answers after {step.condition} stored: {answers}")
        if not self.store.pending():
            self._flow.finish()  # the participant reads "thank you" before the last system stops
            self._ros.publish()
            time.sleep(self.settings.end_screen)
        else:
            self._flow.preparing(step)
            self._ros.publish()

    def _fresh_parameters(self, step: Step, folder: pathlib.Path) -> dict:
        """The parameters of ``step``'s fresh system, stored in ``folder`` (parameters.yaml).

        The study's state is told and the last system's parameters cleared first.
        """
        from teleteach.study.ros import clear_parameters

        self._flow.preparing(step)
        self._ros.publish()
        clear_parameters(KEEP_PARAMETERS)
        parameters = self._parameters(step)
        atomic_write_text(folder / "parameters.yaml", parameters_file(parameters))
        return parameters

    def _questionnaire_alone(self, step: Step) -> None:
        """A questionnaire whose trials were done before a crash: a system for the GUI and the device only."""
        folder = self.store.folder / "questionnaires" / f"{step.key}_system"
        folder.mkdir(parents=True, exist_ok=True)
        from teleteach.study.ros import gui_listens

        self._fresh_parameters(step, folder)
        if self.options.device == "scenario":
            atomic_write_text(folder / "scenario.yaml", self._questionnaire_scenario(step))
        arguments = {
            **self._system(folder, scenario=folder / "scenario.yaml"),
            "real_robot": True,
            "shared_control": False,
        }
        log = folder / "launch.log"
        launch = self.experiment.start(
            "roslaunch", full_launch(arguments), log, data_root=folder / "data", watched=True
        )
        try:
            if not self.experiment.wait_until(gui_listens, self.settings.prepare_timeout):
                raise TrialError(f"the GUI was not up after {self.settings.prepare_timeout:g} s")
            shots = self._screenshots(folder)
            try:
                self._ask(step)
            finally:
                shots.stop()
        finally:
            self.experiment.stop(launch, grace=self.settings.stop_grace)

    def _questionnaire_scenario(self, step: Step) -> str:
        """The scripted participant's answers alone: its answering part of a trial's scenario."""
        from teleteach.study.scripted import questionnaire_scenario

        text, answers = questionnaire_scenario(self.study, self.participant, step, self.gui.device_range)
        atomic_write_text(
            self.store.folder / "questionnaires" / f"{step.key}_system" / "scripted_answers.json",
            json.dumps(answers, indent=2) + "\n",
        )
        return text

    def _screenshots(self, folder: pathlib.Path) -> StageScreenshots:
        """What the participant saw: each phase of the trial (not its preparation or end), then its latest state."""

        def phase() -> Optional[str]:
            current = self._flow.phase
            return None if current in (Phase.PREPARING, Phase.FINISHED) else current.name.lower()

        return self.experiment.screenshots(
            "screen", phase, self.settings.screenshot_delay, period=3.0, folder=folder, enabled=self.options.screenshots
        )


def main(argv: Optional[List[str]] = None) -> int:
    """Command line of ``rosrun teleteach study``; exit 0 complete, 1 a trial failed (resumable), 2 refused."""
    import sys

    from teleteach.study.ordering import ParticipantError
    from teleteach.study.schema import StudyError, load_study
    from teleteach.study.scripted import ScriptError
    from teleteach.study.storage import SessionRefusedError

    parser = _parser()
    if argv is None:
        import rosgraph

        argv = rosgraph.myargv(sys.argv)[1:]  # without roslaunch's __name:= and __log:=
    arguments = parser.parse_args(argv)
    try:
        study = load_study(arguments.study_file)
        options = RunnerOptions(
            device=arguments.device,
            resume=arguments.resume,
            data_root=pathlib.Path(arguments.data_dir).expanduser() if arguments.data_dir else None,
            use_running_master=arguments.use_master,
            headless=arguments.headless,
            screenshots=arguments.screenshots,
        )
        if options.device == "scenario":
            missing = [task.name for task in study.tasks if task.script is None]
            if missing:
                raise ScriptError(f"--device scenario needs a script for every task; {', '.join(missing)} has none")
        return StudyRunner(study, arguments.participant, options).run()
    except (StudyError, ParticipantError, SessionRefusedError, ScriptError, ValueError) as error:
        print(f"study: {error}", flush=True)
        return 2
    except (TrialError, SystemEndedError, ProcessError) as error:
        print(f"study: {error}; the step that ran is not stored: continue with --resume", flush=True)
        return 1
    except KeyboardInterrupt:
        print("study: interrupted; the step that ran is not stored: continue with --resume", flush=True)
        return 1


def _parser():
    """The command line's options, each with the help ``rosrun teleteach study --help`` shows."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="study", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("study_file", help="the study file (config/studies/<name>.yaml)")
    parser.add_argument("--participant", required=True, help="the participant's id, e.g. P07")
    parser.add_argument("--resume", action="store_true", help="continue this participant at the next unfinished step")
    parser.add_argument(
        "--device", default="virtual", choices=DEVICES, help="dhd (Sigma.7), virtual, scenario (scripted participant)"
    )
    parser.add_argument("--data-dir", default=None, help="data directory (default $TELETEACH_DATA or ~/.ros/teleteach)")
    parser.add_argument("--headless", action="store_true", help="no RViz, GUI repaints capped")
    parser.add_argument("--screenshots", action="store_true", help="picture each phase of each trial into its folder")
    parser.add_argument("--use-master", action="store_true", help="use the running ROS master (full.launch study:=)")
    return parser
