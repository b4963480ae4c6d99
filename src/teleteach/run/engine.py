"""Where a bench's trials run (a local process pool or a Ray cluster), which are done already, how long is left.

A trial job (``run.trials.TrialJob``, ``wiping.ablation.WipeJob``, ...) has a ``group``, a ``seed`` (or a ``setup``
with one) and ``run(process)``: a pure function of its own fields and of what a worker loads once (the scene, the
motion configuration, the uncertainty, the Panda's kinematics), seeded by the job alone, returning a row judged from
the world. The engine only maps jobs onto workers, so the same jobs give the same rows on the pool and on a cluster
(``test/unit/test_trials_cluster.py`` compares them on a real local Ray head).

- The pool (default): ``processes`` spawned processes on this machine, each loading once.
- Ray (``cluster``: ``ray://HOST:PORT``, a cluster's client server, or ``auto``, the cluster this machine is a node
  of): one warm actor per CPU of the cluster (``ray.util.ActorPool``), each loading once from its own checkout, which
  must be at this checkout's commit. Ray is optional (``requirements-cluster.txt``, ``scripts/setup --cluster``) and
  imported here only, only when asked for.
- Both give a trial one BLAS thread (Ray sets ``OMP_NUM_THREADS=1`` for a one-CPU actor; the pool's processes get
  the same), so no row depends on how many threads a worker's linear algebra used.
- A store (optional): each finished row is appended to a JSON-lines file as one line, keyed by its job and the
  uncertainty file; a run that finds the file, at the same commit, runs only the jobs not in it and takes the rest
  from it (an interrupted bench continues where it stopped). A torn last line (the run killed while writing) is
  ignored. The file is removed once every job is done: a later run measures afresh.
"""

import dataclasses
import hashlib
import json
import multiprocessing
import os
import pathlib
import tempfile
import time
from typing import Callable, Dict, Iterator, List, Optional, Sequence, Tuple

from teleteach.control.kinematics import PandaKinematics
from teleteach.core.scene import load_scene
from teleteach.run.provenance import commit
from teleteach.sim.uncertainty import DEFAULT_UNCERTAINTY_FILE, load_uncertainty
from teleteach.skills.config import load_motion_config

THREADS = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}  # one BLAS thread per trial, as Ray's 1-CPU actors
PROGRESS_STEPS = 20  # progress lines per run (and one per trial when fewer)
CONNECT_ATTEMPTS = 3  # connections to a cluster before giving up
PACE_AFTER = 4  # trials finished before the pace is counted from the first one (until then: from the start)


class EngineError(RuntimeError):
    """The cluster cannot be reached or used (Ray not installed, no CPUs, a worker at another commit)."""


# --- what a worker loads once --------------------------------------------------------------------
_process: dict = {}


def _start_process(uncertainty_file: Optional[str]) -> None:
    scene = load_scene()
    _process.update(
        scene=scene,
        config=load_motion_config(),
        uncertainty=load_uncertainty(uncertainty_file),
        kinematics=PandaKinematics(scene.robot.mount_height),
    )


def _run_item(item: Tuple[int, object]) -> Tuple[int, dict]:
    index, job = item
    return index, job.run(_process)


class TrialWorker:
    """A Ray actor: loads what the trials need once, then runs jobs (the pool's process, on a cluster).

    Args:
        uncertainty_text: the uncertainty file's text as the driver read it (None: the worker's default), so a worker
            on another machine meets the same world.
    """

    def __init__(self, uncertainty_text: Optional[str]):
        path = None
        if uncertainty_text is not None:
            handle, path = tempfile.mkstemp(prefix="teleteach-uncertainty-", suffix=".yaml")
            with os.fdopen(handle, "w") as file:
                file.write(uncertainty_text)
        _start_process(path)
        self._commit = commit()

    def commit(self) -> str:
        """The commit of the checkout this worker imported teleteach from."""
        return self._commit

    def run(self, item: Tuple[int, object]) -> Tuple[int, dict]:
        """One job (with its index in the run), in this worker."""
        return _run_item(item)


# --- the store of finished trials ------------------------------------------------------------------
def job_key(job, uncertainty_digest: str) -> str:
    """A job's key in the store: its fields (a dataclass' repr, deterministic) and the uncertainty it meets."""
    text = repr(job)
    if " at 0x" in text:
        raise ValueError(f"{type(job).__name__} has no deterministic repr: it cannot be stored and resumed")
    return hashlib.sha256(f"{text}|{uncertainty_digest}".encode()).hexdigest()


@dataclasses.dataclass
class TrialStore:
    """The finished trials of a run, one JSON line each: ``{"key", "commit", "group", "result"}``."""

    path: pathlib.Path

    def load(self, this_commit: str, progress: Callable[[str], None]) -> Dict[str, dict]:
        """The stored rows by key; rows of another commit are set aside (the file is started anew), with a line."""
        if not self.path.exists():
            return {}
        rows, other = {}, set()
        for line in self.path.read_text().splitlines():
            try:
                entry = json.loads(line)
            except json.JSONDecodeError:
                continue  # the last line of a run killed while writing it
            if entry.get("commit") == this_commit:
                rows[entry["key"]] = entry
            else:
                other.add(entry.get("commit", "?")[:7])
        if other:
            commits = ", ".join(sorted(other))
            progress(f"  {self.path}: stored trials of commit {commits} set aside (now at {this_commit[:7]})")
            self.path.write_text("".join(json.dumps(entry) + "\n" for entry in rows.values()))
        return rows

    def append(self, entry: dict) -> None:
        """One finished trial: one line in one write, flushed to the disk before the next trial is counted."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        line = (json.dumps(entry, default=_plain) + "\n").encode()
        descriptor = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(descriptor, line)
            os.fsync(descriptor)
        finally:
            os.close(descriptor)

    def remove(self) -> None:
        """Every job is done: the next run measures afresh."""
        self.path.unlink(missing_ok=True)


def _plain(value):
    """A row's numpy arrays and numbers, and other sequences, as JSON has them (lists, numbers)."""
    return value.tolist() if hasattr(value, "tolist") else list(value)


# --- progress ------------------------------------------------------------------------------------
def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.1f} min"


class Progress:
    """A line every 1/PROGRESS_STEPS of the trials: done (and stored) trials, the time, the pace, the time left.

    The pace counts from the first trial this run finished: the workers' start is not a trial's cost.
    """

    def __init__(self, total: int, stored: int, say: Callable[[str], None]):
        self.total, self.stored, self.say = total, stored, say
        self.done, self.start = stored, time.perf_counter()
        self.first = self.start  # when the first trial of this run finished
        self.step = max(1, total // PROGRESS_STEPS)
        if stored:
            say(f"  {stored}/{total} trials stored by an interrupted run: running the other {total - stored}")

    def trial_done(self) -> None:
        """One more trial finished in this run."""
        self.done += 1
        if self.done % self.step and self.done != self.total:
            return
        now = time.perf_counter()
        elapsed, ran = now - self.start, self.done - self.stored
        if ran == 1:
            self.first = now
        # the pace from the first finished trial on, once a few more have finished (workers finish together): the
        # workers' start (seconds on a cluster) is not a trial's cost
        pace = (now - self.first) / (ran - 1) if ran > PACE_AFTER and now > self.first else elapsed / ran
        left = pace * (self.total - self.done)
        rate = 60.0 / pace if pace > 0 else 0.0
        self.say(
            f"  {self.done}/{self.total} trials, {_duration(elapsed)}, {rate:.1f} per minute, "
            + ("done" if self.done == self.total else f"about {_duration(left)} left")
        )


# --- the two engines -----------------------------------------------------------------------------
def _on_pool(items: List[Tuple[int, object]], processes: int, uncertainty_file: Optional[str]) -> Iterator:
    saved = {name: os.environ.get(name) for name in THREADS}
    os.environ.update(THREADS)  # the spawned processes start with it, before they import numpy
    try:
        context = multiprocessing.get_context("spawn")
        with context.Pool(processes, initializer=_start_process, initargs=(uncertainty_file,)) as pool:
            yield from pool.imap_unordered(_run_item, items)
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def _import_ray():
    try:
        import ray
        from ray.util import ActorPool
    except ImportError:
        raise EngineError(
            "--cluster needs Ray, which the default install leaves out: run `bash scripts/setup --cluster` "
            "(requirements-cluster.txt)"
        ) from None
    return ray, ActorPool


def _on_ray(
    items: List[Tuple[int, object]], cluster: str, uncertainty_file: Optional[str], say: Callable[[str], None]
) -> Iterator:
    ray, actor_pool = _import_ray()
    text = pathlib.Path(uncertainty_file).read_text() if uncertainty_file else None
    for attempt in range(1, CONNECT_ATTEMPTS + 1):
        try:
            ray.init(address=cluster, logging_level="WARNING", log_to_driver=False)
            break
        except Exception as error:  # Ray raises ConnectionError, RuntimeError, ValueError, grpc's errors
            ray.shutdown()
            if attempt == CONNECT_ATTEMPTS:
                raise EngineError(f"cannot connect to the Ray cluster at {cluster}: {error}") from None
            # a loaded head can fail to start the client's server once: its error is one line of many
            say(f"  the Ray cluster at {cluster} refused the connection ({str(error).splitlines()[0]}); again")
    try:
        cpus = int(ray.cluster_resources().get("CPU", 0))
        if cpus < 1:
            raise EngineError(f"the Ray cluster at {cluster} has no CPUs to run trials on")
        worker = ray.remote(num_cpus=1)(TrialWorker)
        actors = [worker.remote(text) for _ in range(min(cpus, len(items)))]
        here = commit()
        for found in set(ray.get([actor.commit.remote() for actor in actors])):
            if found != here:
                raise EngineError(
                    f"a worker of the Ray cluster runs teleteach at commit {found[:7]}, this checkout is at "
                    f"{here[:7]}: the same seeds would not give the same trials (check out {here[:7]} there)"
                )
        say(f"  on the Ray cluster {cluster}: {len(actors)} workers")
        yield from actor_pool(actors).map_unordered(lambda actor, item: actor.run.remote(item), items)
    finally:
        ray.shutdown()


def run_jobs(
    jobs: Sequence,
    processes: int,
    progress: Callable[[str], None] = print,
    uncertainty_file: Optional[str] = None,
    cluster: Optional[str] = None,
    store: Optional[pathlib.Path] = None,
) -> List[Tuple[object, dict]]:
    """Every job's row, in the order of ``jobs``: stored rows taken, the others run on the pool or the cluster.

    Args:
        jobs: the trial jobs (see the module's docstring).
        processes: parallel simulations of the local pool (ignored on a cluster: one per CPU there).
        progress: where the progress lines go.
        uncertainty_file: the world's uncertainty (None: config/uncertainty.yaml); on a cluster its text is sent.
        cluster: None (the pool), ``ray://HOST:PORT`` or ``auto``.
        store: the JSON-lines file of finished trials (None: nothing stored, nothing resumed).
    """
    load_uncertainty(uncertainty_file)  # a bad file is named here, once, not in every worker
    uncertainty_path = pathlib.Path(uncertainty_file) if uncertainty_file else DEFAULT_UNCERTAINTY_FILE
    digest = hashlib.sha256(uncertainty_path.read_bytes()).hexdigest()
    keys = [job_key(job, digest) for job in jobs] if store else [None] * len(jobs)
    here = commit() if store else ""
    trial_store = TrialStore(store) if store else None
    stored = trial_store.load(here, progress) if trial_store else {}
    rows: List[Optional[dict]] = [stored[key]["result"] if key in stored else None for key in keys]
    items = [(index, job) for index, job in enumerate(jobs) if rows[index] is None]
    meter = Progress(len(jobs), len(jobs) - len(items), progress)
    if items:
        finished = (
            _on_ray(items, cluster, uncertainty_file, progress)
            if cluster
            else _on_pool(items, min(processes, len(items)), uncertainty_file)
        )
        for index, row in finished:
            rows[index] = row
            if trial_store:
                trial_store.append({"key": keys[index], "commit": here, "group": jobs[index].group, "result": row})
            meter.trial_done()
    if trial_store:
        trial_store.remove()
    return list(zip(jobs, rows))
