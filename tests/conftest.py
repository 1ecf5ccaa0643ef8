import fcntl
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from selfsense.io.manifest import load_dataset
from selfsense.twin.experiment import daq_plan
from selfsense.twin.params import TwinParams

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


IGNORE = shutil.ignore_patterns(
    ".venv",
    ".git",
    ".snakemake",
    "results",
    "figures",
    "logs",
    "*.nc",
    "out",
    "__pycache__",
    ".hypothesis",
    ".pytest_cache",
    "report.html",
)


def copy_repo(dest: Path) -> Path:
    """A copy of the repository's workflow files (no results, no captures) to run Snakemake in."""
    shutil.copytree(ROOT, dest, ignore=IGNORE)
    return dest


def measured_copy_remakes(table: str) -> bool:
    """Whether the measured copy of the smoke bench (tests/test_byod.py) makes ``table`` again, from
    the same samples in its own DAG, and is held to its bytes there: every table of pi_p885 but the
    twin's (they read /truth, which a measured capture has not) and the scorecard and stage plan
    (they differ by design). The rebuild test (tests/test_report.py) remakes the rest."""
    return (
        table.startswith("results/pi_p885/")
        and not table.startswith("results/pi_p885/twin/")
        and table not in ("results/pi_p885/scorecard.csv", "results/pi_p885/stages.csv")
    )


def snakemake(repo, *args, config="tests/config/smoke.yaml"):
    # targets go before --configfile, which takes several values
    return subprocess.run(
        [sys.executable, "-m", "snakemake", "--cores", "2", *args, "--configfile", config],
        cwd=repo,
        capture_output=True,
        text=True,
        timeout=1800,
    )


#: module-scoped fixtures that run a DAG of their own: a worker builds its own instance of a module's
#: fixture, so the tests sharing one go to one worker (split over two, the DAG ran twice)
OWN_DAGS = ("bench", "lab_csv")


@pytest.hookimpl(tryfirst=True)  # before xdist reads the groups off the markers
def pytest_collection_modifyitems(items):
    """The suite runs on pytest-xdist workers (addopts): the tests that run Snakemake inside the
    shared smoke tree, edit it or copy it whole (``smoke_tree``) go to one worker, one after
    another, and so do those that share a fixture of :data:`OWN_DAGS`; the tests that only read the
    smoke tree's captures and tables run on any."""
    for item in items:
        group = next((f for f in ("smoke_tree", *OWN_DAGS) if f in item.fixturenames), None)
        if group:
            item.add_marker(pytest.mark.xdist_group(group))


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory):
    """The whole DAG on the smoke campaign in a scratch copy, run once per test run: under
    pytest-xdist the first worker that needs it runs it, under a lock in the folder the workers'
    temporary folders share, and the others wait for it and read the same tree."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        return _smoke_dag(tmp_path_factory.mktemp("dag"))
    shared = tmp_path_factory.getbasetemp().parent
    with open(shared / "smoke_run.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes, also if the worker dies
        done = shared / "smoke_run.json"
        if not done.exists():
            try:
                repo = _smoke_dag(shared / "dag")
                done.write_text(json.dumps({"repo": str(repo)}))
            except (
                AssertionError
            ) as err:  # every worker fails with the same reason, none runs it again
                done.write_text(json.dumps({"failed": str(err)}))
    state = json.loads(done.read_text())
    assert "failed" not in state, state.get("failed")
    return Path(state["repo"])


def _smoke_dag(folder: Path) -> Path:
    repo = copy_repo(folder / "repo")
    run = snakemake(repo)
    assert run.returncode == 0, run.stderr[-3000:]
    return repo


@pytest.fixture(scope="session")
def smoke_report(smoke_tree):
    """`snakemake --report report.html` in the smoke tree, built once for the tests that read it:
    (path of the page, the build's stderr)."""
    run = snakemake(smoke_tree, "--report", "report.html")
    assert run.returncode == 0, run.stderr[-3000:]
    return smoke_tree / "report.html", run.stderr


@pytest.fixture(scope="session")
def smoke_tree(smoke_run):
    """``smoke_run`` for a test that runs Snakemake inside it, edits it or copies it whole: these
    run on one pytest-xdist worker, one at a time (pytest_collection_modifyitems)."""
    return smoke_run
