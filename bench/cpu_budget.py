"""Benchmark: the whole system's CPU, node by node, in the phases of a teaching session (issue 33's budget).

Question: what does each node of full.launch cost, in % of one core, while the tree runs its program, once it has
finished (Idle holding the arm, nothing changing), while the operator records a LOW-LEVEL demonstration, while SHARED
CONTROL drives the arm, and over the whole thesis scenario (the main job)?

Method: each node's process is found through its XML-RPC ``getPid``; its CPU time is read from /proc/<pid>/stat
(utime + stime, all threads) at the start and the end of a window of wall time. CPU time is far less sensitive to
other processes' load than wall time, not insensitive (a loaded machine delays messages and timers, and caches are
shared): every phase is printed with the load average of the minute before it ended, and the real-time factor of
the simulation (robot_sim's /diagnostics) during the window. Each run has its own roscore on a free port and its own
Xvfb when DISPLAY is unset.

Runs (``--runs``, all three by default):

- ``virtual``: ``full.launch device:=virtual rviz:=false start_paused:=false`` (an operator at a screen, without
  RViz; the tree runs at once, not waiting for the operator's start as it does by default with this device). Phases
  ``tree_running`` (a window inside the tree's program, from the first skill on) and ``idle`` (the program has
  finished: the tree's root succeeded).
- ``teaching``: ``full.launch device:=scenario rviz:=false`` with bench/data/cpu_budget_operator.yaml: the scripted
  operator waits for the program to end, then records a stiffness demonstration (phase ``low_level``: LOW-LEVEL
  open, recording on), then draws a wave in SHARED CONTROL (phase ``shared_control``: the MPC enabled and driving).
- ``thesis``: what ``run_thesis`` launches (``headless:=true device:=scenario``, config/scenarios/thesis_full.yaml,
  ``record:=true``); phase ``thesis``: from the scenario's start to the end of the scenario and the tree.

Goals (issue 33): idle: total <= 60 %; skill_server, behaviour_tree, shared_control and ellipsoid_marker <= 2 %
each; teaching_gui <= 10 %; sigma7_node <= 15 %; robot_sim <= 30 % (at real-time factor 1). thesis: total <= 100 %.
The table compares each figure with its goal and, with ``--baseline FILE`` (an earlier cpu_budget.json), with that.
``--launch-args`` adds full.launch arguments to every run (e.g. ``clock_rate:=100``: what a coarser clock would save).
``--profile NODE ...`` samples those nodes with py-spy (100 Hz, running threads only) over every window: where their CPU
goes, as the functions the samples were in (their own time, callees not included) and the share of the samples each
took; the raw stacks go to bench/results/cpu_budget_profiles/<phase>_<node>.txt (flamegraph.pl's input).

Writes bench/results/cpu_budget.json: {phase: {node: percent_of_one_core, "total": ...}} and, beside the phases,
"context" (per phase: window, load average, real-time factor) and "outside" (per phase: the processes that are no
node of the system: roslaunch, rosmaster, Xvfb, and ``floor``: a rospy node that does nothing on the same master,
i.e. what any rospy node pays for /clock under /use_sim_time) and, with --profile, "profiles" (per phase and node: the
hottest functions, [function, % of the samples]).

    source build/env.sh && python bench/cpu_budget.py [--runs virtual teaching thesis] [--window 20]
        [--baseline bench/results/cpu_budget_before.json] [--profile robot_sim teaching_gui]
"""

import argparse
import collections
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import xmlrpc.client

from teleteach.runtime.experiment import Experiment, SystemEndedError
from teleteach.runtime.processes import master_pid

ROOT = pathlib.Path(__file__).resolve().parents[1]
RESULTS = ROOT / "bench" / "results"
OPERATOR = ROOT / "bench" / "data" / "cpu_budget_operator.yaml"
THESIS = ROOT / "config" / "scenarios" / "thesis_full.yaml"
EXECUTION = "BehaviorExecution"
LOW_LEVEL, SHARED_CONTROL = 2, 3

GOALS = {
    "idle": {
        "total": 60.0,
        "skill_server": 2.0,
        "behaviour_tree": 2.0,
        "shared_control": 2.0,
        "ellipsoid_marker": 2.0,
        "teaching_gui": 10.0,
        "sigma7_node": 15.0,
        "robot_sim": 30.0,
    },
    "thesis": {"total": 100.0},
}
PHASES = ("tree_running", "idle", "low_level", "shared_control", "thesis")
FLOOR = "import rospy; rospy.init_node('cpu_budget_floor'); rospy.spin()"
PROFILES = RESULTS / "cpu_budget_profiles"
HOT_FUNCTIONS = 8  # per node and phase in the printed profile


def cpu_seconds(pid):
    """utime + stime of a process, all its threads [s]; None when it is gone."""
    try:
        fields = pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def process_name(pid):
    """The command name of a process ("" when it is gone)."""
    try:
        return pathlib.Path(f"/proc/{pid}/comm").read_text().strip()
    except OSError:
        return ""


def children(parent):
    """Process ids whose parent is ``parent``."""
    from teleteach.runtime.processes import parent_pid

    return [
        int(entry.name)
        for entry in pathlib.Path("/proc").iterdir()
        if entry.name.isdigit() and parent_pid(int(entry.name)) == parent
    ]


def node_pids(master_uri):
    """{node name without its leading slash: pid} of every node registered with the master."""
    import rosgraph

    master = rosgraph.Master("/cpu_budget_bench", master_uri=master_uri)
    publishers, subscribers, services = master.getSystemState()
    names = {node for _, nodes in publishers + subscribers + services for node in nodes}
    pids = {}
    for name in names:
        try:
            code, _, pid = xmlrpc.client.ServerProxy(master.lookupNode(name)).getPid("/cpu_budget_bench")
        except (OSError, xmlrpc.client.Error, rosgraph.MasterError):
            continue
        if code == 1 and pid != os.getpid():
            pids[name.lstrip("/")] = pid
    return pids


def short_name(node):
    """rosbag's and anonymous nodes' names end in _<pid>_<stamp>: the bench names them by their kind."""
    if node.startswith("record_") or node.startswith("session_bag"):
        return "recorder"
    return node


class Watcher:
    """What the bench needs to know of the running system: the tree, the GUI's tab and recording, the sim's factor."""

    def __init__(self):
        import rospy
        from diagnostic_msgs.msg import DiagnosticArray
        from std_msgs.msg import Bool, Int8

        from teleteach.msg import BehaviourTree

        self._lock = threading.Lock()
        self.running = frozenset()
        self.finished = False
        self.tab = 0
        self.recording = False
        self.factors = []
        self._subscribers = [
            rospy.Subscriber("behaviour_tree/log/tree", BehaviourTree, self._on_tree, queue_size=20),
            rospy.Subscriber("teleteach/active_tab", Int8, self._on_tab, queue_size=5),
            rospy.Subscriber("teleteach/recording", Bool, self._on_recording, queue_size=5),
            rospy.Subscriber("diagnostics", DiagnosticArray, self._on_diagnostics, queue_size=5),
        ]

    def _on_tree(self, message):
        from teleteach.msg import Behaviour

        by_id = {behaviour.own_id: behaviour for behaviour in message.behaviours}
        root = next((b for b in message.behaviours if b.parent_id not in by_id), None)
        execution = next((b for b in message.behaviours if b.name == EXECUTION), None)
        with self._lock:
            self.running = frozenset(b.name for b in message.behaviours if b.status == Behaviour.RUNNING)
            self.finished = all(node is not None and node.status == Behaviour.SUCCESS for node in (root, execution))

    def _on_tab(self, message):
        with self._lock:
            self.tab = int(message.data)

    def _on_recording(self, message):
        with self._lock:
            self.recording = bool(message.data)

    def _on_diagnostics(self, message):
        for status in message.status:
            if status.name == "robot_sim":
                values = {value.key: value.value for value in status.values}
                with self._lock:
                    self.factors.append((time.monotonic(), float(values.get("real_time_factor", "nan"))))

    def factor_between(self, start, end):
        """Mean real-time factor reported between two monotonic times (None without a report)."""
        with self._lock:
            values = [factor for stamp, factor in self.factors if start <= stamp <= end]
        return sum(values) / len(values) if values else None

    def close(self):
        for subscriber in self._subscribers:
            subscriber.unregister()


class System(Experiment):
    """One full.launch on its own master (and Xvfb when there is no display), stopped in reverse order."""

    def __init__(self, name, launch_args, log):
        super().__init__(log.parent, pathlib.Path(tempfile.mkdtemp(prefix=f"cpu_budget_{name}_")))
        self.name = name
        self.xvfb_pid = None
        if self.own_display():
            self.xvfb_pid = next(pid for pid in children(os.getpid()) if process_name(pid) == "Xvfb")
        log.unlink(missing_ok=True)

        def command(port):
            return [
                "roslaunch",
                "-p",
                str(port),
                "teleteach",
                "full.launch",
                *launch_args,
                f"data_dir:={self.data_root}",
            ]

        self.launch = self.own_launch(command, log)
        self.log = log
        self.floor = None

    def start_floor(self):
        """The do-nothing node, once roslaunch has set /use_sim_time (rospy reads it when the node starts)."""
        self.floor = self.start("floor", [sys.executable, "-c", FLOOR])

    def master_pid(self):
        return master_pid(self.master_uri)


def measure(system, watcher, seconds, phase, profiled, until=None):
    """CPU of every node (and of roslaunch, rosmaster, Xvfb) over ``seconds`` of wall time, or until ``until()``;
    the nodes in ``profiled`` sampled with py-spy meanwhile."""
    pids = {node: pid for node, pid in node_pids(system.master_uri).items() if pid != system.floor.pid}
    outside = {"roslaunch": system.launch.pid, "rosmaster": system.master_pid(), "floor": system.floor.pid}
    if system.xvfb_pid is not None:
        outside["Xvfb"] = system.xvfb_pid
    processes = {**{short_name(node): pid for node, pid in pids.items()}, **outside}
    samplers = start_profiles({node: processes[node] for node in profiled if node in processes}, seconds, phase)
    started = time.monotonic()
    before = {name: cpu_seconds(pid) for name, pid in processes.items() if pid}
    end = started + seconds
    while time.monotonic() < end and system.launch.poll() is None and not (until is not None and until()):
        time.sleep(0.2)
    after = {name: cpu_seconds(pid) for name, pid in processes.items() if pid}
    wall = time.monotonic() - started
    profiles = {node: hot_functions(stop_profile(sampler, raw)) for node, (sampler, raw) in samplers.items()}
    percent = {
        name: round(100.0 * (after[name] - before[name]) / wall, 1)
        for name in before
        if before[name] is not None and after.get(name) is not None
    }
    nodes = {name: value for name, value in percent.items() if name not in outside}
    nodes["total"] = round(sum(nodes.values()), 1)
    factor = watcher.factor_between(started, time.monotonic())
    context = {
        "window_s": round(wall, 1),
        "load_average_1min": round(os.getloadavg()[0], 2),
        "real_time_factor": None if factor is None else round(factor, 3),
    }
    print(
        f"cpu_budget: {phase}: {wall:.1f} s, total {nodes['total']:.1f} % of one core, "
        f"load {context['load_average_1min']}, real-time factor {context['real_time_factor']}",
        flush=True,
    )
    return nodes, {name: value for name, value in percent.items() if name in outside}, context, profiles


def start_profiles(pids, seconds, phase):
    """{node: (py-spy recording it for ``seconds``, its raw stack file)}; py-spy never pauses the node."""
    if not pids:
        return {}
    spy = shutil.which("py-spy")
    if spy is None:
        raise RuntimeError("py-spy is not installed (requirements.txt; bash scripts/setup installs it)")
    PROFILES.mkdir(parents=True, exist_ok=True)
    samplers = {}
    for node, pid in pids.items():
        raw = PROFILES / f"{phase}_{node}.txt"
        raw.unlink(missing_ok=True)
        command = [spy, "record", "--pid", str(pid), "--duration", str(max(1, round(seconds))), "--rate", "100"]
        command += ["--format", "raw", "--function", "--nonblocking", "--output", str(raw)]
        log = raw.with_suffix(".log").open("w")
        samplers[node] = (subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT), raw)
        log.close()
    return samplers


def stop_profile(sampler, raw):
    """The raw stacks of a recording, once py-spy wrote them (it is told to stop when the window ended early)."""
    try:
        sampler.wait(timeout=10.0)
    except subprocess.TimeoutExpired:
        sampler.send_signal(2)  # py-spy writes what it has on SIGINT
        sampler.wait(timeout=10.0)
    return raw.read_text() if raw.exists() else ""


def hot_functions(stacks, count=HOT_FUNCTIONS):
    """[[function (file), % of the samples]] of the functions the samples were in, hottest first.

    ``stacks``: py-spy's raw format, one line per distinct stack: "outer (file:line);...;inner (file:line) samples".
    """
    own = collections.Counter()
    for line in stacks.splitlines():
        frames, _, samples = line.rpartition(" ")
        if frames and samples.isdigit():
            function, _, where = frames.rsplit(";", 1)[-1].partition(" (")
            own[f"{function} ({pathlib.Path(where.rsplit(':', 1)[0]).name})"] += int(samples)
    total = sum(own.values())
    return [[function, round(100.0 * samples / total, 1)] for function, samples in own.most_common(count)]


def wait_for(system, condition, timeout, what):
    """Poll ``condition()`` (5 Hz) for at most ``timeout`` s of wall time."""
    try:
        happened = system.wait_until(condition, timeout)
    except SystemEndedError as ended:
        raise RuntimeError(f"{system.name}: {ended} while waiting for {what}") from ended
    if not happened:
        raise RuntimeError(f"{system.name}: no {what} within {timeout:.0f} s; see {system.log}")


def start_system(name, launch_args, log):
    """The system, rospy initialised against its master, and a watcher."""
    system = System(name, launch_args, log)
    system.join("cpu_budget_bench", anonymous=True)  # one run per process: rospy reads the master at init
    import rospy

    wait_for(system, lambda: rospy.has_param("/use_sim_time"), 60, "/use_sim_time")
    system.start_floor()
    return system, Watcher()


def run_virtual(window, log, extra, profiled):
    """tree_running and idle, with the virtual device."""
    system, watcher = start_system("virtual", ["device:=virtual", "rviz:=false", "start_paused:=false", *extra], log)
    try:
        wait_for(system, lambda: watcher.running - {EXECUTION, "Root", "PauseCondition"}, 120, "running skill")
        time.sleep(3.0)  # the nodes' start-up is over
        phases = {
            "tree_running": measure(system, watcher, window, "tree_running", profiled, until=lambda: watcher.finished)
        }
        wait_for(system, lambda: watcher.finished, 300, "end of the tree's program")
        time.sleep(3.0)
        phases["idle"] = measure(system, watcher, window, "idle", profiled)
        return phases
    finally:
        watcher.close()
        system.close()


def run_teaching(window, log, extra, profiled):
    """low_level and shared_control, with the scripted operator of bench/data/cpu_budget_operator.yaml."""
    args = ["device:=scenario", f"scenario:={OPERATOR}", "rviz:=false", *extra]
    system, watcher = start_system("teaching", args, log)
    try:
        recording = lambda: watcher.tab == LOW_LEVEL and watcher.recording  # noqa: E731
        wait_for(system, recording, 400, "LOW-LEVEL recording")
        time.sleep(2.0)  # the controller switch and the trajectory's start
        phases = {
            "low_level": measure(system, watcher, window, "low_level", profiled, until=lambda: not watcher.recording)
        }
        wait_for(system, lambda: watcher.tab == SHARED_CONTROL, 400, "SHARED CONTROL tab")
        time.sleep(4.0)  # the reference reaches the task plane, the wave begins
        shared = measure(
            system, watcher, window, "shared_control", profiled, until=lambda: watcher.tab != SHARED_CONTROL
        )
        phases["shared_control"] = shared
        return phases
    finally:
        watcher.close()
        system.close()


def run_thesis(window, log, extra, profiled):
    """The main job's launch; one window from the scenario's start to the end of the scenario and the tree."""
    import rospy

    args = ["headless:=true", "device:=scenario", f"scenario:={THESIS}", "record:=true", "rviz:=false", *extra]
    system, watcher = start_system("thesis", args, log)
    try:
        wait_for(system, lambda: rospy.has_param("/sigma7_node/scenario_start"), 120, "scenario start")
        played = lambda: rospy.get_param("/sigma7_node/scenario_played", False) and watcher.finished  # noqa: E731
        return {"thesis": measure(system, watcher, 600, "thesis", profiled, until=played)}
    finally:
        watcher.close()
        system.close()


RUNS = {"virtual": run_virtual, "teaching": run_teaching, "thesis": run_thesis}


def table(results, baseline):
    """One row per node, one column per phase (figure, and the baseline's when given); goals marked."""
    phases = [phase for phase in PHASES if phase in results]
    ranked = sorted(
        {node for phase in phases for node in results[phase] if node != "total"},
        key=lambda node: -max(results[phase].get(node, 0.0) for phase in phases),
    )
    nodes = [*ranked, "total"]
    lines = ["| node | " + " | ".join(phases) + " |", "|---" * (len(phases) + 1) + "|"]
    for node in nodes:
        cells = []
        for phase in phases:
            value = results[phase].get(node)
            cell = "-" if value is None else f"{value:.1f}"
            before = (baseline or {}).get(phase, {}).get(node)
            if before is not None:
                cell = f"{before:.1f} -> {cell}"
            goal = GOALS.get(phase, {}).get(node)
            if goal is not None and value is not None:
                cell += f" ({'ok' if value <= goal else 'OVER'} <= {goal:g})"
            cells.append(cell)
        lines.append(f"| {node} | " + " | ".join(cells) + " |")
    for key, label in (("load_average_1min", "load average (1 min)"), ("real_time_factor", "real-time factor")):
        lines.append(f"| {label} | " + " | ".join(str(results["context"][phase][key]) for phase in phases) + " |")
    outside = sorted({name for phase in phases for name in results["outside"][phase]})
    for name in outside:
        values = [results["outside"][phase].get(name) for phase in phases]
        lines.append(f"| ({name}) | " + " | ".join("-" if v is None else f"{v:.1f}" for v in values) + " |")
    return "\n".join(lines)


def profile_text(results):
    """Each profiled node's hottest functions, per phase, with the node's CPU in that phase."""
    lines = []
    for phase, nodes in results["profiles"].items():
        for node, functions in nodes.items():
            cpu = results[phase].get(node, results["outside"][phase].get(node, 0.0))
            lines.append(f"{node} in {phase} ({cpu:.1f} % of one core), own time:")
            lines.extend(f"  {share:5.1f} %  {function}" for function, share in functions)
            if not functions:
                lines.append(f"  no samples: see {PROFILES / f'{phase}_{node}.log'}")
    return "\n".join(lines)


def run_one(name, window, output, extra, profiled):
    """One run in this process (rospy talks to one master per process): its phases into ``output``."""
    results = {"context": {}, "outside": {}, "profiles": {}}
    for phase, (nodes, outside, context, profiles) in RUNS[name](
        window, output.with_suffix(".log"), extra, profiled
    ).items():
        results[phase] = nodes
        results["outside"][phase] = outside
        results["context"][phase] = context
        results["profiles"][phase] = profiles
    output.write_text(json.dumps(results, indent=2) + "\n")
    import rospy

    rospy.signal_shutdown("cpu_budget run done")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", nargs="+", choices=sorted(RUNS), default=list(RUNS))
    parser.add_argument("--window", type=float, default=20.0, help="[s] wall time of each window but thesis'")
    parser.add_argument("--baseline", type=pathlib.Path, help="an earlier cpu_budget.json to compare with")
    parser.add_argument("--output", type=pathlib.Path, default=RESULTS / "cpu_budget.json")
    parser.add_argument("--launch-args", nargs="*", default=[], help="more full.launch arguments, e.g. clock_rate:=100")
    parser.add_argument("--profile", nargs="*", default=[], metavar="NODE", help="nodes to sample with py-spy")
    parser.add_argument("--one", choices=sorted(RUNS), help=argparse.SUPPRESS)  # a child: one run, to --output
    options = parser.parse_args(argv)
    if options.one:
        run_one(options.one, options.window, options.output, options.launch_args, options.profile)
        return 0
    options.output.parent.mkdir(parents=True, exist_ok=True)
    results = {"context": {}, "outside": {}, "profiles": {}}
    for name in options.runs:
        part = options.output.parent / f"{options.output.stem}_{name}.json"
        command = [sys.executable, __file__, "--one", name, "--window", str(options.window), "--output", str(part)]
        command += ["--launch-args", *options.launch_args, "--profile", *options.profile]
        part.unlink(missing_ok=True)
        if subprocess.run(command, check=False).returncode != 0 or not part.exists():
            print(f"cpu_budget: the {name} run failed (its log: {part.with_suffix('.log')})")
            continue
        for key, value in json.loads(part.read_text()).items():
            if key in results:
                results[key].update(value)
            else:
                results[key] = value
    baseline = json.loads(options.baseline.read_text()) if options.baseline else None
    print(table(results, baseline))
    print(profile_text(results))
    results["launch_args"] = options.launch_args
    options.output.write_text(json.dumps(results, indent=2) + "\n")
    print(f"cpu_budget: wrote {options.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
