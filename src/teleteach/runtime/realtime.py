"""A control loop's threads at a real-time priority, so that ordinary processes do not make its cycles late.

Measured by bench/wiping_rate.py (issue 49) on two cores shared with other work: the shared controller's cycle needs
about 2.5 ms of CPU in its 20 ms, yet 2-5 % of its cycles came out late, nearly all because its threads waited for a
core (a cycle of 3 ms CPU took 30-80 ms of wall time; the loop woke 30-110 ms after its slot), not because a solve
was slow. With every thread of the node at SCHED_FIFO (priority 10), the same machine gave 0-0.1 % late cycles. A
real-time thread preempts every ordinary process when it wakes; the kernel still keeps 5 % of each second for
ordinary ones (sched_rt_runtime_us), so a runaway loop cannot lock the machine up.

Linux only, and only with the right (root, CAP_SYS_NICE or an rtprio limit: ``ulimit -r``, /etc/security/limits.conf);
without it the loop runs as before and says so in one line.

As a launch-prefix (launch/shared_control.launch's ``realtime_priority``)::

    python3 -m teleteach.runtime.realtime PRIORITY NAME COMMAND [ARGUMENT ...]

sets this process to SCHED_FIFO ``PRIORITY`` and replaces it with COMMAND (exec), so every thread the node starts
inherits the priority; NAME is the node's, for the one line printed when it is not permitted. Child processes inherit
it too: a shared controller that compiles its solvers on its first start (no cache from scripts/setup) compiles at
that priority, on one core.
"""

import os
import pathlib
import sys
from typing import Sequence

MAX_PRIORITY = 99  # SCHED_FIFO's range is 1-99 on Linux


def realtime_threads(priority: int, tasks: pathlib.Path = pathlib.Path("/proc/self/task")) -> str:
    """Every thread of this process at SCHED_FIFO ``priority`` (threads started later inherit it); "" when done.

    ``priority`` 0 changes nothing. Returns why it could not (no permission, no such scheduler), in a few words for
    the caller's one line; raises ValueError for a priority outside 0-99.
    """
    if not 0 <= int(priority) <= MAX_PRIORITY:
        raise ValueError(f"a real-time priority is 1-{MAX_PRIORITY} (0: none), got {priority}")
    if priority == 0:
        return ""
    if not hasattr(os, "sched_setscheduler"):
        return "this system has no real-time scheduler (sched_setscheduler)"
    parameter = os.sched_param(int(priority))
    try:
        threads = sorted(int(entry.name) for entry in tasks.iterdir() if entry.name.isdigit())
    except OSError as error:
        return f"cannot list the threads in {tasks}: {error.strerror}"
    for thread in threads:
        try:
            os.sched_setscheduler(thread, os.SCHED_FIFO, parameter)
        except ProcessLookupError:
            continue  # the thread ended meanwhile
        except OSError as error:
            return f"SCHED_FIFO {priority} not permitted ({error.strerror}: needs root, CAP_SYS_NICE or ulimit -r)"
    return ""


def main(argv: Sequence[str]) -> int:
    """``PRIORITY NAME COMMAND ...``: COMMAND run in this process at SCHED_FIFO PRIORITY (as usual when refused)."""
    if len(argv) < 3 or not argv[0].isdigit():
        print("usage: python3 -m teleteach.runtime.realtime PRIORITY NAME COMMAND [ARGUMENT ...]", file=sys.stderr)
        return 2
    priority, name, command = int(argv[0]), argv[1], list(argv[2:])
    try:
        reason = realtime_threads(priority)
    except ValueError as error:
        print(f"{name}: {error}", file=sys.stderr)
        return 2
    if reason:
        print(
            f"{name}: runs at the ordinary priority, its cycles may come out late on a busy machine: {reason}",
            file=sys.stderr,
            flush=True,
        )
    os.execvp(command[0], command)
    return 1  # not reached: exec replaces this process


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
