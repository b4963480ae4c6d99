"""The data directory, where everything a user teaches or records lives, and atomic writes into it.

Layout (docs/architecture.md, README "Data"): ``skills/``, ``trees/``, ``runs/``, ``bags/`` under one root,
``~/.ros/teleteach`` unless ``TELETEACH_DATA`` or an explicit path says otherwise.
"""

import os
import pathlib
import tempfile
from typing import Optional, Union

SUBDIRECTORIES = ("skills", "trees", "runs", "bags")


def data_dir(override: Optional[Union[str, pathlib.Path]] = None) -> pathlib.Path:
    """Return the data directory (created with its sub-folders if missing)."""
    root = override or os.environ.get("TELETEACH_DATA") or pathlib.Path.home() / ".ros" / "teleteach"
    root = pathlib.Path(root).expanduser()
    for name in SUBDIRECTORIES:
        (root / name).mkdir(parents=True, exist_ok=True)
    return root


def atomic_write_bytes(path: Union[str, pathlib.Path], data: bytes) -> None:
    """Write ``data`` to ``path`` so that a crash leaves either the old file or the new one, never half."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
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
