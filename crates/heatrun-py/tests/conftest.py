"""Shared paths and the optional command line the tests compare with."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

#: The repository's root (fixtures/, examples/, datasets/).
ROOT = Path(os.environ.get("HEATRUN_ROOT", Path(__file__).resolve().parents[3]))
FIXTURE = ROOT / "fixtures" / "paper_heat_run.mcap"
TRUTH = ROOT / "fixtures" / "paper_heat_run.mcap.truth.json"
TCLAB = ROOT / "datasets" / "tclab_mimo_heaters"
TCLAB_EXAMPLE = ROOT / "examples" / "tclab_mimo_heaters"


def heatrun_binary():
    """The `heatrun` command named by $HEATRUN (or on PATH), else None."""
    named = os.environ.get("HEATRUN")
    if named:
        return named if Path(named).exists() else None
    return shutil.which("heatrun")


@pytest.fixture(scope="session")
def cli():
    """Runs the command line (skips the test where there is none)."""
    binary = heatrun_binary()
    if binary is None:
        pytest.skip("no heatrun binary ($HEATRUN) to compare with")

    def run(*args, cwd=None):
        return subprocess.run(
            [binary, *map(str, args)], cwd=cwd, check=True, capture_output=True, text=True
        )

    return run


@pytest.fixture(scope="session")
def fixture_report():
    """The shipped fixture replayed once for the session (with its traces)."""
    import heatrun

    return heatrun.replay(str(FIXTURE))
