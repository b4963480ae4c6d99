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
