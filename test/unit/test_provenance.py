"""A bench result's provenance (teleteach.run.provenance): what anyone needs to tell which code and settings made it."""

import hashlib
import re
import sys

from teleteach.core.paths import config_file
from teleteach.run.provenance import provenance


def test_the_provenance_names_the_commit_the_command_the_configuration_and_the_machine(monkeypatch):
    monkeypatch.setattr(sys, "argv", ["/somewhere/bench/wiping_ablation.py", "--trials", "3"])
    scene = config_file("supermarket.yaml")
    record = provenance([scene])
    assert re.fullmatch(r"[0-9a-f]{40}", record["commit"])
    assert isinstance(record["dirty"], bool)
    assert record["command"] == ["wiping_ablation.py", "--trials", "3"]
    assert record["config_sha256"] == {"supermarket.yaml": hashlib.sha256(scene.read_bytes()).hexdigest()}
    assert record["machine"]["cores"] >= 1 and record["machine"]["packages"]["numpy"] != "not installed"
    assert re.match(r"\d{4}-\d\d-\d\dT", record["date"])


def test_a_bench_asks_for_held_out_seeds_unless_told_development():
    import argparse

    import pytest

    from teleteach.run.trials import add_trial_arguments, trial_seeds

    parser = argparse.ArgumentParser()
    add_trial_arguments(parser, 3, least=2)
    assert trial_seeds(parser, parser.parse_args([]), 4900) == [4900, 4901, 4902]
    assert trial_seeds(parser, parser.parse_args(["--development", "--trials", "2"]), 4900) == [0, 1]
    with pytest.raises(SystemExit):
        trial_seeds(parser, parser.parse_args(["--trials", "1"]), 4900)
    with pytest.raises(SystemExit):
        trial_seeds(parser, parser.parse_args(["--processes", "0"]), 4900)


def test_a_stored_result_rewritten_by_an_earlier_bench_does_not_make_the_next_one_dirty(monkeypatch):
    from teleteach.run import provenance as module

    asked = []

    def git(*arguments):
        asked.append(arguments)
        return " M bench/results/wiping_ablation.json" if "status" in arguments and len(arguments) == 3 else ""

    monkeypatch.setattr(module, "_git", git)
    assert module.provenance([])["dirty"] is False
    (status,) = [arguments for arguments in asked if arguments[0] == "status"]
    assert status[-2:] == (".", ":(exclude)bench/results")  # the code and the settings still count


def test_a_placement_bench_names_the_configuration_every_trial_reads_and_its_own_files(tmp_path):
    from teleteach.run.trials import placement_provenance

    skill = tmp_path / "TaughtPlace.npz"
    skill.write_bytes(b"a taught skill")
    record = placement_provenance(config_file("uncertainty.yaml"), skill)
    assert sorted(record["config_sha256"]) == sorted(
        ["supermarket.yaml", "skills_motion.yaml", "controllers.yaml", "uncertainty.yaml", "TaughtPlace.npz"]
    )
    assert record["config_sha256"]["TaughtPlace.npz"] == hashlib.sha256(b"a taught skill").hexdigest()
