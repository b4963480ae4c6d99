import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def pytest_configure(config):
    if "TELETEACH_ROOT" not in os.environ:
        raise pytest.UsageError("run the tests through `bash scripts/test` (it sources build/env.sh first)")


@pytest.fixture
def artifacts_dir():
    """Folder for files a person should look at after the run (screenshots, plots)."""
    path = ROOT / "test-artifacts"
    path.mkdir(exist_ok=True)
    return path
