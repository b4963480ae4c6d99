"""Benchmark: the predefined skills on the in-process simulation (no ROS), and the skills' own computing costs.

Runs the whole predefined sequence on teleteach.sim.robot_sim.RobotSim through the SkillRunner and reports, per
skill, the simulated duration and the wall time; then the cost of one IK solve (a grasp pose, from the carry
posture), of planning a straight 12 cm line (IK waypoints + timing), and of resampling and decomposing a 60 s
stiffness recording for replay at 200 Hz. Prints the figures and writes bench/results/skills.json.

    source build/env.sh && python bench/skills.py
"""

import json
import math
import os
import pathlib
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from teleteach.control.kinematics import PandaKinematics
from teleteach.control.stiffness import translational_stiffness
from teleteach.core import skill_file
from teleteach.core.rotations import yaw_rotation
from teleteach.run.sim_robot import SimRobot
from teleteach.sim.robot_sim import RobotSim
from teleteach.skills.config import load_motion_config
from teleteach.skills.motion import TOP_DOWN, InverseKinematics
from teleteach.skills.predefined import PREDEFINED_SKILLS
from teleteach.skills.replay import plan_replay
from teleteach.skills.runner import SkillRunner

ROOT = pathlib.Path(__file__).resolve().parents[1]


def sequence(kinematics, config):
    sim = RobotSim()
    runner = SkillRunner(SimRobot(sim), config, sim.scene, kinematics)
    rows = []
    for name in PREDEFINED_SKILLS:
        sim_start, wall_start = sim.time, time.perf_counter()
        outcome = runner.execute(name)
        rows.append(
            {
                "skill": name,
                "success": outcome.success,
                "sim_s": sim.time - sim_start,
                "wall_s": time.perf_counter() - wall_start,
                "message": outcome.message,
            }
        )
    offset = sim.world.product_poses()["product_pick_1"][0] - np.array(sim.scene.gap("gap_1").position)
    sim.close()
    return rows, float(math.hypot(offset[0], offset[1]))


def ik_cost(kinematics, config, repeats=50):
    ik = InverseKinematics(kinematics, tolerance=config.arm.ik_tolerance)
    carry = np.array(config.postures["carry"])
    started = time.perf_counter()
    for index in range(repeats):
        ik.solve([0.62, -0.1 + 0.002 * index, 0.535], TOP_DOWN, carry)
    return 1000.0 * (time.perf_counter() - started) / repeats


def line_cost(kinematics, config, repeats=5):
    ik = InverseKinematics(kinematics, tolerance=config.arm.ik_tolerance)
    start = ik.solve([0.62, -0.1, 0.655], TOP_DOWN, np.array(config.postures["carry"]))
    started = time.perf_counter()
    for _ in range(repeats):
        joints = [start]
        for height in np.linspace(0.655, 0.535, 13)[1:]:
            joints.append(ik.solve([0.62, -0.1, height], TOP_DOWN, joints[-1]))
    return 1000.0 * (time.perf_counter() - started) / repeats


def replay_cost(rate=200.0):
    count = 600  # a 60 s demonstration recorded at 10 Hz
    angles = np.linspace(0.0, math.pi / 4, count)
    stiffness = np.array(
        [translational_stiffness([300.0, 300.0 + 2000.0 * angle, 1000.0], yaw_rotation(angle)) for angle in angles]
    )
    poses = np.tile([0.5, 0.0, 0.8, 1.0, 0.0, 0.0, 0.0], (count, 1))
    skill = skill_file.Skill("bench", "stiffness", np.linspace(0.0, 60.0, count), stiffness, poses, poses)
    started = time.perf_counter()
    plan = plan_replay(skill, rate)
    return 1000.0 * (time.perf_counter() - started), len(plan.times)


def main():
    config = load_motion_config()
    kinematics = PandaKinematics(0.40)
    rows, gap_error = sequence(kinematics, config)
    for row in rows:
        print(
            f"{row['skill']:18s} {'ok ' if row['success'] else 'FAIL'} sim {row['sim_s']:5.1f} s  "
            f"wall {row['wall_s']:5.1f} s  {row['message']}"
        )
    total_sim, total_wall = sum(row["sim_s"] for row in rows), sum(row["wall_s"] for row in rows)
    print(
        f"whole sequence: sim {total_sim:.1f} s, wall {total_wall:.1f} s ({total_sim / total_wall:.1f}x real time), "
        f"product {1000.0 * gap_error:.1f} mm from the gap's centre"
    )
    ik_ms, line_ms = ik_cost(kinematics, config), line_cost(kinematics, config)
    replay_ms, samples = replay_cost()
    print(
        f"IK solve: {ik_ms:.2f} ms; straight 12 cm line (12 IK waypoints): {line_ms:.1f} ms; "
        f"replay plan of a 60 s recording ({samples} samples at 200 Hz): {replay_ms:.0f} ms"
    )
    results = {
        "skills": rows,
        "sequence_sim_s": total_sim,
        "sequence_wall_s": total_wall,
        "gap_error_m": gap_error,
        "ik_solve_ms": ik_ms,
        "straight_line_plan_ms": line_ms,
        "replay_plan_ms": replay_ms,
        "replay_samples": samples,
    }
    out = ROOT / "bench" / "results"
    out.mkdir(parents=True, exist_ok=True)
    (out / "skills.json").write_text(json.dumps(results, indent=2))
    print(f"wrote {out / 'skills.json'}")


if __name__ == "__main__":
    main()
