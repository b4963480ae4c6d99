"""The data directory, where everything a user teaches or records lives, and atomic writes into it.

Layout (docs/architecture.md, the README's "Data"): ``skills/``, ``trees/``, ``runs/``, ``bags/`` under one root,
``~/.ros/teleteach`` unless ``TELETEACH_DATA`` or an explicit path says otherwise.
"""

import functools
import os
import pathlib
import tempfile
from typing import Optional, Tuple, Union

SUBDIRECTORIES = ("skills", "trees", "runs", "bags")


AUTOMATIC = "auto"  # a launch file's data_dir default: the directory below, as no override


def data_dir(override: Optional[Union[str, pathlib.Path]] = None) -> pathlib.Path:
    """Return the data directory (created with its sub-folders if missing).

    ``override``, else ``$TELETEACH_DATA``, else ``~/.ros/teleteach`` (``"auto"``, the launch files' default, and ""
    are no override).
    """
    override = None if str(override or "") in ("", AUTOMATIC) else override
    root = override or os.environ.get("TELETEACH_DATA") or pathlib.Path.home() / ".ros" / "teleteach"
    root = pathlib.Path(root).expanduser()
    for name in SUBDIRECTORIES:
        (root / name).mkdir(parents=True, exist_ok=True)
    return root


@functools.lru_cache(maxsize=1)
def umask() -> int:
    """The process's umask, read without changing it (os.umask can only be read by setting it, for every thread)."""
    try:
        for line in pathlib.Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except OSError:
        pass
    current = os.umask(0o022)
    os.umask(current)
    return current


def temporary_beside(path: pathlib.Path) -> Tuple[int, str]:
    """A new temporary file next to ``path`` (to be renamed over it), readable as the user's umask says.

    mkstemp makes it 0600; a file renamed into place keeps that, so skills, trees and reports would be unreadable to
    anyone else whatever the umask (0644 with the usual 022, as any other new file).
    """
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.fchmod(handle, 0o666 & ~umask())
    return handle, temporary


def atomic_write_bytes(path: Union[str, pathlib.Path], data: bytes) -> None:
    """Write ``data`` to ``path`` so that a crash leaves either the old file or the new one, never half."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = temporary_beside(path)
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except BaseException:
        pathlib.Path(temporary).unlink(missing_ok=True)
        raise
    directory = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(directory)
    finally:
        os.close(directory)


def atomic_write_text(path: Union[str, pathlib.Path], text: str) -> None:
    """Atomic :func:`atomic_write_bytes` for UTF-8 text."""
    atomic_write_bytes(path, text.encode("utf-8"))
