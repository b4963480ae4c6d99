"""The layering docs/architecture.md promises: five floors of parts with the shared words at the bottom, no import
cycles, the library never imports the executables, benches or tests, and only the ROS layers import rospy (so every
part's logic is testable without a master)."""

import ast
import pathlib
import re

import pytest
from conftest import ROOT

PACKAGE = ROOT / "src" / "teleteach"
# The ROS layers: each part's ros.py, the GUI's worker, arm and perception (the scene and TF), the node helpers and
# the nodes' entries, the actionlib helpers the ros.py layers share (their status thread stops with rospy's shutdown),
# the main jobs (the thesis', the wipe's) and the learn_skill CLI: they import rospy.
ROS_LAYERS = {
    "runtime/node.py",
    "executables.py",
    "runtime/ros_actions.py",
    "gui/worker.py",
    "gui/perception.py",
    "gui/arm.py",
    "run/thesis.py",
    "wiping/scenario_ros.py",
    "learning/command.py",
}
# What starts or hosts ROS layers, with no rospy of its own (issue 56: rospy confined to the adapters): the GUI's
# window (it hosts the worker and the tabs' adapters), the experiment runner (it joins its master as a node through
# runtime.node) and the study's trial processes (docs/architecture.md: study/runner.py starts the study node,
# importing it in functions). They reach rospy only through a ROS layer.
HOSTS_OF_ROS_LAYERS = {"gui/app.py", "runtime/experiment.py", "study/runner.py"}


def modules():
    """{module name: (path relative to the package, parsed tree)} of every module of the library."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        relative = path.relative_to(PACKAGE)
        parts = ["teleteach", *relative.with_suffix("").parts]
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = (relative.as_posix(), ast.parse(path.read_text(), str(path)))
    return found


def imported_names(tree, top_level_only):
    """Module names a tree imports (at its top level only, or anywhere, e.g. inside functions)."""
    statements = tree.body if top_level_only else ast.walk(tree)
    for node in statements:
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module
            yield from (f"{node.module}.{alias.name}" for alias in node.names)


def find_cycle(graph):
    """One import cycle of ``graph`` ({module: set of modules}) as a list, or None."""
    state = {}

    def visit(module, path):
        state[module] = "open"
        for target in sorted(graph[module]):
            if state.get(target) == "open":
                return path[path.index(target) :] + [target]
            if target not in state:
                cycle = visit(target, [*path, target])
                if cycle:
                    return cycle
        state[module] = "done"
        return None

    for module in sorted(graph):
        if module not in state:
            cycle = visit(module, [module])
            if cycle:
                return cycle
    return None


def test_the_library_has_no_import_cycle_at_module_level():
    library = modules()
    graph = {
        name: {target for target in imported_names(tree, top_level_only=True) if target in library and target != name}
        for name, (_, tree) in library.items()
    }
    assert sum(len(targets) for targets in graph.values()) > 100  # the check saw the library's imports
    assert find_cycle(graph) is None


def part(module):
    """The part of the house a module belongs to: its subpackage (teleteach.gui), or itself at the top."""
    return ".".join(module.split(".")[:2])


def test_no_import_runs_back_up_between_the_parts():
    # Expect the parts (subpackages, and the shared modules at the top) to import each other without a loop, even
    # through imports inside functions: a word two parts share lives below both (docs/architecture.md)
    graph = part_graph(modules())
    assert {"teleteach.gui", "teleteach.study", "teleteach.sim", "teleteach.perception"} <= set(graph)
    assert find_cycle(graph) is None


def part_graph(library):
    """{part: the parts it imports}, imports inside functions included."""
    graph = {}
    for name, (_, tree) in library.items():
        targets = {part(target) for target in imported_names(tree, top_level_only=False) if target in library}
        graph.setdefault(part(name), set()).update(targets - {part(name)})
    return graph


def floors(graph):
    """{part: its floor}: 1 for a part that imports none, else one above the highest part it imports (no cycle)."""
    found = {}

    def floor(name):
        if name not in found:
            found[name] = 1 + max((floor(target) for target in graph[name]), default=0)
        return found[name]

    for name in graph:
        floor(name)
    return found


def test_the_parts_stand_on_five_floors_with_the_shared_words_at_the_bottom():
    graph = part_graph(modules())
    floor = floors(graph)
    assert max(floor.values()) <= 5, {name: level for name, level in floor.items() if level > 5}
    assert floor["teleteach.executables"] == 5  # the check saw the whole house
    assert graph["teleteach.core"] == set()
    assert graph["teleteach.runtime"] == {"teleteach.core"}
    assert graph["teleteach.control"] <= {"teleteach.core"}


def test_floors_count_the_longest_chain_of_imports():
    graph = {"a": {"b", "d"}, "b": {"c"}, "c": set(), "d": set()}
    assert floors(graph) == {"a": 3, "b": 2, "c": 1, "d": 1}


def test_a_cycle_is_found_when_there_is_one():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]


def test_the_library_never_imports_the_executables_benches_or_tests():
    outside = {"nodes", "bench", "test", "conftest"}
    offending = {
        path: sorted(name for name in imported_names(tree, top_level_only=False) if name.split(".")[0] in outside)
        for path, tree in modules().values()
    }
    assert {path: names for path, names in offending.items() if names} == {}


def test_only_the_ros_layers_import_rospy():
    importers = {
        path
        for path, tree in modules().values()
        if any(name.split(".")[0] == "rospy" for name in imported_names(tree, top_level_only=False))
    }
    layers = {path for path in importers if path.endswith("/ros.py")}
    assert layers >= {"bt/ros.py", "haptics/ros.py", "shared_control/ros.py", "sim/ros.py", "skills/ros.py"}
    assert importers - layers <= ROS_LAYERS
    assert importers & HOSTS_OF_ROS_LAYERS == set()


def library_imports(library, tree):
    """The library's modules an import anywhere in ``tree`` runs: each one named and the packages above it."""
    found = set()
    for name in imported_names(tree, top_level_only=False):
        parts = name.split(".")
        found |= {".".join(parts[:end]) for end in range(1, len(parts) + 1)} & set(library)
    return found


def chains_to_rospy(library):
    """{path: the import chain through which the module gets rospy, e.g. ['teleteach.a', 'teleteach.b', 'rospy']}."""
    graph = {name: library_imports(library, tree) - {name} for name, (_, tree) in library.items()}
    chains = {
        name: [name, "rospy"]
        for name, (_, tree) in library.items()
        if any(target.split(".")[0] == "rospy" for target in imported_names(tree, top_level_only=False))
    }
    while True:  # breadth first: each module gets one of its shortest chains
        reached = dict(chains)
        for name in sorted(set(graph) - set(reached)):
            via = sorted(target for target in graph[name] if target in reached)
            if via:
                chains[name] = [name, *reached[via[0]]]
        if len(chains) == len(reached):
            break
    return {library[name][0]: chain for name, chain in chains.items()}


def is_ros_layer(path):
    return path.endswith("/ros.py") or path in ROS_LAYERS | HOSTS_OF_ROS_LAYERS


def test_only_the_ros_layers_get_rospy_even_through_other_modules():
    chains = chains_to_rospy(modules())
    assert {"bt/ros.py", "viz/ros.py", "runtime/node.py"} <= set(chains)  # the check saw the ROS layers
    assert {path: " -> ".join(chain) for path, chain in chains.items() if not is_ros_layer(path)} == {}


def test_a_chain_to_rospy_is_found_through_an_import_inside_a_function():
    library = {
        "teleteach.a": ("a.py", ast.parse("def f():\n    from teleteach.b import thing")),
        "teleteach.b": ("b/__init__.py", ast.parse("import teleteach.b.ros")),
        "teleteach.b.ros": ("b/ros.py", ast.parse("import rospy")),
        "teleteach.c": ("c.py", ast.parse("import math")),
    }
    assert chains_to_rospy(library) == {
        "a.py": ["teleteach.a", "teleteach.b", "teleteach.b.ros", "rospy"],
        "b/__init__.py": ["teleteach.b", "teleteach.b.ros", "rospy"],
        "b/ros.py": ["teleteach.b.ros", "rospy"],
    }


def test_every_executable_is_its_usage_and_one_call_into_the_library():
    # Expect each file of nodes/ to be its docstring and one library entry (docs/architecture.md): 20 lines at most
    nodes = sorted(path for path in (ROOT / "nodes").iterdir() if path.is_file())
    assert len(nodes) >= 16
    too_long = {path.name: len(path.read_text().splitlines()) for path in nodes}
    assert {name: lines for name, lines in too_long.items() if lines > 20} == {}
    for path in nodes:
        tree = ast.parse(path.read_text())
        library = {node.module for node in tree.body if isinstance(node, ast.ImportFrom)}
        assert len(library) == 1 and library.pop().startswith("teleteach."), path.name
        assert not any(isinstance(node, (ast.FunctionDef, ast.ClassDef)) for node in tree.body), path.name


def test_the_entries_load_nothing_heavy_before_their_node_checks_the_pinned_libraries():
    library = modules()
    light = {"argparse", "os", "sys", "typing", "dataclasses", "re"}
    for module in ("teleteach.executables", "teleteach.runtime.node"):
        names = set(imported_names(library[module][1], top_level_only=True))
        assert names - light <= {name for name in names if name.startswith("teleteach.runtime.node")}, module


EULER_SEQUENCE = re.compile(r"""(?:from|as)_euler\(\s*["'][xyzXYZ]{3}["']""")
STIFFNESS_COMPOSITION = re.compile(r"@\s*np\.diag\((?:[^()]|\([^()]*\))*\)\s*@", re.DOTALL)
"""Roll-pitch-yaw (a three-axis Euler sequence) and K = V Sigma V^T, written out."""
MINIMUM_JERK = re.compile(
    r"(?<![\w.])10(?:\.0)?\s*-\s*15(?:\.0)?\s*\*"  # s = tau^3 (10 - 15 tau + 6 tau^2)
    r"|(?<![\w.])10(?:\.0)?\s*\*\s*\w+\s*\*\*\s*3\s*-\s*15"  # s = 10 tau^3 - 15 tau^4 + 6 tau^5
    r"|(?<![\w.])30(?:\.0)?\s*\*\s*\w+\s*\*\*\s*2\s*\*\s*\(\s*1(?:\.0)?\s*-"  # ds/dtau = 30 tau^2 (1 - tau)^2
    r"|(?<![\d.])1\.875(?!\d)"  # its peak speed over its mean
)
YAW_ROTATION = re.compile(
    r"""(?:from|as)_euler\(\s*["'][zZ]["']"""  # scipy's rotation about Z alone
    r"|\[\[\s*(\w+)\s*,\s*-\s*(\w+)\s*,\s*0(?:\.0)?\s*\]\s*,\s*\[\s*\2\s*,\s*\1\b"  # [[c, -s, 0], [s, c, ...
    r"|(?:sin|cos)\(\s*-?\s*\w+\s*/\s*2(?:\.0)?\s*\)"  # the half angle of its quaternion
)
STIFFNESS_ELLIPSE = re.compile(r"(?<![\w.])(?:patches\.)?Ellipse\(")
ANGLE_WRAP = re.compile(
    r"a(?:rc)?tan2\(\s*(?:np\.|math\.)?sin\("  # atan2(sin a, cos a)
    r"|%\s*\(?\s*2(?:\.0)?\s*\*\s*(?:np\.|math\.)?pi|%\s*(?:np\.|math\.)?tau"  # (a + pi) % (2 pi) - pi
    r"|remainder\([^()]*,\s*(?:2(?:\.0)?\s*\*\s*)?(?:np\.|math\.)?(?:pi|tau)\s*\)"  # math.remainder(a, tau)
)
"""The minimum-jerk profile, a rotation about the vertical, a stiffness ellipse, an angle wrapped, written out."""


def copies(pattern, home):
    """Files of the library and the benches, other than ``home``, that write ``pattern`` out."""
    files = [*PACKAGE.rglob("*.py"), *(ROOT / "bench").glob("*.py")]
    return sorted(str(path.relative_to(ROOT)) for path in files if path != home and pattern.search(path.read_text()))


def test_roll_pitch_yaw_and_the_stiffness_composition_each_have_one_home():
    assert copies(EULER_SEQUENCE, PACKAGE / "core" / "rotations.py") == []
    assert copies(STIFFNESS_COMPOSITION, PACKAGE / "control" / "stiffness.py") == []


def test_minimum_jerk_yaw_rotation_angle_wrapping_and_the_stiffness_ellipse_each_have_one_home():
    assert copies(MINIMUM_JERK, PACKAGE / "core" / "trajectories.py") == []
    assert copies(YAW_ROTATION, PACKAGE / "core" / "rotations.py") == []
    assert copies(STIFFNESS_ELLIPSE, PACKAGE / "core" / "plotting.py") == []
    assert copies(ANGLE_WRAP, PACKAGE / "core" / "rotations.py") == []


def test_a_second_copy_of_either_is_recognised():
    assert EULER_SEQUENCE.search('Rotation.from_quat(q).as_euler("ZYX")[0]')
    assert EULER_SEQUENCE.search("Rotation.from_euler('xyz', rpy)")
    assert not EULER_SEQUENCE.search('Rotation.from_euler("z", yaw)')
    assert STIFFNESS_COMPOSITION.search("v @ np.diag(sigma) @ v.T")
    assert STIFFNESS_COMPOSITION.search("R.as_matrix()\n    @ np.diag([300.0, f(a), 1.0])\n    @ R.as_matrix().T")
    assert not STIFFNESS_COMPOSITION.search("transform[:3, :3] = rotation @ np.diag(lengths)")


SECOND_COPIES = {
    "minimum jerk": (
        MINIMUM_JERK,
        [
            "s**3 * (10.0 - 15.0 * s + 6.0 * s * s)",
            "t**3 * (10 - 15 * t + 6 * t**2)",
            "10 * tau**3 - 15 * tau**4 + 6 * tau**5",
            "rate = 30.0 * tau**2 * (1.0 - tau) ** 2 / self.duration",
            "PEAK_TO_MEAN = 1.875",
        ],
        ["timeout = 10.875; x = 110 - 15 * y"],
    ),
    "yaw rotation": (
        YAW_ROTATION,
        [
            'Rotation.from_euler("z", -config.grasp.yaw)',
            "Rotation.from_euler('Z', 20.0, degrees=True)",
            "return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])",
            "hs, hc = math.sin(-yaw / 2.0), math.cos(-yaw / 2.0)",
        ],
        ['Rotation.from_euler("x", math.pi)', "normal = np.array([math.cos(yaw), math.sin(yaw)])"],
    ),
    "stiffness ellipse": (
        STIFFNESS_ELLIPSE,
        ["axes.add_patch(\n    Ellipse(\n        (time, 0.0),", "patches.Ellipse((0, 0), 1, 2)"],
        ["painter.drawEllipse(centre, 6, 6)"],
    ),
    "angle wrap": (
        ANGLE_WRAP,
        [
            "math.atan2(math.sin(a - b), math.cos(a - b))",
            "np.arctan2(np.sin(yaw), np.cos(yaw))",
            "(angles + math.pi) % (2 * math.pi) - math.pi",
            "abs(math.remainder(later - earlier, math.tau))",
        ],
        ["yaw = 2.0 * np.arctan2(rotation.z, rotation.w)", "index = step % 2"],
    ),
}
"""Each form that once had a second home (issue 56), and neighbours of it that are something else."""


@pytest.mark.parametrize("name", SECOND_COPIES)
def test_a_second_minimum_jerk_yaw_rotation_ellipse_or_angle_wrap_is_recognised(name):
    pattern, written_out, something_else = SECOND_COPIES[name]
    assert [text for text in written_out if not pattern.search(text)] == []
    assert [text for text in something_else if pattern.search(text)] == []


GET_PARAM = re.compile(r"rospy\.(get|has)_param\(")
SERVER_READ = re.compile(r"\bserver_(value|has)\(")
# Where a process reads what another leaves on the parameter server (issue 56: each to become a topic, a service or
# a shared yaml section; a new one is refused): the START tab sigma7_node's backend (device.launch sets it); the
# device monitor and the thesis run sigma7_node's scenario_start, the thesis run its scenario_played; the behaviour
# tree its own ~running, left by a process of the same node that crashed; the study node each condition's values.
SERVER_READS = {"gui/start/ros.py": 1, "haptics/ros.py": 2, "run/thesis.py": 3, "bt/ros.py": 1, "study/ros.py": 1}


def test_a_node_reads_its_parameters_through_the_one_helper():
    """runtime.node.node_parameters reads a node's yaml and its private parameters, runtime.node.server_value and
    server_has a flag another process leaves on the server (issue 56: to become a topic or a service); nothing else
    asks the server, and no other module reads what another process left there."""
    helper = PACKAGE / "runtime" / "node.py"
    found = {
        str(path.relative_to(ROOT)): len(GET_PARAM.findall(path.read_text()))
        for path in PACKAGE.rglob("*.py")
        if path != helper
    }
    assert {path: count for path, count in found.items() if count} == {}
    assert len(GET_PARAM.findall(helper.read_text())) == 4  # the check saw the helper's own
    reads = {
        str(path.relative_to(PACKAGE)): len(SERVER_READ.findall(path.read_text())) for path in PACKAGE.rglob("*.py")
    }
    assert {path: count for path, count in reads.items() if count and path != "runtime/node.py"} == SERVER_READS


ROSCORE_START = re.compile(r"""["']roscore["']\s*,\s*["']-p["']""")
THIS_FILE = pathlib.Path(__file__).resolve()


def test_a_roscore_of_our_own_is_started_in_one_place():
    """Experiments, benches and tests get a master from runtime.processes.own_roscore (a free port, checked ours).

    The unit test of own_master's port race starts roscores on chosen ports itself, on purpose.
    """
    files = [*PACKAGE.rglob("*.py"), *(ROOT / "bench").glob("*.py"), *(ROOT / "test").rglob("*.py")]
    allowed = {PACKAGE / "runtime" / "processes.py", ROOT / "test" / "unit" / "test_run_thesis.py", THIS_FILE}
    found = sorted(
        str(path.relative_to(ROOT)) for path in files if path not in allowed and ROSCORE_START.search(path.read_text())
    )
    assert found == []
    assert ROSCORE_START.search('subprocess.Popen(["roscore", "-p", str(port)], env=env)')


MAX_FUNCTION_LINES = 50  # issue 56: a function longer than this is split into steps with names


def long_functions(tree, limit=MAX_FUNCTION_LINES):
    """{qualified name: lines} of the functions and methods of ``tree`` longer than ``limit`` (decorators excluded)."""
    found = {}

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = f"{prefix}{child.name}"
                lines = child.end_lineno - child.lineno + 1
                if not isinstance(child, ast.ClassDef) and lines > limit:
                    found[name] = lines
                visit(child, f"{name}.")
            else:
                visit(child, prefix)

    visit(tree, "")
    return found


def test_every_function_fits_in_fifty_lines():
    """A function longer than a screen does more than one thing: split it into named steps (issue 56)."""
    found = {
        f"{path}: {name}": lines for path, tree in modules().values() for name, lines in long_functions(tree).items()
    }
    too_long = sorted(f"{name} ({lines} lines)" for name, lines in found.items())
    assert too_long == [], f"longer than {MAX_FUNCTION_LINES} lines: {', '.join(too_long)}"


def test_a_long_function_is_found_by_its_qualified_name():
    body = "\n".join(f"        x{index} = {index}" for index in range(MAX_FUNCTION_LINES))
    tree = ast.parse(f"class A:\n    def long(self):\n{body}\n\n    def short(self):\n        pass\n")
    assert long_functions(tree) == {"A.long": MAX_FUNCTION_LINES + 1}


MAX_GUI_FILE_LINES = 400  # issue 56: a GUI file a Qt developer reads whole; a tab that grows past it splits by concern


def test_every_gui_file_fits_in_four_hundred_lines():
    """The GUI is a file per concern (a tab's view and its adapter, the window, the worker): none grows into a heap."""
    found = {
        str(path.relative_to(PACKAGE)): len(path.read_text().splitlines()) for path in (PACKAGE / "gui").rglob("*.py")
    }
    assert len(found) > 30  # the check saw the tabs' packages too
    too_long = sorted(f"{path} ({lines} lines)" for path, lines in found.items() if lines > MAX_GUI_FILE_LINES)
    assert too_long == [], f"longer than {MAX_GUI_FILE_LINES} lines: {', '.join(too_long)}"
