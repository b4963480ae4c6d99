"""What a stopped recording becomes: a skill file in the data directory, a skill of the tree's library, a DMP.

The file is written at once; /behaviour_tree/add_skill is called off the GUI thread; a stiffness taught along a
taught path is learned into a DMP skill by learn_skill in a process of its own, which closing the window waits for.
"""

import pathlib
import time
from typing import Callable, List, Optional, Tuple

from PyQt5.QtCore import QObject, QProcess

from teleteach.core import skill_file
from teleteach.core.frames import Transform
from teleteach.core.gui_config import GuiConfig
from teleteach.gui.recording import StiffnessRecorder, unique_skill_name
from teleteach.srv import AddSkill, AddSkillRequest

LEARNING_GRACE_MS = 60000  # a DMP being learned as the window closes gets this long to join the library


class TaughtSkills(QObject):
    """Saves recordings as skills, adds them to the library, learns DMPs; says what happened in the status bar.

    A new name differs from the library's skills as the tree last published them (``window.library_names``); the
    answer of a DMP's learning is shown in TELEOP's path line too; ``log(text, warning)`` is the node's log.
    """

    def __init__(self, window, log: Callable[..., None]):
        super().__init__(window)
        self.window = window
        self.config: GuiConfig = window.config
        self.data_root: pathlib.Path = window.data_root
        self.skills_dir = self.data_root / "skills"
        self.services = window.services
        self.saved: List[str] = []
        self._log = log
        self._learning: Optional[QProcess] = None  # learn_skill turning a taught path's stiffness into a DMP skill
        self.services.finished.connect(self._on_added)

    def _status(self, text: str, milliseconds: int) -> None:
        self.window.statusBar().showMessage(text, milliseconds)

    def save(
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
        name = unique_skill_name(prefix, self.window.library_names + self.saved, self.skills_dir)
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
            self._status(f"recording not saved: {error}{hint}", 15000)
            return None
        self.saved.append(name)
        self._status(f"saved {name} ({len(skill.time)} samples) to {path}", 10000)
        if add:
            self._add(name, kind, path)
        return path

    def _add(self, name: str, kind: str, path: pathlib.Path) -> None:
        request = AddSkillRequest(name, kind, str(path))
        self.services.call(f"add_skill:{name}", "behaviour_tree/add_skill", AddSkill, request)

    def _on_added(self, key: str, success: bool, message: str, response) -> None:
        if not key.startswith("add_skill:"):
            return
        name = key.split(":", 1)[1]
        if success and response.success:
            text = f"{name} is in the skill library: a new button in HIGH-LEVEL"
        else:
            text = f"{name} was not added to the skill library: {response.message if success else message}"
        self._status(text, 15000)

    def learn_dmp(self, stiffness_skill: pathlib.Path) -> None:
        """learn_skill in the background: the DMP of a stiffness taught along a taught path joins the library."""
        if self._learning is not None and self._learning.state() != QProcess.NotRunning:
            name = stiffness_skill.stem  # one learning at a time: this demonstration joins the library as it is
            self._add(name, "stiffness", stiffness_skill)
            self._status(f"still learning the previous skill: {name} joins as a stiffness skill", 15000)
            return
        process = QProcess(self)
        process.setProcessChannelMode(QProcess.MergedChannels)
        name = f"{stiffness_skill.stem}_dmp"
        arguments = ["teleteach", "learn_skill", str(stiffness_skill), "--name", name, "--add"]
        process.finished.connect(lambda code, _status: self._on_learned(process, name, code))
        process.start("rosrun", [*arguments, "--data-dir", str(self.data_root)])
        self._learning = process
        self._status(f"learning {name} (a DMP skill) from {stiffness_skill.name}...", 15000)

    def _on_learned(self, process: QProcess, name: str, code: int) -> None:
        lines = bytes(process.readAll()).decode(errors="replace").strip().splitlines()
        last = lines[-1] if lines else "no output"
        text = f"{name} is in the skill library: {last}" if code == 0 else f"{name} was not learned: {last}"
        self.window.teleop.show_path(text, False)
        self._status(text, 30000)

    def finish_learning(self) -> None:
        """A DMP still being learned is learned to the end, not lost: Qt would kill its process with the window."""
        process = self._learning
        if process is None or process.state() == QProcess.NotRunning:
            return
        process.finished.disconnect()  # its answer has no window left to be shown in
        self._log(f"waiting up to {LEARNING_GRACE_MS / 1000:.0f} s for learn_skill to finish the DMP it learns")
        if process.waitForFinished(LEARNING_GRACE_MS):
            output = bytes(process.readAll()).decode(errors="replace").strip().splitlines()
            self._log(output[-1] if output else f"learn_skill ended with exit status {process.exitCode()}")
        else:
            process.kill()
            process.waitForFinished(1000)
            self._log(f"learn_skill did not finish in {LEARNING_GRACE_MS / 1000:.0f} s and was stopped", warning=True)
