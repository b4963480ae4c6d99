"""runtime.realtime: a control loop's threads at SCHED_FIFO, or one reason why not."""

import os
import subprocess
import sys
import threading

import pytest

from teleteach.runtime.realtime import realtime_threads


def test_priority_zero_changes_nothing(tmp_path):
    assert realtime_threads(0, tmp_path / "missing") == ""


@pytest.mark.parametrize("priority", [-1, 100])
def test_a_priority_outside_the_range_is_refused(priority):
    with pytest.raises(ValueError, match="1-99"):
        realtime_threads(priority)


def test_threads_it_cannot_list_are_named(tmp_path):
    assert realtime_threads(5, tmp_path / "missing").startswith(f"cannot list the threads in {tmp_path / 'missing'}")


def test_a_refused_scheduler_says_why(monkeypatch, tmp_path):
    (tmp_path / "123").mkdir()

    def refuse(pid, policy, parameter):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(os, "sched_setscheduler", refuse)
    assert realtime_threads(10, tmp_path) == (
        "SCHED_FIFO 10 not permitted (Operation not permitted: needs root, CAP_SYS_NICE or ulimit -r)"
    )


def test_every_thread_listed_is_set_and_one_that_ended_is_skipped(monkeypatch, tmp_path):
    for name in ("11", "12", "13", "status"):
        (tmp_path / name).mkdir()
    calls = []

    def set_scheduler(pid, policy, parameter):
        if pid == 12:
            raise ProcessLookupError(3, "No such process")
        calls.append((pid, policy, parameter.sched_priority))

    monkeypatch.setattr(os, "sched_setscheduler", set_scheduler)
    assert realtime_threads(7, tmp_path) == ""
    assert calls == [(11, os.SCHED_FIFO, 7), (13, os.SCHED_FIFO, 7)]


def test_this_process_and_a_thread_started_later_run_real_time_when_permitted():
    # In a child process (the test runner stays as it was): as root the threads become SCHED_FIFO, a thread started
    # afterwards inherits it; without the right the reason is returned and nothing changes.
    read, write = os.pipe()
    child = os.fork()
    if child == 0:
        os.close(read)
        reason = realtime_threads(1)
        seen = {}
        thread = threading.Thread(target=lambda: seen.update(policy=os.sched_getscheduler(threading.get_native_id())))
        thread.start()
        thread.join()
        os.write(write, f"{reason}|{os.sched_getscheduler(0)}|{seen['policy']}".encode())
        os._exit(0)
    os.close(write)
    reason, main, later = os.read(read, 1000).decode().split("|")
    os.waitpid(child, 0)
    if reason:
        assert "not permitted" in reason and int(main) == int(later) == os.SCHED_OTHER
    else:
        assert int(main) == int(later) == os.SCHED_FIFO


def run_prefix(*arguments):
    return subprocess.run(
        [sys.executable, "-m", "teleteach.runtime.realtime", *arguments], capture_output=True, text=True, timeout=60
    )


def test_as_a_launch_prefix_the_command_replaces_it_at_the_priority_or_as_usual_with_one_line():
    policy = "import os, threading; print(os.sched_getscheduler(0))"
    ordinary = run_prefix("0", "probe", sys.executable, "-c", policy)
    assert (ordinary.returncode, ordinary.stdout.strip(), ordinary.stderr) == (0, str(os.SCHED_OTHER), "")
    raised = run_prefix("1", "probe", sys.executable, "-c", policy)
    assert raised.returncode == 0
    if raised.stderr:
        assert raised.stderr.startswith("probe: runs at the ordinary priority, its cycles may come out late")
        assert raised.stdout.strip() == str(os.SCHED_OTHER)
    else:
        assert raised.stdout.strip() == str(os.SCHED_FIFO)


@pytest.mark.parametrize("arguments", [(), ("10", "probe"), ("ten", "probe", "true")])
def test_a_prefix_without_priority_name_and_command_says_how(arguments):
    result = run_prefix(*arguments)
    assert (result.returncode, result.stderr.strip()) == (
        2,
        "usage: python3 -m teleteach.runtime.realtime PRIORITY NAME COMMAND [ARGUMENT ...]",
    )


def test_a_prefix_priority_out_of_range_is_refused_before_the_command_runs():
    result = run_prefix("100", "probe", "true")
    assert (result.returncode, result.stderr.strip()) == (2, "probe: a real-time priority is 1-99 (0: none), got 100")
