"""Running the main job as a fresh headless machine would (the end-to-end tests' shared helper)."""

import os
import pathlib
import subprocess

ROOT = pathlib.Path(__file__).resolve().parents[2]
RUN_TIMEOUT = 480.0  # [s] wall: the runner bounds itself (scenario 300 s, RViz picture 2 x 45 s, stop, report)


def run_thesis(data: pathlib.Path, *arguments, timeout: float = RUN_TIMEOUT) -> subprocess.CompletedProcess:
    """``run_thesis --data-dir data ARGUMENTS``, without a display: the runner starts its own Xvfb."""
    env = dict(os.environ)
    env.pop("DISPLAY", None)
    command = [str(ROOT / "nodes" / "run_thesis"), "--data-dir", str(data), *map(str, arguments)]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout, env=env, check=False)
