"""The tables of figures in the docs are what the stored results render (bench/render_docs.py, issue 51, item 2).

A table between ``<!-- results:NAME -->`` and ``<!-- /results -->`` that differs from its stored result is a figure
nobody can check; the failure names the table, shows the difference and lists the stored results older than the code
their bench measures (bench/measures.yaml), so whoever re-runs knows which.
"""

import difflib
import subprocess

import pytest
import yaml
from bench_scripts import bench_module

render_docs = bench_module("render_docs")


def test_every_table_of_figures_in_the_docs_is_what_its_stored_result_renders():
    problems = []
    for path in render_docs.DOCS:
        text = path.read_text()
        expected = render_docs.rendered(text, path.name)
        if expected != text:
            diff = difflib.unified_diff(text.splitlines(), expected.splitlines(), str(path), "rendered", lineterm="")
            problems.append("\n".join(diff))
    if problems:
        stale = render_docs.staleness_report() or "none"
        pytest.fail(
            "tables differ from the stored results (python bench/render_docs.py writes them):\n"
            + "\n".join(problems)
            + f"\nstored results older than the code they measure:\n{stale}"
        )


def test_every_figure_stands_in_the_docs_once():
    names = [match.group(2) for path in render_docs.DOCS for match in render_docs.BLOCK.finditer(path.read_text())]
    assert sorted(names) == sorted(render_docs.FIGURES)


def test_a_table_edited_by_hand_is_found():
    block = f"<!-- results:wiping_ablation -->\n{render_docs.render('wiping_ablation')}<!-- /results -->"
    assert render_docs.rendered(block) == block
    edited = block.replace("22 / 30", "30 / 30")
    assert edited != block and render_docs.rendered(edited) == block


def test_a_block_naming_no_figure_is_refused():
    with pytest.raises(KeyError, match="results:wiping_ablations"):
        render_docs.rendered("<!-- results:wiping_ablations -->\n<!-- /results -->", "README.md")


def test_every_bench_measures_paths_that_exist():
    measures = yaml.safe_load(render_docs.MEASURES.read_text())
    benches = {figure.bench for figure in render_docs.FIGURES.values()} - {"mutation"}
    assert benches <= set(measures)
    missing = [path for paths in measures.values() for path in paths if not (render_docs.ROOT / path).exists()]
    assert not missing


def fake_log(changes):
    """git as older_than_the_code calls it, answering ``changes`` to the log of the measured paths."""

    def log(*arguments):
        if arguments[-1] == "unknown/path.py":
            raise subprocess.CalledProcessError(128, "git")
        return changes

    return log


def measured(provenance, paths=("src/teleteach/wiping",)):
    return render_docs.Measured("x.json", provenance, paths)


def test_a_result_is_older_than_the_code_when_a_later_commit_changed_what_it_measures():
    provenance = {"commit": "a" * 40, "dirty": False, "config_sha256": {}}
    assert render_docs.older_than_the_code(measured(provenance), fake_log("")) == []
    reasons = render_docs.older_than_the_code(
        measured(provenance), fake_log("e00f971 2026-11-29 Scripted wipe operator\n1594626 2026-11-29 Wiping skill")
    )
    assert reasons == [
        "2 later commit(s) changed what it measures, the last: e00f971 2026-11-29 Scripted wipe operator"
    ]


def test_a_dirty_run_a_changed_config_and_an_unknown_commit_are_named():
    changed = {"commit": "a" * 40, "dirty": True, "config_sha256": {"wiping.yaml": "0" * 64}}
    assert render_docs.older_than_the_code(measured(changed), fake_log("")) == [
        "run with uncommitted changes",
        "wiping.yaml differs from the one it read",
    ]
    unknown = measured({"commit": "b" * 40, "dirty": False}, ("unknown/path.py",))
    assert render_docs.older_than_the_code(unknown, fake_log("")) == [
        "its commit bbbbbbb is not in this checkout's history"
    ]
    assert render_docs.older_than_the_code(measured({}), fake_log("")) == [
        "no provenance: the commit it was measured at is unknown"
    ]
