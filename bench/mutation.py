"""Mutation testing of the pure library's core (issue 32): how many deliberate bugs each module's unit tests catch.

For each module given (a path under src/teleteach such as ``haptics/click.py``; all of bench/mutation.yaml's when
none is) it lays out a scratch folder build/mutation/<module>/ (links to this checkout, a fresh ``mutants/``, a
setup.cfg telling mutmut the one file to mutate and the module's tests from bench/mutation.yaml), runs ``mutmut run``
there (its output in mutmut.log beside it), reads every mutant's status (``mutmut results --all true``), sets aside
the equivalent mutants the yaml names, prints each survivor as file:line and its mutated line, and merges
{module: {mutants, killed, survived, timeout, score, ..., provenance}} into bench/results/mutation.json (the modules
not run keep their entries; the provenance says at which commit each was run). The score is (killed + timeout) /
mutants, equivalents excluded; a mutant no selected test reaches ("no tests") counts as survived. Not a test: far too
slow for CI. Needs mutmut 3 (Python >= 3.10).

    source build/env.sh && python bench/mutation.py haptics/click.py     (or: bash scripts/mutation haptics/click.py)
"""

import argparse
import ast
import json
import pathlib
import re
import shutil
import subprocess
import sys
import time

import yaml

from teleteach.run.provenance import provenance

ROOT = pathlib.Path(__file__).resolve().parents[1]
CONFIG = ROOT / "bench" / "mutation.yaml"
RESULTS = ROOT / "bench" / "results" / "mutation.json"
WORK = ROOT / "build" / "mutation"
PACKAGE = "src/teleteach"
CLASS_SEPARATOR = "ǁ"  # mutmut's mangled names: x_function__mutmut_3, xǁClassǁmethod__mutmut_3
# mutmut's statuses, grouped as the results count them
KILLED = {"killed", "caught by type check", "segfault"}  # segfault: the test process died, the mutant was seen
TIMEOUT = {"timeout"}
SURVIVED = {"survived", "no tests", "suspicious"}
RESULT_LINE = re.compile(r"^\s+(\S+__mutmut_\d+): (.+)$")
HUNK = re.compile(r"^@@ -(\d+)(?:,\d+)? \+\d+(?:,\d+)? @@")
# what the scratch folder does not link: the workspace and the venv (mutmut would walk them), git's folder
NOT_LINKED = {"build", ".venv", ".git"}


def load_config(path=CONFIG) -> dict:
    """The modules of bench/mutation.yaml: {module: {"tests": [...], "equivalent": [{mutant, mutation, reason}]}}."""
    modules = yaml.safe_load(pathlib.Path(path).read_text())["modules"]
    for module, entry in modules.items():
        if not entry.get("tests"):
            raise ValueError(f"{path}: {module} names no tests")
        for exclusion in entry.setdefault("equivalent", []):
            missing = {"mutant", "mutation", "reason"} - set(exclusion)
            if missing:
                raise ValueError(f"{path}: an equivalent mutant of {module} lacks {', '.join(sorted(missing))}")
    return modules


def module_key(argument: str, modules) -> str:
    """The yaml's name of a module given as haptics/click.py, haptics.click, teleteach.haptics.click or its path."""
    name = argument.strip()
    for prefix in (f"{PACKAGE}/", "teleteach."):
        if name.startswith(prefix):
            name = name[len(prefix) :]
    if not name.endswith(".py"):
        name = name.replace(".", "/") + ".py"
    if name not in modules:
        raise KeyError(f"{argument}: not a module of bench/mutation.yaml ({', '.join(modules)})")
    return name


def setup_cfg(module: str, tests) -> str:
    """mutmut's configuration for one module: mutate only its file, select only its tests.

    The unit tests need no display: without ``-p no:xvfb`` every mutant's pytest starts an Xvfb that mutmut's forked
    children never stop (a run over click.py left some 500 behind, and the next Xvfb could not start).
    """
    lines = ["[mutmut]", "source_paths = src", f"only_mutate = {PACKAGE}/{module}"]
    lines += ["pytest_add_cli_args_test_selection ="]
    lines += [f"    {test}" for test in tests]
    lines += ["pytest_add_cli_args =", "    -p", "    no:cacheprovider", "    -p", "    no:xvfb"]
    return "\n".join(lines) + "\n"


def parse_results(text: str) -> dict:
    """``mutmut results --all true`` -> {mutant name: status}."""
    return {match.group(1): match.group(2).strip() for match in map(RESULT_LINE.match, text.splitlines()) if match}


def function_of(mutant: str):
    """(class name or None, function name) a mutant lives in, from mutmut's name for it."""
    mangled = mutant.rpartition(".")[2].partition("__mutmut_")[0]
    if CLASS_SEPARATOR in mangled:
        _, class_name, function = mangled.split(CLASS_SEPARATOR)
        return class_name, function
    return None, mangled[len("x_") :]


def function_span(source: str, class_name, function: str):
    """(first line, last line) of a top-level function or a method in ``source``, decorators included (or None)."""
    body = ast.parse(source).body
    if class_name is not None:
        body = next((node.body for node in body if isinstance(node, ast.ClassDef) and node.name == class_name), [])
    for node in body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name == function:
            first = min([node.lineno] + [decorator.lineno for decorator in node.decorator_list])
            return first, node.end_lineno
    return None


def parse_diff(diff: str):
    """A mutant's diff (``mutmut show``, the function before and after) -> (offset of the first changed line in the
    function, its original text, the mutated text: the added lines joined, '' when the line was removed)."""
    offset, removed, added = None, None, []
    position = 0
    for line in diff.splitlines():
        hunk = HUNK.match(line)
        if hunk:
            position = int(hunk.group(1))
            continue
        if line.startswith(("---", "+++")) or position == 0:
            continue
        if line.startswith("-"):
            if removed is None:
                offset, removed = position, line[1:]
            position += 1
        elif line.startswith("+"):
            added.append(line[1:].strip())
        else:
            position += 1
    return offset, removed, " / ".join(added)


def survivor_line(source: str, mutant: str, diff: str):
    """(line number in the module, original line, mutated line) of a mutant, from its diff; the line is the one of
    the function's lines with the diff's original text nearest to where the diff's offset puts it."""
    offset, removed, added = parse_diff(diff)
    span = function_span(source, *function_of(mutant))
    if span is None or offset is None:
        return (span[0] if span else None), (removed or "").strip(), added
    lines = source.splitlines()
    expected = span[0] + offset - 1
    matches = [number for number in range(span[0], span[1] + 1) if lines[number - 1].strip() == removed.strip()]
    number = min(matches, key=lambda candidate: abs(candidate - expected)) if matches else expected
    return number, removed.strip(), added


def tally(statuses: dict, equivalent=()) -> dict:
    """Counts of a module's mutants, the equivalent ones (names) left out; score = (killed + timeout) / mutants."""
    counted = {name: status for name, status in statuses.items() if name not in set(equivalent)}
    killed = sum(status in KILLED for status in counted.values())
    timeout = sum(status in TIMEOUT for status in counted.values())
    survived = sum(status in SURVIVED for status in counted.values())
    result = {
        "mutants": len(counted),
        "killed": killed,
        "survived": survived,
        "timeout": timeout,
        "score": round((killed + timeout) / len(counted), 4) if counted else None,
        "no_tests": sum(status == "no tests" for status in counted.values()),
        "not_checked": len(counted) - killed - timeout - survived,
        "equivalent_excluded": len(statuses) - len(counted),
    }
    return result


def merge(existing: dict, new: dict) -> dict:
    """The results file after a run: the new modules' entries replace theirs, the others stay; sorted by module."""
    merged = dict(existing)
    merged.update(new)
    return dict(sorted(merged.items()))


def applicable_exclusions(exclusions, diffs: dict):
    """The equivalent mutants whose mutated line still reads as the yaml says, and warnings for the others."""
    applied, warnings = [], []
    for exclusion in exclusions:
        diff = diffs.get(exclusion["mutant"])
        if diff is None:
            warnings.append(f"{exclusion['mutant']}: no such surviving mutant, exclusion not applied")
            continue
        mutated = parse_diff(diff)[2]
        if mutated != exclusion["mutation"].strip():
            warnings.append(f"{exclusion['mutant']}: now mutates to {mutated!r}, not {exclusion['mutation']!r}")
            continue
        applied.append(exclusion["mutant"])
    return applied, warnings


def prepare(module: str, tests) -> pathlib.Path:
    """build/mutation/<module>/: links to the checkout's entries, setup.cfg, and an empty mutants/ in which every
    entry but src/ and test/ (mutmut copies those two) is linked, so tests find config/ etc. beside their copy."""
    folder = WORK / module[: -len(".py")].replace("/", ".")
    shutil.rmtree(folder, ignore_errors=True)
    (folder / "mutants").mkdir(parents=True)
    for entry in sorted(ROOT.iterdir()):
        if entry.name in NOT_LINKED:
            continue
        (folder / entry.name).symlink_to(entry)
        if entry.name not in {"src", "test", "pyproject.toml"}:
            (folder / "mutants" / entry.name).symlink_to(entry)
    (folder / "setup.cfg").write_text(setup_cfg(module, tests))
    return folder


def mutmut(folder: pathlib.Path, *arguments, log=None) -> str:
    """Runs ``mutmut ARGUMENTS`` in ``folder``; its output (to ``log`` when given)."""
    command = [sys.executable, "-c", "import sys; from mutmut.__main__ import cli; sys.exit(cli())", *arguments]
    if log is None:
        return subprocess.run(command, cwd=folder, capture_output=True, text=True, check=True).stdout
    with open(log, "w") as output:
        status = subprocess.run(command, cwd=folder, stdout=output, stderr=subprocess.STDOUT).returncode
    if status != 0:
        raise RuntimeError(f"mutmut {' '.join(arguments)} failed with status {status}: see {log}")
    return ""


def run_module(module: str, entry: dict, jobs: int) -> dict:
    """Mutation testing of one module: its figures, with its survivors (where, original and mutated line)."""
    result_provenance = provenance([CONFIG])
    folder = prepare(module, entry["tests"])
    print(f"mutation: {module} against {len(entry['tests'])} test files (log: {folder / 'mutmut.log'})", flush=True)
    started = time.monotonic()
    mutmut(folder, "run", "--max-children", str(jobs), log=folder / "mutmut.log")
    seconds = time.monotonic() - started
    statuses = parse_results(mutmut(folder, "results", "--all", "true"))
    if not statuses:
        raise RuntimeError(f"mutmut found no mutants in {module}: see {folder / 'mutmut.log'}")
    source = (ROOT / PACKAGE / module).read_text()
    left = sorted((name for name, status in statuses.items() if status in SURVIVED), key=_mutant_order)
    diffs = {name: mutmut(folder, "show", name) for name in left}
    applied, warnings = applicable_exclusions(entry["equivalent"], diffs)
    for warning in warnings:
        print(f"mutation: {module}: equivalent mutant {warning}")
    result = tally(statuses, applied)
    result["seconds"] = round(seconds, 1)
    result["tests"] = list(entry["tests"])
    result["provenance"] = result_provenance
    result["survivors"] = []
    for name in left:
        if name in applied:
            continue
        number, original, mutated = survivor_line(source, name, diffs[name])
        result["survivors"].append(
            {
                "mutant": name,
                "status": statuses[name],
                "where": f"{PACKAGE}/{module}:{number}",
                "original": original,
                "mutated": mutated,
            }
        )
    return result


def _mutant_order(name: str):
    function = name.partition("__mutmut_")
    return function[0], int(function[2])


def report(module: str, result: dict) -> None:
    score = "-" if result["score"] is None else f"{100 * result['score']:.1f} %"
    print(
        f"mutation: {module}: score {score}: {result['mutants']} mutants, {result['killed']} killed, "
        f"{result['timeout']} timeout, {result['survived']} survived ({result['no_tests']} reached by no test), "
        f"{result['equivalent_excluded']} equivalent excluded, {result['seconds']} s"
    )
    for survivor in result["survivors"]:
        note = "" if survivor["status"] == "survived" else f"  [{survivor['status']}]"
        print(f"  {survivor['where']}: {survivor['original']}  ->  {survivor['mutated'] or '(removed)'}{note}")
        print(f"      ({survivor['mutant']})")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("modules", nargs="*", help="paths under src/teleteach (default: all of bench/mutation.yaml)")
    parser.add_argument("--jobs", type=int, default=1, help="mutants tested at once (mutmut's --max-children)")
    options = parser.parse_args()
    if sys.version_info < (3, 10):
        print("mutation: mutmut 3 needs Python >= 3.10 (Debian 12's 3.11); not available on Noetic's 3.8")
        return 2
    modules = load_config()
    try:
        chosen = [module_key(argument, modules) for argument in options.modules] or list(modules)
    except KeyError as error:
        print(f"mutation: {error.args[0]}")
        return 2
    results = {}
    for module in chosen:
        results[module] = run_module(module, modules[module], options.jobs)
        report(module, results[module])
        existing = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
        RESULTS.parent.mkdir(parents=True, exist_ok=True)
        RESULTS.write_text(json.dumps(merge(existing, {module: results[module]}), indent=2) + "\n")
    print(f"mutation: wrote {RESULTS.relative_to(ROOT)}")
    for module, result in results.items():
        score = "-" if result["score"] is None else f"{100 * result['score']:.1f} %"
        print(f"mutation: {module:28s} {score:>8s}  ({result['survived']} of {result['mutants']} survived)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
