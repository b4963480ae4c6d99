"""Compile the shared controller's solvers into the cache before anyone starts the node (scripts/setup runs this).

The node's ``compiled`` solvers are shared libraries that gcc builds from the code casadi generates for the
configuration (``cache.py``): minutes of CPU on two cores. Built here, a user's first session starts on them
instead of waiting (or, before issue 31, running on the slower virtual machine while they were built). A stamp in
the cache (named by a hash of this package's shared-control code, the yaml and the casadi version) makes a second run
return at once; a deleted cache takes its stamp with it, and checkouts of other versions keep stamps of their own.

    python -m teleteach.shared_control.prebuild [--config FILE]
"""

import argparse
import dataclasses
import hashlib
import importlib.metadata
import pathlib
import sys
import time

import yaml

from teleteach.core.paths import config_file
from teleteach.shared_control import cache


def stamp(config_path: pathlib.Path) -> str:
    """Hash of what the compiled code depends on: the shared-control modules, the yaml, the casadi version."""
    digest = hashlib.sha256(importlib.metadata.version("casadi").encode())
    for module in sorted(pathlib.Path(__file__).parent.glob("*.py")):
        digest.update(module.read_bytes())
    digest.update(pathlib.Path(config_path).read_bytes())
    return digest.hexdigest()


def build(config) -> bool:
    """Compile what ``config`` (a ``SharedControlConfig``) needs unless it is cached; returns whether it compiled."""
    from teleteach.shared_control.loop import SharedControl

    config = dataclasses.replace(config, solver="compiled")
    try:
        with cache.only_cached():
            SharedControl(config)
        return False
    except cache.NotCachedError:
        SharedControl(config)
        return True


def main(argv=None) -> int:
    """Build the cache for the yaml unless its stamp says it is built; prints one line."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--config", help="parameter file (default: the package's config/shared_control.yaml)")
    args = parser.parse_args(argv)
    path = pathlib.Path(args.config or config_file("shared_control.yaml"))
    stamp_file = cache.cache_dir() / f".prebuilt-{stamp(path)[:16]}"
    if stamp_file.is_file():
        print(f"shared-control solvers for {path}: cached ({cache.cache_dir()})")
        return 0
    from teleteach.shared_control.loop import SharedControlConfig

    config = SharedControlConfig.from_parameters(yaml.safe_load(path.read_text()))
    started = time.monotonic()
    compiled = build(config)
    what = f"compiled in {time.monotonic() - started:.0f} s" if compiled else "already cached"
    stamp_file.touch()
    print(f"shared-control solvers for {path}: {what} ({cache.cache_dir()})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
