#!/usr/bin/env python3
"""Benchmark of the teaching GUI (issue 6): device-to-stiffness latency and the GL repaint rate under Xvfb.

1. Latency: the real teaching_gui node (LOW-LEVEL tab, deadband off) runs against a roscore started here; this
   process publishes /sigma7/pose at 1 kHz and steps the device X between two positions; the latency of a step is
   the time from its first /sigma7/pose message to the first /eigenvalues carrying the new X stiffness.
   Target: p95 <= 20 ms.
2. Repaint rate: the four-view EllipsoidView (800x600) repainted as fast as Qt allows for 5 s, the ellipsoid
   changing every frame. Target: >= 30 fps.

Starts its own Xvfb when DISPLAY is unset. Prints the figures and writes bench/results/gui_latency.json.
Run: source build/env.sh && python bench/gui_latency.py [--steps 200]
"""

import argparse
import json
import os
import pathlib
import sys
import tempfile
import threading
import time

import numpy as np

from teleteach.runtime.experiment import Experiment

ROOT = pathlib.Path(__file__).resolve().parents[1]
RESULTS = ROOT / "bench" / "results" / "gui_latency.json"


def stiffness_x(x):
    return 50.0 + (x + 0.1) / 0.2 * 2950.0


def measure_latency(steps, folder):
    """The latency figures, on a roscore and a teaching_gui of their own (both stopped before it returns)."""
    with Experiment(folder) as experiment:
        experiment.own_roscore(host="127.0.0.1")
        command = [str(ROOT / "nodes" / "teaching_gui"), "_initial_tab:=2", "_deadband_position:=0.0"]
        experiment.start("teaching_gui", command, folder / "teaching_gui.log", watched=True)
        experiment.join("gui_latency_bench")
        return step_latencies(steps, experiment)


def step_latencies(steps, experiment):
    import rospy
    from geometry_msgs.msg import PoseStamped, Vector3Stamped

    lock = threading.Lock()
    state = {"x": -0.05, "step_time": None, "expected": None}
    latencies = []
    published = []

    def on_eigenvalues(message):
        now = time.monotonic()
        published.append(now)
        with lock:
            expected, step_time = state["expected"], state["step_time"]
            if step_time and abs(message.vector.x - expected) < 1e-3 * expected:
                latencies.append(now - step_time)
                state["step_time"] = None

    rospy.Subscriber("/eigenvalues", Vector3Stamped, on_eigenvalues, queue_size=100, tcp_nodelay=True)
    pose = rospy.Publisher("/sigma7/pose", PoseStamped, queue_size=10, tcp_nodelay=True)
    stop_publishing = threading.Event()

    def publish():
        message = PoseStamped()
        message.header.frame_id = "sigma7"
        message.pose.orientation.w = 1.0
        while not stop_publishing.is_set():
            with lock:
                message.pose.position.x = state["x"]
                if state["step_time"] == 0.0:  # first message of a new step
                    state["step_time"] = time.monotonic()
            message.header.stamp = rospy.Time.now()
            pose.publish(message)
            time.sleep(0.001)

    threading.Thread(target=publish, daemon=True).start()
    if not experiment.wait_until(lambda: bool(published), 60.0, poll=0.1):
        sys.exit("teaching_gui did not publish /eigenvalues within 60 s")
    time.sleep(1.0)
    for step in range(steps):
        x = 0.05 if step % 2 == 0 else -0.05
        with lock:
            state.update(x=x, expected=stiffness_x(x), step_time=0.0)
        time.sleep(0.06)
    stop_publishing.set()
    window = [t for t in published if t > published[-1] - 5.0]
    rate = (len(window) - 1) / (window[-1] - window[0])
    return np.array(latencies) * 1000.0, rate, steps


def measure_repaint(seconds=5.0):
    from PyQt5.QtCore import QTimer
    from PyQt5.QtWidgets import QApplication

    from teleteach.core.gui_config import GuiConfig
    from teleteach.gui.device import DeviceSample
    from teleteach.gui.ellipsoid import EllipsoidCommand
    from teleteach.gui.gl_view import EllipsoidView

    app = QApplication.instance() or QApplication(["gui_latency_bench"])
    command = EllipsoidCommand(GuiConfig.load())
    view = EllipsoidView(command)
    view.resize(800, 600)
    view.show()
    swapped = []
    view.frameSwapped.connect(lambda: swapped.append(time.monotonic()))
    start_time = time.monotonic()

    def next_frame():
        phase = time.monotonic() - start_time
        command.device(DeviceSample(0.08 * np.sin(phase), 0.05 * np.cos(phase), 0.02, 0.3 * phase % 1, 0.2, 0.1))
        view.update()

    timer = QTimer()
    timer.timeout.connect(next_frame)
    timer.start(0)
    while time.monotonic() - start_time < seconds + 1.0:
        app.processEvents()
    timer.stop()
    frames = [t for t in swapped if t > start_time + 1.0]
    from OpenGL import GL

    view.makeCurrent()
    renderer = GL.glGetString(GL.GL_RENDERER).decode()
    return (len(frames) - 1) / (frames[-1] - frames[0]), renderer


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200, help="device steps for the latency measurement")
    args = parser.parse_args()
    folder = pathlib.Path(tempfile.mkdtemp(prefix="teleteach_bench_gui_latency_"))
    with Experiment(folder) as screen:
        screen.own_display()
        os.environ["DISPLAY"] = screen.display  # the repaint runs in this process
        latencies, rate, steps = measure_latency(args.steps, folder)
        fps, renderer = measure_repaint()
    results = {
        "latency_pose_to_eigenvalues_ms": {
            "p50": float(np.percentile(latencies, 50)),
            "p95": float(np.percentile(latencies, 95)),
            "max": float(latencies.max()),
            "samples": int(latencies.size),
            "steps": steps,
            "target_p95": 20.0,
        },
        "eigenvalues_rate_hz": rate,
        "repaint_fps_four_views_800x600": fps,
        "repaint_target_fps": 30.0,
        "gl_renderer": renderer,
        "machine": {"cpus": os.cpu_count(), "load_1min": os.getloadavg()[0]},
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(results, indent=2))
    latency = results["latency_pose_to_eigenvalues_ms"]
    print(
        f"/sigma7/pose -> /eigenvalues latency: p50 {latency['p50']:.1f} ms, p95 {latency['p95']:.1f} ms, "
        f"max {latency['max']:.1f} ms over {latency['samples']}/{steps} steps (target p95 <= 20 ms)"
    )
    print(f"/eigenvalues rate: {rate:.0f} Hz (target >= 100 Hz)")
    print(f"GL repaint, four views 800x600: {fps:.0f} fps (target >= 30 fps) on {renderer}")
    print(f"written to {RESULTS}")


if __name__ == "__main__":
    main()
