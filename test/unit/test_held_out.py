"""No held-out gap, seed or LASA shape in a test or a development script (bench/held_out.yaml, issue 51).

A figure measured on items the code was tuned or tested on is not held out: every bench declares its development and
held-out parts in bench/held_out.yaml, and this test reads every unit test, rostest (its .test file and its check), test
data file and development script for a held-out item. A line the file lists under known_leaks (with its reason) is let
through; any other fails, naming the file, the line and the bench whose held-out part it uses.
"""

import pathlib
import re

import yaml

ROOT = pathlib.Path(__file__).resolve().parents[2]
DECLARATION = ROOT / "bench" / "held_out.yaml"
SCANNED = ("*.py", "*.test", "*.yaml", "*.launch", "*.json", "*.md")
GAP = re.compile(r"(?<![A-Za-z0-9])gap_\d+(?!\d)")  # gap_3, and in place_gap_3
SEED = re.compile(r"seed\w*\W{1,4}(\d+)", re.IGNORECASE)


def declaration() -> dict:
    return yaml.safe_load(DECLARATION.read_text())


def held_out_items(benches: dict) -> dict:
    """Every held-out item: ('gap', name), ('seed', number), ('shape', name) -> the benches that hold it out."""
    items = {}
    for bench, parts in benches.items():
        held = parts.get("held_out", {})
        for gap in held.get("gaps", []):
            items.setdefault(("gap", gap), []).append(bench)
        for first, last in held.get("seeds", []):
            for seed in range(first, last + 1):
                items.setdefault(("seed", seed), []).append(bench)
        for shape in held.get("lasa_shapes", []):
            items.setdefault(("shape", shape), []).append(bench)
    return items


def scanned_files(development_scripts) -> list:
    folders = [ROOT / "test", *(ROOT / folder for folder in development_scripts)]
    files = [path for folder in folders for pattern in SCANNED for path in folder.rglob(pattern)]
    return sorted(path for path in set(files) if path != pathlib.Path(__file__).resolve())


def found_in(line: str, shapes) -> list:
    """The items a line names: gaps, seeds, quoted LASA shapes."""
    items = [("gap", gap) for gap in GAP.findall(line)]
    items += [("seed", int(seed)) for seed in SEED.findall(line)]
    items += [("shape", shape) for shape in shapes if f'"{shape}"' in line or f"'{shape}'" in line]
    return items


def test_the_declaration_names_real_gaps_seeds_and_shapes():
    from teleteach.core.scene import load_scene
    from teleteach.shared_control.operators import lasa_shapes

    found = declaration()
    gaps, shapes = set(load_scene().gaps), set(lasa_shapes())
    for bench, parts in found["benches"].items():
        assert (ROOT / "bench" / f"{bench}.py").exists(), bench
        for part in ("development", "held_out", "looked_at"):
            assert set(parts.get(part, {})) <= {"gaps", "seeds", "lasa_shapes"}, (bench, part)
            assert set(parts.get(part, {}).get("gaps", [])) <= gaps, (bench, part)
            assert set(parts.get(part, {}).get("lasa_shapes", [])) <= shapes, (bench, part)
            assert all(first <= last for first, last in parts.get(part, {}).get("seeds", [])), (bench, part)
        held, developed = parts.get("held_out", {}), parts.get("development", {})
        # Expect: nothing both developed on and held out in one bench
        assert not set(held.get("gaps", [])) & set(developed.get("gaps", [])), bench
        assert not set(held.get("lasa_shapes", [])) & set(developed.get("lasa_shapes", [])), bench
        for first, last in held.get("seeds", []):
            assert all(last < low or first > high for low, high in developed.get("seeds", [])), bench
    assert held_out_items(found["benches"])[("shape", "Angle")] == ["shared_control_sweep"]
    assert set(lasa_shapes()) == set(
        found["benches"]["shared_control_sweep"]["held_out"]["lasa_shapes"]
        + found["benches"]["shared_control_sweep"]["development"]["lasa_shapes"]
    )


def test_no_test_or_development_script_uses_a_held_out_gap_seed_or_shape():
    found = declaration()
    items = held_out_items(found["benches"])
    shapes = [name for kind, name in items if kind == "shape"]
    allowed = {(leak["file"], leak["item"]) for leak in found["known_leaks"]}
    leaks, used_allowances = [], set()
    for path in scanned_files(found["development_scripts"]):
        relative = str(path.relative_to(ROOT))
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), start=1):
            for item in found_in(line, shapes):
                if item not in items:
                    continue
                if (relative, str(item[1])) in allowed:
                    used_allowances.add((relative, str(item[1])))
                    continue
                leaks.append(f"{relative}:{number}: {item[0]} {item[1]} (held out by {', '.join(items[item])})")
    assert not leaks, "held-out items in tests or development scripts:\n" + "\n".join(leaks)
    # Expect: every listed leak still exists (a moved test leaves no stale allowance behind)
    assert used_allowances == allowed, sorted(allowed - used_allowances)


def test_the_scan_finds_gaps_seeds_and_quoted_shapes():
    assert found_in('TrialSetup("product_pick_1", "gap_3", "place_gap_3", seed=5)', ["Angle"]) == [
        ("gap", "gap_3"),
        ("gap", "gap_3"),
        ("seed", 5),
    ]
    assert found_in("seeds: [4900, 4901]", []) == [("seed", 4900)]
    assert found_in('lasa_path("Angle", 0, DT)  # not Angle unquoted', ["Angle", "Line"]) == [("shape", "Angle")]
