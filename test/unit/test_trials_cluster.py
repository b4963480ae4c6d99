"""Trials on a Ray cluster give the rows the local pool gives (teleteach.run.engine, issue 51: trials are tasks).

A real Ray head on 127.0.0.1 (no CPUs of its own) and two worker nodes of one CPU each, started by the test as
`ray start --block` children in a process group of their own and stopped by that group's id. Ray comes from
requirements-cluster.txt, which scripts/test installs (scripts/setup --cluster).
"""

import json
import os
import pathlib
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

import pytest

from teleteach.core.wiping import load_wiping_config
from teleteach.run.trials import run_trials
from teleteach.wiping.ablation import CELLS, jobs

pytestmark = [pytest.mark.system, pytest.mark.slow]

RAY = pathlib.Path(sys.executable).parent / "ray"
START_TIMEOUT = 120.0  # [s] for one node to join, on a loaded 2-core machine
ATTEMPTS = 3  # starts of one node
STOP_GRACE = 2.0  # [s] after SIGTERM before the nodes' process groups are killed


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def cluster_cpus(address: str) -> float:
    """The CPUs `ray status` reports for the cluster at address (-1 while it does not answer)."""
    status = subprocess.run(
        [str(RAY), "status", "--address", address], capture_output=True, text=True, timeout=60, check=False
    )
    for line in status.stdout.splitlines():
        if line.strip().endswith(" CPU") and "/" in line:
            return float(line.split("/")[1].split()[0])
    return 0.0 if status.returncode == 0 else -1.0


@pytest.fixture(scope="module")
def ray_cluster(tmp_path_factory):
    """A Ray head on 127.0.0.1 with two one-CPU worker nodes: the client address ray://127.0.0.1:PORT.

    One node at a time, each once the one before has joined: a node that cannot reach the head's GCS within Ray's 30 s
    (a loaded machine) ends, and is started again (at most ATTEMPTS times).
    """
    if not RAY.exists():
        pytest.fail(f"no {RAY}: Ray is installed by `scripts/setup --cluster`, which scripts/test runs")
    folder = tmp_path_factory.mktemp("ray")
    port, client_port = free_port(), free_port()
    address = f"127.0.0.1:{port}"
    head = [str(RAY), "start", "--block", "--head", "--node-ip-address", "127.0.0.1", "--port", str(port)]
    head += ["--ray-client-server-port", str(client_port), "--num-cpus", "0", "--include-dashboard", "false"]
    # Ray's sockets live under --temp-dir, and a UNIX socket's path is at most 107 bytes: a pytest-xdist worker's
    # tmp_path (/tmp/pytest-of-root/pytest-N/popen-gwN/...) plus Ray's session folder is longer.
    short = pathlib.Path(tempfile.mkdtemp(prefix="ray", dir="/tmp"))
    head += ["--temp-dir", str(short), "--disable-usage-stats"]
    worker = [str(RAY), "start", "--block", "--address", address, "--node-ip-address", "127.0.0.1"]
    worker += ["--num-cpus", "1", "--disable-usage-stats"]
    env = dict(os.environ, RAY_USAGE_STATS_ENABLED="0")
    started = []

    def start(command, name: str, cpus: float) -> None:
        for attempt in range(ATTEMPTS):
            log_path = folder / f"{name}.{attempt}.log"
            with open(log_path, "w") as log:
                process = subprocess.Popen(
                    command, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
                )
            started.append(process)
            deadline = time.monotonic() + START_TIMEOUT
            while process.poll() is None and time.monotonic() < deadline:
                if cluster_cpus(address) >= cpus:
                    return
                time.sleep(3.0)
            stop(process)
        logs = "\n".join(f"{path.name}: {path.read_text()[-1200:]}" for path in sorted(folder.glob(f"{name}.*.log")))
        pytest.fail(f"the Ray {name} did not join in {ATTEMPTS} attempts:\n{logs}")

    try:
        start(head, "head", 0.0)
        start(worker, "worker1", 1.0)
        start(worker, "worker2", 2.0)
        yield f"ray://127.0.0.1:{client_port}"
    finally:
        stop(*reversed(started))
        shutil.rmtree(short, ignore_errors=True)


def stop(*processes: subprocess.Popen) -> None:
    """Ends `ray start --block` processes and the Ray processes each started (its process group), all at once.

    SIGKILL after STOP_GRACE: on SIGTERM each node waits Ray's grace period (about 16 s) for its workers, and the
    cluster is thrown away with its temp folder (the teardown took 35 s of a worker's time with SIGTERM alone).
    """
    for signal_number, wait in ((signal.SIGTERM, STOP_GRACE), (signal.SIGKILL, 10.0)):
        for process in processes:
            try:
                os.killpg(process.pid, signal_number)
            except ProcessLookupError:
                pass
        deadline = time.monotonic() + wait
        for process in processes:
            try:
                process.wait(max(deadline - time.monotonic(), 0.0))
            except subprocess.TimeoutExpired:
                continue
        if all(process.poll() is not None for process in processes):
            return


def rows(results: dict) -> dict:
    """Each group's rows as text (NaN compares equal as text)."""
    return {group: [json.dumps(row, sort_keys=True) for row in trials] for group, trials in results.items()}


def test_the_same_seeds_give_the_same_wipes_on_the_pool_and_on_ray(ray_cluster, tmp_path):
    # development seeds only (wiping_ablation's held-out ones start at 4900)
    cells = {name: CELLS[name] for name in ("constant_low", "taught_anisotropic")}
    work = [job for job in jobs([0, 1], load_wiping_config()) if job.group in cells]
    lines = []
    on_pool = run_trials(work, 2, progress=lines.append)
    on_ray = run_trials(work, 1, progress=lines.append, cluster=ray_cluster, store=tmp_path / "trials.jsonl")
    # Expect: four wipes each, row for row the same; the cluster's two workers named; the store gone once all is done
    assert sum(len(trials) for trials in on_pool.values()) == 4
    assert all("error" not in row for trials in on_pool.values() for row in trials)
    assert rows(on_ray) == rows(on_pool)
    assert any("on the Ray cluster" in line and "2 workers" in line for line in lines), lines
    assert lines[-1].startswith("  4/4 trials") and lines[-1].endswith("done")
    assert not (tmp_path / "trials.jsonl").exists()
