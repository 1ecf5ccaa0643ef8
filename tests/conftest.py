import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from selfsense.manifest import load_dataset
from selfsense.twin import TwinParams, daq_plan

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def stack_manifest():
    return load_dataset(ROOT / "raw", "pi_p885")


@pytest.fixture(scope="session")
def stack_params(stack_manifest):
    return TwinParams.from_manifest(stack_manifest["twin"])


@pytest.fixture(scope="session")
def stack_daq(stack_manifest):
    return daq_plan(stack_manifest)


def raised_sine(f, duration, fs=48000.0, hi=100.0):
    t = np.arange(int(round(duration * fs))) / fs
    return t, hi * 0.5 * (1 - np.cos(2 * np.pi * f * t))


IGNORE = shutil.ignore_patterns(".venv", ".git", ".snakemake", "results", "figures", "logs", "*.nc",
                                "out", "__pycache__", ".hypothesis", ".pytest_cache", "report.html")


def copy_repo(dest: Path) -> Path:
    """A copy of the repository's workflow files (no results, no captures) to run Snakemake in."""
    shutil.copytree(ROOT, dest, ignore=IGNORE)
    return dest


def snakemake(repo, *args, config="tests/config/smoke.yaml"):
    # targets go before --configfile, which takes several values
    return subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", *args, "--configfile", config],
                          cwd=repo, capture_output=True, text=True, timeout=1800)


@pytest.hookimpl(tryfirst=True)  # before xdist reads the groups off the markers
def pytest_collection_modifyitems(items):
    """Under pytest-xdist (the suite's addopts) every test that needs the smoke DAG goes to one
    worker, which runs that DAG once (a session fixture is per worker); the others share out the
    rest meanwhile."""
    for item in items:
        if "smoke_run" in item.fixturenames:
            item.add_marker(pytest.mark.xdist_group("smoke_run"))


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory):
    """The whole DAG on the smoke campaign, run once per test session in a scratch copy."""
    repo = copy_repo(tmp_path_factory.mktemp("dag") / "repo")
    run = snakemake(repo)
    assert run.returncode == 0, run.stderr[-3000:]
    return repo
