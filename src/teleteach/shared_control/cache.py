"""On-disk cache of compiled NLP functions, so the shared controller starts fast after the first build.

The C code casadi generates for a problem is hashed (with the casadi version and the compiler command); the shared
library is compiled once with gcc into ``cache_dir()`` under that hash and reused by every later start.
"""

import contextlib
import hashlib
import os
import pathlib
import shutil
import subprocess
import tempfile
import threading
from typing import Optional

import casadi as ca

COMPILER = ("gcc", "-O1", "-fPIC", "-shared")

_mode = threading.local()


class NotCachedError(RuntimeError):
    """A compiled library was needed but is not in the cache (inside ``only_cached()``)."""


@contextlib.contextmanager
def only_cached():
    """In this thread, raise ``NotCachedError`` instead of compiling (for a start-up that must stay fast)."""
    previous = getattr(_mode, "only_cached", False)
    _mode.only_cached = True
    try:
        yield
    finally:
        _mode.only_cached = previous


def cache_dir() -> pathlib.Path:
    """Folder of compiled code: ``$TELETEACH_CACHE`` or ``~/.cache/teleteach``, plus ``shared_control``."""
    root = os.environ.get("TELETEACH_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "teleteach")
    return pathlib.Path(root) / "shared_control"


def compiled_dependencies(solver: ca.Function, name: str, folder: Optional[str] = None) -> str:
    """Path of a shared library holding the functions the nlpsol ``solver`` needs, compiled only if not cached.

    Args:
        solver: an nlpsol built from casadi expressions (its ``generate_dependencies`` gives the C code).
        name: problem name (file name prefix).
        folder: cache folder, default ``cache_dir()``.

    Returns:
        The library path, to pass to ``casadi.nlpsol`` instead of the expressions.
    """
    return _compile(lambda file_name: solver.generate_dependencies(file_name), name, folder)


def compiled_function(function: ca.Function, folder: Optional[str] = None) -> ca.Function:
    """``function`` compiled to a shared library (cached) and loaded back with ``casadi.external``."""
    library = _compile(lambda file_name: function.generate(file_name), function.name(), folder)
    return ca.external(function.name(), library)


def compiler_failure(result: subprocess.CompletedProcess) -> str:
    """Why the compiler failed, in its own words (the end of what it printed) and how it ended (status or signal)."""
    code = result.returncode
    ended = f"killed by signal {-code}" if code < 0 else f"exit status {code}"
    said = " ".join((result.stderr or result.stdout or "").split())[-2000:]
    return f"{COMPILER[0]} {ended}: {said}" if said else f"{COMPILER[0]} {ended}, printing nothing"


def _compile(generate, name: str, folder: Optional[str]) -> str:
    folder = pathlib.Path(folder) if folder else cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=folder) as work:
        source = pathlib.Path(work) / f"{name}.c"
        cwd = os.getcwd()
        os.chdir(work)
        try:
            generate(source.name)
        finally:
            os.chdir(cwd)
        code = source.read_bytes()
        key = hashlib.sha256(code + ca.__version__.encode() + " ".join(COMPILER).encode()).hexdigest()[:16]
        library = folder / f"{name}_{key}.so"
        if library.exists():
            return str(library)
        if getattr(_mode, "only_cached", False):
            raise NotCachedError(f"{library.name} is not cached")
        if shutil.which(COMPILER[0]) is None:
            raise RuntimeError(f"cannot compile {name}: {COMPILER[0]} not found (use the 'fast' solver instead)")
        built = pathlib.Path(work) / library.name
        result = subprocess.run([*COMPILER, str(source), "-o", str(built), "-lm"], capture_output=True, text=True)
        if result.returncode != 0:
            raise RuntimeError(f"compiling {name} failed: {compiler_failure(result)}")
        os.replace(built, library)
    return str(library)
