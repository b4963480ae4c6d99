"""Starting a teleteach ROS node (``--help`` without a master, pins checked, init_node), and ending one quietly.

Every executable in nodes/ starts through :func:`start`: its usage says what the node does and lists its parameters
with their defaults and meanings, read from the node's ``config/*.yaml`` (the one place of defaults), so ``rosrun
teleteach <node> --help`` answers at once, with or without a roscore. Then the libraries teleteach pins are checked
(:mod:`teleteach.core.pins`): a wrong version that another install put first on the path stops the node in one line.
At Ctrl-C, :func:`publish` drops what a timer sends while rospy closes the topics.
"""

import argparse
import dataclasses
import re
import sys
import typing

ROSOUT_TOPICS_PARAM = "/rosout_disable_topics_generation"


@dataclasses.dataclass(frozen=True)
class Parameter:
    """A private parameter of a node's yaml: its name, its default as the user would write it, what it means."""

    name: str
    default: str
    meaning: str


def start(
    name: str,
    description: str,
    parameters_file: typing.Union[str, typing.Sequence[str]] = "",
    parser: typing.Optional[argparse.ArgumentParser] = None,
    init: bool = True,
) -> argparse.Namespace:
    """Parse the command line (``--help`` lists the parameters), check the pinned libraries, init the node.

    Args:
        name: the node's name (and program name in the usage).
        description: the node's docstring: its first paragraph opens the usage.
        parameters_file: the node's ``config/<file>`` (or files): each key is a private parameter, its value the
            default.
        parser: the node's own parser, for command-line options; its epilog gets the parameters.
        init: ``rospy.init_node`` (False: the caller inits later, e.g. robot_sim, whose --urdf only prints).

    A library at a version other than the pinned one ends the process with one line (exit status 1).

    The node's log lines go out as they are written: rospy writes INFO to stdout without flushing, and Python
    buffers a stdout that is a file or a pipe (``roslaunch ... | tee``, a CI log) by 8 KB, so a quiet node's lines
    showed up minutes late or only at its exit.
    """
    import rospy

    from teleteach.core import pins

    sys.stdout.reconfigure(line_buffering=True)

    parser = parser or argparse.ArgumentParser()
    parser.prog = name
    parser.description = description
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = parameters_help(parameters_file)
    arguments = parser.parse_args(rospy.myargv(sys.argv)[1:])
    try:
        pins.check()
    except pins.PinError as error:
        sys.exit(f"{name} cannot start: {error}")
    if init:
        init_node(name)
    return arguments


def parameters_help(
    parameters_file: typing.Union[str, typing.Sequence[str]] = "", parameters: typing.Sequence[Parameter] = ()
) -> str:
    """The usage's list of private parameters: ``~name (default value): meaning``, from yamls and ``parameters``."""
    files = [parameters_file] if isinstance(parameters_file, str) else list(parameters_file)
    files = [name for name in files if name]
    entries = list(parameters) + [entry for name in files for entry in file_parameters(name)]
    source = f"; defaults from {', '.join(f'config/{name}' for name in files)}" if files else ""
    if not entries:
        return "parameters: none"
    lines = [f"parameters (private: rosrun teleteach <node> _name:=value, or a launch file's <param>{source}):"]
    for entry in entries:
        lines.append(f"  ~{entry.name} (default {entry.default}): {entry.meaning}".rstrip(": "))
    return "\n".join(lines)


def file_parameters(name: str) -> typing.List[Parameter]:
    """The parameters of ``config/<name>``, its ``shared: [section]`` replaced by ``config/shared/<section>.yaml``'s."""
    import yaml

    from teleteach.core.paths import SHARED, config_file

    text = config_file(name).read_text()
    found = []
    for entry in yaml_parameters(text):
        if entry.name != SHARED:
            found.append(entry)
            continue
        for section in yaml.safe_load(text)[SHARED]:
            found += yaml_parameters(config_file(SHARED, f"{section}.yaml").read_text())
    return found


_KEY = re.compile(r"^(?P<indent>\s*)(?P<key>[A-Za-z_][\w]*):(?P<value>[^#]*?)\s*(#\s?(?P<comment>.*))?$")
_CONTINUED = re.compile(r"^\s+#\s?(?P<comment>.*)$")


def yaml_parameters(text: str) -> typing.List[Parameter]:
    """The leaves of a parameter yaml as parameters: nested keys joined with ``/``, their comments as meaning.

    Comment lines indented under a leaf continue its meaning; the defaults are the yaml's own values.
    """
    import yaml

    data = yaml.safe_load(text) or {}
    found: typing.List[Parameter] = []
    stack: typing.List[typing.Tuple[int, str]] = []
    comment_column = -1  # where the last leaf's comment began: a comment line aligned with it continues it
    for line in text.splitlines():
        match = _KEY.match(line)
        if match is None:
            continued = _CONTINUED.match(line)
            if continued and found and 0 <= comment_column <= line.index("#"):
                previous = found[-1]
                found[-1] = dataclasses.replace(
                    previous, meaning=f"{previous.meaning} {continued['comment'].strip()}".strip()
                )
            else:
                comment_column = -1
            continue
        indent = len(match["indent"])
        while stack and stack[-1][0] >= indent:
            stack.pop()
        path = [key for _, key in stack] + [match["key"]]
        value = _lookup(data, path)
        if isinstance(value, dict):
            stack.append((indent, match["key"]))
            continue
        found.append(Parameter("/".join(path), _shown(value), (match["comment"] or "").strip()))
        comment_column = line.index("#") if match["comment"] is not None else -1
    return found


def _lookup(data: typing.Any, path: typing.Sequence[str]) -> typing.Any:
    for key in path:
        data = data.get(key) if isinstance(data, dict) else None
    return data


def _shown(value: typing.Any) -> str:
    """A default as a user would type it: yaml's spelling (true, [a, b]), "" for an empty string."""
    import yaml

    text = yaml.safe_dump(value, default_flow_style=True, width=1000).strip()
    return text[: -len("...")].strip() if text.endswith("...") else text


def init_node(name: str, **kwargs: typing.Any) -> None:
    """``rospy.init_node``, then make sure ``/rosout_disable_topics_generation`` exists (default value, false).

    rospy reads that parameter through its cache on every log call, but never caches a parameter that is not set:
    each ``rospy.loginfo`` then costs an XML-RPC round trip to the master (about half of a /change_tree answer).
    Setting it to its default changes nothing else; a value the user set is kept, and later changes still reach
    every node through the parameter subscription.
    """
    import rospy

    rospy.init_node(name, **kwargs)
    if not rospy.has_param(ROSOUT_TOPICS_PARAM):
        rospy.set_param(ROSOUT_TOPICS_PARAM, False)


def node_parameters(
    defaults_file: str, get_param: typing.Optional[typing.Callable[[str, typing.Any], typing.Any]] = None
) -> typing.Dict[str, typing.Any]:
    """The node's parameters: the keys of ``config/<defaults_file>``, each overridden by its private parameter.

    The yaml is the one place of their defaults; a launch file's ``<param>`` or ``_name:=value`` overrides one. A
    mapping is overridden key by key (``~plane/origin`` alone keeps the yaml's ``plane/normal``).
    ``get_param(name, default)`` is ``rospy.get_param`` unless given.
    """
    from teleteach.core.paths import config_values

    if get_param is None:
        import rospy

        get_param = rospy.get_param
    defaults = config_values(defaults_file)
    return {name: merged(value, get_param(f"~{name}", value)) for name, value in defaults.items()}


_NO_DEFAULT = object()


def server_value(name: str, default: typing.Any = _NO_DEFAULT) -> typing.Any:
    """A value another process leaves on the parameter server (a flag, what a launch chose), ``default`` if none.

    Not a parameter of the node's own: those come through :func:`node_parameters`. Without ``default`` a name not on
    the server raises KeyError.
    """
    import rospy

    return rospy.get_param(name) if default is _NO_DEFAULT else rospy.get_param(name, default)


def server_has(name: str) -> bool:
    """Whether another process has left ``name`` on the parameter server yet (its value: :func:`server_value`)."""
    import rospy

    return rospy.has_param(name)


def merged(default: typing.Any, override: typing.Any) -> typing.Any:
    """``override``, except that two mappings merge key by key (nested)."""
    if not (isinstance(default, dict) and isinstance(override, dict)):
        return override
    values = dict(default)
    for key, value in override.items():
        values[key] = merged(values[key], value) if key in values else value
    return values


def exit_on_bad_parameter(name: str, build: typing.Callable[[], typing.Any]) -> typing.Any:
    """``build()``; a TypeError or ValueError (a bad parameter or file) ends the node in one fatal line, status 2."""
    import rospy

    try:
        return build()
    except (TypeError, ValueError) as error:
        rospy.logfatal(f"{name} cannot start: {error}")
        sys.exit(2)


def since_process_start() -> float:
    """[s] since this process started (Linux: /proc), interpreter and imports included: a node's start-up time."""
    import os
    import pathlib

    started_ticks = int(pathlib.Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()[19])
    uptime = float(pathlib.Path("/proc/uptime").read_text().split()[0])
    return uptime - started_ticks / os.sysconf("SC_CLK_TCK")


def shutting_down() -> bool:
    """True from the first moment of a shutdown: rospy closes every topic in a pre-shutdown hook, before is_shutdown."""
    import rospy
    import rospy.core

    return rospy.core.is_shutdown_requested() or rospy.is_shutdown()


def publish(publisher: typing.Any, message: typing.Any) -> None:
    """``publisher.publish(message)``, or nothing during a shutdown: Ctrl-C closes every topic, maybe mid-publish.

    Outside a shutdown a closed topic (or a bad message) still raises.
    """
    import rospy

    if shutting_down():
        return
    try:
        publisher.publish(message)
    except (rospy.ROSException, ValueError, OSError):
        if not shutting_down():
            raise


def end_parent_launch(name: str) -> None:
    """Ask the roslaunch that started this node to stop, as Ctrl-C would: a normal end, not a process that died.

    (roslaunch ends a launch when a required node dies, but says so in red as a failure.)
    """
    import os
    import pathlib
    import signal

    import rospy

    parent = os.getppid()
    command = pathlib.Path(f"/proc/{parent}/cmdline").read_bytes().replace(b"\0", b" ")
    if b"roslaunch" in command:
        os.kill(parent, signal.SIGINT)
    else:
        rospy.logwarn(f"{name}: end_launch, but no roslaunch started this node: nothing to end")
