"""A participant's data: refusals in one line, resuming at the next unfinished step, a crashed trial set aside."""

import json
import pathlib
import subprocess
import sys
import time

import pytest

from teleteach.study.ordering import QUESTIONNAIRE
from teleteach.study.schema import load_study, parse_study
from teleteach.study.storage import ParticipantStore, SessionRefusedError

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "config" / "studies" / "example.yaml"


@pytest.fixture
def study():
    return load_study(EXAMPLE)


def finish_everything(store):
    for step in store.pending():
        if step.kind == QUESTIONNAIRE:
            store.save_questionnaire(step, {"answers": {}})
        else:
            store.begin_trial(step)
            store.finish_trial(step, {"step": step.key})


def test_a_first_start_writes_the_plan_and_the_study_file(study, tmp_path):
    store = ParticipantStore(study, "P01", tmp_path)
    store.open(resume=False)
    plan = json.loads((store.folder / "plan.json").read_text())
    assert [step["position"] for step in plan["steps"]] == list(range(1, 11))
    assert plan["study_sha256"] == study.digest
    assert (store.folder / "study.yaml").read_text() == EXAMPLE.read_text()
    assert store.folder == tmp_path / "studies" / "guidance_example" / "P01"
    assert (store.folder / "runner.pid").is_file()
    store.close()
    assert not (store.folder / "runner.pid").exists()


def test_data_without_resume_is_refused_saying_resume_or_a_new_id(study, tmp_path):
    store = ParticipantStore(study, "P01", tmp_path)
    store.open(resume=False)
    step = store.pending()[0]
    store.begin_trial(step)
    store.finish_trial(step, {"step": step.key})
    store.close()
    again = ParticipantStore(study, "P01", tmp_path)
    with pytest.raises(SessionRefusedError) as refused:
        again.open(resume=False)
    assert str(refused.value) == (
        f"P01 already has data for guidance_example (1 of 10 steps done, {store.folder}): continue with --resume, "
        "or use a new --participant id"
    )
    again.open(resume=True)
    assert again.pending()[0].key == "02_guided_remove_place_item_2"


def test_complete_data_is_refused_even_with_resume(study, tmp_path):
    store = ParticipantStore(study, "P02", tmp_path)
    store.open(resume=False)
    finish_everything(store)
    store.close()
    for resume in (False, True):
        with pytest.raises(SessionRefusedError) as refused:
            ParticipantStore(study, "P02", tmp_path).open(resume=resume)
        assert str(refused.value) == (
            f"P02 has complete data for guidance_example in {store.folder}: use a new --participant id"
        )


def test_resume_without_data_and_a_changed_study_are_refused(study, tmp_path):
    with pytest.raises(SessionRefusedError, match="P03 has nothing to resume in .*: start without --resume"):
        ParticipantStore(study, "P03", tmp_path).open(resume=True)
    store = ParticipantStore(study, "P03", tmp_path)
    store.open(resume=False)
    store.close()
    changed = tmp_path / "example.yaml"
    text = EXAMPLE.read_text().replace("trials_per_task: 2", "trials_per_task: 3")
    changed.write_text(text.replace("script: scripts/", f"script: {EXAMPLE.parent}/scripts/"))
    with pytest.raises(SessionRefusedError, match="the study file changed since; restore it, or use a new"):
        ParticipantStore(parse_study(changed.read_text(), changed), "P03", tmp_path).open(resume=True)


def test_a_crashed_trial_is_set_aside_and_run_again(study, tmp_path):
    store = ParticipantStore(study, "P04", tmp_path)
    store.open(resume=False)
    step = store.pending()[0]
    folder = store.begin_trial(step)
    (folder / "trial.bag.active").write_text("half a bag")
    # the runner dies here; the next start resumes
    store.close()
    again = ParticipantStore(study, "P04", tmp_path)
    again.open(resume=True)
    assert again.pending()[0] == step
    fresh = again.begin_trial(step)
    assert list(fresh.iterdir()) == []
    (crashed,) = (again.folder / "crashed").iterdir()
    assert crashed.name.startswith(step.key + "_")
    assert (crashed / "trial.bag.active").read_text() == "half a bag"
    again.finish_trial(step, {"step": step.key})
    assert again.pending()[0].key == "02_unguided_remove_place_item_2"  # P04: the Latin square's second row


def test_a_participant_is_run_by_one_runner_at_a_time(study, tmp_path):
    store = ParticipantStore(study, "P05", tmp_path)
    store.open(resume=False)
    store.close()
    # a live process whose command line names a study runner holds the lock
    holder = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)", "study"])
    cmdline = pathlib.Path(f"/proc/{holder.pid}/cmdline")
    deadline = time.monotonic() + 10.0
    while b"time.sleep(60)" not in cmdline.read_bytes() and time.monotonic() < deadline:
        time.sleep(0.01)  # the child has not exec'd python yet
    try:
        (store.folder / "runner.pid").write_text(f"{holder.pid}\n")
        with pytest.raises(SessionRefusedError, match=f"another study runner \\(pid {holder.pid}\\) is running P05"):
            ParticipantStore(study, "P05", tmp_path).open(resume=True)
    finally:
        holder.kill()
        holder.wait()
    # Expect a dead runner's lock not to hold anyone up
    ParticipantStore(study, "P05", tmp_path).open(resume=True)
