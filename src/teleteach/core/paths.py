"""Where the package's own files are (config/, launch/, rviz/, ...): one lookup for every module.

In a source checkout (what a catkin devel space runs) they lie beside ``src/``; in an install space
(``catkin_make install``) catkin puts them into ``share/teleteach``, which ROS finds through ROS_PACKAGE_PATH.
"""

import functools
import pathlib
import typing


class PackageFilesError(RuntimeError):
    """Neither a checkout nor ROS_PACKAGE_PATH gives the package's files."""


@functools.lru_cache(maxsize=1)
def share_dir() -> pathlib.Path:
    """The package's directory: the checkout holding this module, or the one ROS knows (install space)."""
    checkout = pathlib.Path(__file__).resolve().parents[3]
    if (checkout / "package.xml").is_file():
        return checkout
    import rospkg

    try:
        return pathlib.Path(rospkg.RosPack().get_path("teleteach"))
    except rospkg.ResourceNotFound:
        raise PackageFilesError(
            "teleteach's files (config/, launch/) are not found: source the workspace (build/env.sh or "
            "<install>/setup.bash) so that ROS_PACKAGE_PATH names the package"
        ) from None


def config_file(*parts: str) -> pathlib.Path:
    """A file of the package's config/ (e.g. ``config_file("scenarios", "thesis_full.yaml")``)."""
    return share_dir().joinpath("config", *parts)


SHARED = "shared"
"""A yaml's key (at any level) naming the sections of config/shared/ whose keys it has: ``shared: [stiffness]``."""


class SharedValueError(ValueError):
    """A yaml names a shared section that does not exist, or repeats one of its keys."""


def config_values(name: typing.Union[str, pathlib.Path], *section: str) -> typing.Dict[str, typing.Any]:
    """The values of config/<name> (or of the yaml at a path), or of its nested ``section``: the one way to read them.

    A mapping that says ``shared: [<section>, ...]`` gets the keys of config/shared/<section>.yaml, a value several
    nodes need written once; a mapping that gives one of them itself is refused (a second place of the value).
    """
    import yaml

    path = name if isinstance(name, pathlib.Path) else config_file(name)
    values = with_shared(yaml.safe_load(path.read_text()) or {}, str(name))
    for key in section:
        values = values[key]
    return dict(values)


def with_shared(values: typing.Any, where: str) -> typing.Any:
    """``values`` with each ``shared`` key replaced by the keys of the sections it names (nested mappings too)."""
    import yaml

    if not isinstance(values, dict):
        return values
    resolved = {key: with_shared(value, f"{where}/{key}") for key, value in values.items() if key != SHARED}
    for section in values.get(SHARED) or ():
        path = config_file(SHARED, f"{section}.yaml")
        if not path.is_file():
            raise SharedValueError(f"{where}: no shared section {section!r} (config/{SHARED}/{section}.yaml)")
        shared = yaml.safe_load(path.read_text()) or {}
        repeated = sorted(set(shared) & set(resolved))
        if repeated:
            raise SharedValueError(f"{where}: {', '.join(repeated)} written again (config/{SHARED}/{section}.yaml)")
        resolved.update(shared)
    return resolved
