"""Benchmark: /change_tree round-trip latency over ROS for trees of 10, 100 and 1000 leaves.

Starts its own roscore (free port), the test skill server (the first leaf runs for the whole benchmark, so edits hit
a running tree) and the behaviour_tree node with a generated tree; a subscriber of /behaviour_tree/log/tree plays the
GUI. Each request alternates an insert in the middle of BehaviorExecution with the removal of that node (every
successful change is also saved to the data directory). Prints p50/p99 and writes bench/results/change_tree.json.
Target: p99 <= 10 ms at 1000 leaves, cost growing at most linearly.

    source build/env.sh && python bench/change_tree.py [--requests 1000]
"""

import argparse
import json
import os
import pathlib
import sys
import tempfile
import time

import numpy as np

from teleteach.runtime.experiment import Experiment

ROOT = pathlib.Path(__file__).resolve().parents[1]
SIZES = (10, 100, 1000)


def tree_yaml(leaves):
    children = "\n".join(f"        - {{name: Leaf_{i}, skill: Idle}}" for i in range(leaves))
    return (
        "execution: BehaviorExecution\nroot:\n  type: selector\n  name: Root\n  memory: false\n  children:\n"
        "    - {type: pause, name: PauseCondition}\n    - type: sequence\n      name: BehaviorExecution\n"
        f"      memory: true\n      children:\n{children}\n"
    )


def measure(leaves, requests, workdir, experiment):
    import rospy

    from teleteach.msg import BehaviourTree
    from teleteach.srv import ChangeTree

    tree_file = workdir / f"tree_{leaves}.yaml"
    tree_file.write_text(tree_yaml(leaves))
    node = experiment.start(
        "behaviour_tree",
        [
            sys.executable,
            str(ROOT / "nodes" / "behaviour_tree"),
            f"_tree:={tree_file}",
            f"_data_dir:={workdir / f'data_{leaves}'}",
            "__name:=behaviour_tree",
        ],
        workdir / "processes.log",
        watched=True,
    )
    try:
        received = []
        subscriber = rospy.Subscriber(
            "/behaviour_tree/log/tree", BehaviourTree, lambda m: received.append(len(m.behaviours))
        )
        rospy.wait_for_service("/change_tree", timeout=60)
        if not experiment.wait_until(lambda: bool(received) and received[-1] == leaves + 3, 30.0, poll=0.05):
            raise RuntimeError(f"no log/tree of {leaves + 3} nodes from the node")
        change = rospy.ServiceProxy("/change_tree", ChangeTree, persistent=True)
        latencies = []
        for i in range(requests + 20):
            if i % 2 == 0:
                begin = time.perf_counter()
                response = change(node_name="Idle", operation="insert", index=leaves // 2, parent="")
                elapsed = time.perf_counter() - begin
                name = response.new_node_name
            else:
                begin = time.perf_counter()
                response = change(node_name=name, operation="remove", index=0, parent="")
                elapsed = time.perf_counter() - begin
            if not response.success:
                raise RuntimeError(response.message)
            if i >= 20:  # warm-up
                latencies.append(elapsed)
        change.close()
        subscriber.unregister()
        return np.array(latencies) * 1e3
    finally:
        experiment.stop(node)


def measure_in_process(leaves, requests, workdir):
    """The node's own share: edit + yaml + atomic save of TeachingTree.change, no ROS, same requests.

    Returns wall-clock latencies and this thread's CPU time per request [ms]; the CPU time does not depend on how
    busy the machine is, so it shows how the cost grows with the tree.
    """
    import yaml

    from teleteach.bt.library import SkillLibrary
    from teleteach.bt.ros import ActionClients, ActionSkill, BehaviourTreeConfig
    from teleteach.bt.teaching import TeachingTree, TreeStore
    from teleteach.bt.tree import parse_tree

    library = SkillLibrary.load(ROOT / "config" / "skills.yaml")
    spec = parse_tree(yaml.safe_load(tree_yaml(leaves)), library)
    clients, config = ActionClients(), BehaviourTreeConfig.from_yaml()
    store = TreeStore(workdir / f"in_process_{leaves}")
    tree = TeachingTree(spec, library, lambda name, entry: ActionSkill(name, entry, clients, config), store=store)
    latencies, cpu = [], []
    for i in range(requests):
        begin, begin_cpu = time.perf_counter(), time.thread_time()
        if i % 2 == 0:
            name = tree.change("Idle", "insert", leaves // 2).new_node_name
        else:
            tree.change(name, "remove")
        latencies.append(time.perf_counter() - begin)
        cpu.append(time.thread_time() - begin_cpu)
    return np.array(latencies) * 1e3, np.array(cpu) * 1e3


def stats(latencies):
    return {
        "requests": int(latencies.size),
        "p50_ms": float(np.percentile(latencies, 50)),
        "p99_ms": float(np.percentile(latencies, 99)),
        "mean_ms": float(latencies.mean()),
        "max_ms": float(latencies.max()),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--requests", type=int, default=1000, help="timed requests per tree size")
    args = parser.parse_args()
    workdir = pathlib.Path(tempfile.mkdtemp(prefix="teleteach_bench_change_tree_"))
    with Experiment(workdir) as experiment:
        experiment.own_roscore(workdir / "processes.log")
        server = [sys.executable, str(ROOT / "test" / "ros" / "skill_test_server.py"), "_duration:=1000000.0"]
        experiment.start("skill_test_server", server, workdir / "processes.log", watched=True)
        experiment.join("change_tree_bench")
        results, in_process, in_process_cpu = {}, {}, {}
        load = [os.getloadavg()[0]]
        for leaves in SIZES:
            results[str(leaves)] = stats(measure(leaves, args.requests, workdir, experiment))
            wall, cpu = measure_in_process(leaves, args.requests, workdir)
            in_process[str(leaves)], in_process_cpu[str(leaves)] = stats(wall), stats(cpu)
            load.append(os.getloadavg()[0])
            ros, own = results[str(leaves)], in_process[str(leaves)]
            print(
                f"{leaves:5d} leaves: over ROS p50 {ros['p50_ms']:.2f} ms  p99 {ros['p99_ms']:.2f} ms  "
                f"max {ros['max_ms']:.2f} ms | in-process (edit + save) p50 {own['p50_ms']:.2f} ms  "
                f"p99 {own['p99_ms']:.2f} ms (CPU p50 {in_process_cpu[str(leaves)]['p50_ms']:.2f} ms)",
                flush=True,
            )
        small, large = results["10"]["p50_ms"], results["1000"]["p50_ms"]
        summary = {
            "benchmark": "change_tree round trip (persistent service connection, insert/remove alternating)",
            "sizes": results,
            "in_process_edit_and_save": in_process,
            "in_process_cpu_time": in_process_cpu,
            "cpu_p50_growth_10_to_1000": in_process_cpu["1000"]["p50_ms"] / in_process_cpu["10"]["p50_ms"],
            "load_average_1min": load,
            "cpus": os.cpu_count(),
            "p50_growth_10_to_1000": large / small,
            "target_p99_ms_at_1000": 10.0,
            "meets_target": results["1000"]["p99_ms"] <= 10.0,
            "linear_or_better": large / small <= 100.0,
        }
        out = ROOT / "bench" / "results" / "change_tree.json"
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(summary, indent=2) + "\n")
        print(f"load average during the run: {', '.join(f'{value:.1f}' for value in load)} on {os.cpu_count()} cpus")
        print(
            f"p50 growth 10 -> 1000 leaves: x{summary['p50_growth_10_to_1000']:.1f}; "
            f"p99 <= 10 ms at 1000 leaves: {summary['meets_target']}; written {out}"
        )


if __name__ == "__main__":
    main()
