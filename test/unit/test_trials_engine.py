"""Where trials run and how a bench continues after an interruption (teleteach.run.engine)."""

import dataclasses
import json
import pathlib

import numpy as np
import pytest

from teleteach.run.engine import Progress, TrialStore, job_key, run_jobs


@dataclasses.dataclass(frozen=True)
class CountedJob:
    """A trial that leaves a mark per run in ``folder`` and fails while ``folder/fail-<seed>`` exists."""

    group: str
    seed: int
    folder: str

    def run(self, process: dict) -> dict:
        folder = pathlib.Path(self.folder)
        with open(folder / f"ran-{self.seed}", "a") as marks:
            marks.write("x")
        if (folder / f"fail-{self.seed}").exists():
            raise RuntimeError(f"trial {self.seed} interrupted")
        return {"seed": self.seed, "value": self.seed**2 + 0.5, "has_scene": "scene" in process}


def runs(folder: pathlib.Path, seed: int) -> int:
    path = folder / f"ran-{seed}"
    return len(path.read_text()) if path.exists() else 0


@pytest.mark.slow
def test_an_interrupted_run_continues_from_the_trials_it_stored(tmp_path):
    store = tmp_path / "store.jsonl"
    work = [CountedJob("cell", seed, str(tmp_path)) for seed in range(4)]
    (tmp_path / "fail-2").touch()
    with pytest.raises(RuntimeError, match="trial 2 interrupted"):
        run_jobs(work, 1, progress=lambda line: None, store=store)
    stored = [json.loads(line) for line in store.read_text().splitlines()]
    assert [entry["result"]["seed"] for entry in stored] == [0, 1]
    (tmp_path / "fail-2").unlink()
    lines = []
    rows = run_jobs(work, 1, progress=lines.append, store=store)
    # Expect: trials 0 and 1 taken from the store, not run again; 2 (and 3, which the worker may have begun before
    # trial 2's error reached the run) run; every row as a fresh run gives it
    assert [runs(tmp_path, seed) for seed in range(3)] == [1, 1, 2]
    assert [row for _, row in rows] == [{"seed": seed, "value": seed**2 + 0.5, "has_scene": True} for seed in range(4)]
    assert lines[0] == "  2/4 trials stored by an interrupted run: running the other 2"
    assert lines[-1].startswith("  4/4 trials, ") and lines[-1].endswith("done")
    assert not store.exists()


def test_the_store_ignores_a_torn_line_and_sets_another_commits_trials_aside(tmp_path):
    store = TrialStore(tmp_path / "store.jsonl")
    store.append({"key": "a", "commit": "1" * 40, "group": "g", "result": {"seed": 0}})
    store.append({"key": "b", "commit": "2" * 40, "group": "g", "result": {"seed": 1, "error": np.array([0.5, 1.0])}})
    with open(store.path, "a") as file:
        file.write('{"key": "c", "commit": "11')  # killed while writing
    assert json.loads(store.path.read_text().splitlines()[1])["result"]["error"] == [0.5, 1.0]  # numpy as lists
    lines = []
    loaded = store.load("1" * 40, lines.append)
    # Expect: only a's row; b's commit named and dropped from the file
    assert list(loaded) == ["a"]
    assert lines == [f"  {store.path}: stored trials of commit 2222222 set aside (now at 1111111)"]
    assert [json.loads(line)["key"] for line in store.path.read_text().splitlines()] == ["a"]


def test_a_job_is_keyed_by_its_fields_and_the_uncertainty_it_meets(tmp_path):
    job = CountedJob("cell", 3, str(tmp_path))
    assert job_key(job, "u") == job_key(CountedJob("cell", 3, str(tmp_path)), "u")
    assert job_key(job, "u") != job_key(CountedJob("cell", 4, str(tmp_path)), "u")
    assert job_key(job, "u") != job_key(job, "v")

    class Opaque:
        group = "cell"

    with pytest.raises(ValueError, match="no deterministic repr"):
        job_key(Opaque(), "u")


def test_the_progress_line_says_how_many_are_done_and_the_time_left(monkeypatch):
    clock = iter([100.0, 130.0, 160.0])
    monkeypatch.setattr("teleteach.run.engine.time.perf_counter", lambda: next(clock))
    lines = []
    meter = Progress(3, 1, lines.append)
    meter.trial_done()
    meter.trial_done()
    assert lines == [
        "  1/3 trials stored by an interrupted run: running the other 2",
        "  2/3 trials, 30 s, 2.0 per minute, about 30 s left",
        "  3/3 trials, 60 s, 2.0 per minute, done",
    ]


def test_a_cluster_without_ray_says_how_to_install_it(monkeypatch, tmp_path):
    import builtins

    real_import = builtins.__import__

    def no_ray(name, *arguments, **keywords):
        if name == "ray" or name.startswith("ray."):
            raise ImportError(name)
        return real_import(name, *arguments, **keywords)

    monkeypatch.setattr(builtins, "__import__", no_ray)
    from teleteach.run.engine import EngineError

    with pytest.raises(EngineError, match="scripts/setup --cluster"):
        run_jobs([CountedJob("cell", 0, str(tmp_path))], 1, progress=lambda line: None, cluster="auto")
