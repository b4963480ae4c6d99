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


def config_values(name: str, *section: str) -> typing.Dict[str, typing.Any]:
    """The values of config/<name> (the one place of a node's values), or of its nested ``section``."""
    import yaml

    values = yaml.safe_load(config_file(name).read_text()) or {}
    for key in section:
        values = values[key]
    return dict(values)
