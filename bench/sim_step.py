#!/usr/bin/env python3
"""Benchmark of robot_sim's 1 kHz step (physics + Cartesian impedance controller), without ROS.

Figures: microseconds per step (mean, p99) in the supermarket scene with the arm pressing on the shelf, the
real-time factor with the sim and controllers alone (impedance and position control in free space), and the
overshoot of a 5 cm reference step for the two damping designs (thesis eq 7 vs mass-aware). Target: <= 0.2 ms
mean per step in contact (>= 5x real time). Writes bench/results/sim_step.json.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import json
import pathlib
import time

import numpy as np
from scipy.spatial.transform import Rotation

from teleteach.control import panda
from teleteach.control.kinematics import PandaKinematics
from teleteach.sim.robot_sim import IMPEDANCE, TRAJECTORY, RobotSim, load_controller_config

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "sim_step.json"
DOWN = [1.0, 0.0, 0.0, 0.0]


def timed_steps(sim, steps):
    """Wall-clock microseconds of each step, and the mean CPU microseconds (less sensitive to a loaded machine)."""
    durations = np.empty(steps)
    cpu_started = time.process_time()
    for index in range(steps):
        started = time.perf_counter()
        sim.tick()
        durations[index] = time.perf_counter() - started
    return durations * 1e6, (time.process_time() - cpu_started) / steps * 1e6


def summary(timing):
    durations_us, cpu_us = timing
    mean = float(np.mean(durations_us))
    return {
        "mean_us": mean,
        "p99_us": float(np.percentile(durations_us, 99)),
        "cpu_mean_us": cpu_us,
        "real_time_factor": 1e3 / mean,
        "load_average_1min": os.getloadavg()[0],
    }


def contact_step_cost(steps):
    """Arm at the shelf (base in place_perpendicular), fingers pressed 3 cm into the upper board's top."""
    sim = RobotSim()
    sim.world.teleport_base(sim.scene.base_poses["place_perpendicular"])
    kinematics = PandaKinematics(sim.scene.robot.mount_height)
    board_top = 0.65
    free_spot = [0.62, -0.45]  # [m] in base_link: on board_high, 0.2 m clear of the products
    above = kinematics.inverse([*free_spot, board_top + 0.05], DOWN, seed=sim.state.q)
    sim.command_trajectory(panda.ARM_JOINTS, [(above.tolist(), [0.0] * 7, 2.0)])
    sim.run(2.5)
    ok, message = sim.switch_controllers([IMPEDANCE], [TRAJECTORY], 2)
    assert ok, message
    sim.command_equilibrium("base_link", [*free_spot, board_top - 0.03], DOWN)
    sim.run(1.5)
    force, _ = sim.world.external_wrench()
    result = summary(timed_steps(sim, steps))
    result["contact_force_z_N"] = float(force[2])
    result["tcp_height_above_board_m"] = float(sim.state.position[2] - board_top)
    sim.close()
    return result


def free_space_cost(controller, steps):
    sim = RobotSim()
    if controller == IMPEDANCE:
        assert sim.switch_controllers([IMPEDANCE], [TRAJECTORY], 2)[0]
    sim.run(1.0)
    result = summary(timed_steps(sim, steps))
    sim.close()
    return result


def step_overshoot(damping):
    """Overshoot [%] of the TCP after a 5 cm step of the reference along x, y and z (800 N/m)."""
    config = load_controller_config()
    config[IMPEDANCE]["damping"] = damping
    sim = RobotSim(config=config)
    assert sim.switch_controllers([IMPEDANCE], [TRAJECTORY], 2)[0]
    sim.command_eigenvalues([800.0, 800.0, 800.0])
    sim.run(1.0)
    overshoot = {}
    for axis, name in enumerate("xyz"):
        start, quaternion = sim.state.position.copy(), sim.state.quaternion.copy()
        target = start.copy()
        target[axis] += 0.05
        sim.command_equilibrium("base_link", target, quaternion)
        travelled = []
        for _ in range(1500):
            sim.tick()
            travelled.append(sim.state.position[axis] - start[axis])
        overshoot[name] = 100.0 * (max(travelled) - 0.05) / 0.05
        sim.command_equilibrium("base_link", start, quaternion)
        sim.run(1.5)
    sim.close()
    return overshoot


def rotation_step(damping, ratio):
    """A 0.1 rad step of the reference orientation about x and z: overshoot [%] and the torque jitter [Nm]
    (standard deviation per joint over the last 0.5 s of 1.5 s; chatter shows as jitter that never settles)."""
    config = load_controller_config()
    config[IMPEDANCE]["damping"] = damping
    config[IMPEDANCE]["rotational_damping_ratio"] = ratio
    sim = RobotSim(config=config)
    assert sim.switch_controllers([IMPEDANCE], [TRAJECTORY], 2)[0]
    sim.run(0.5)
    start = Rotation.from_quat(sim.state.quaternion)
    step = Rotation.from_rotvec([0.1, 0.0, 0.1])
    sim.command_equilibrium("base_link", sim.state.position, (step * start).as_quat())
    angles, torques = [], []
    for _ in range(1500):
        sim.tick()
        angles.append(np.linalg.norm((Rotation.from_quat(sim.state.quaternion) * start.inv()).as_rotvec()))
        torques.append(sim.impedance.last_torque.copy())
    sim.close()
    size = step.magnitude()
    return {
        "overshoot_percent": 100.0 * (max(angles) - size) / size,
        "torque_jitter_Nm": float(np.max(np.std(np.array(torques[-500:]), axis=0))),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5000, help="timed steps per case")
    args = parser.parse_args()
    results = {
        "contact_impedance": contact_step_cost(args.steps),
        "free_space_impedance": free_space_cost(IMPEDANCE, args.steps),
        "free_space_position": free_space_cost(TRAJECTORY, args.steps),
        "overshoot_5cm_step_percent": {kind: step_overshoot(kind) for kind in ("unit_mass", "mass_aware")},
        "rotation_step_ratio_1": {kind: rotation_step(kind, 1.0) for kind in ("unit_mass", "mass_aware")},
        "rotation_step_ratio_0.5": {kind: rotation_step(kind, 0.5) for kind in ("unit_mass", "mass_aware")},
        "target_mean_us": 200.0,
    }
    contact = results["contact_impedance"]
    results["target_met"] = contact["mean_us"] <= 200.0
    for case in ("contact_impedance", "free_space_impedance", "free_space_position"):
        figures = results[case]
        print(
            f"{case:22s} mean {figures['mean_us']:7.1f} us  p99 {figures['p99_us']:7.1f} us  "
            f"cpu {figures['cpu_mean_us']:7.1f} us  real-time factor {figures['real_time_factor']:5.1f}  "
            f"(load average {figures['load_average_1min']:.1f})"
        )
    print(f"contact force {contact['contact_force_z_N']:.1f} N (z, on the hand)")
    for kind, overshoot in results["overshoot_5cm_step_percent"].items():
        print(f"overshoot {kind:10s} " + "  ".join(f"{axis} {value:5.1f} %" for axis, value in overshoot.items()))
    for ratio in ("1", "0.5"):
        for kind, figures in results[f"rotation_step_ratio_{ratio}"].items():
            print(
                f"0.1 rad rotation step, rotational ratio {ratio:3s} {kind:10s} overshoot "
                f"{figures['overshoot_percent']:5.1f} %  torque jitter {figures['torque_jitter_Nm']:.3f} Nm"
            )
    print(f"target <= 200 us mean in contact: {'met' if results['target_met'] else 'NOT met'}")
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(results, indent=2))
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
