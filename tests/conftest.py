"""The fixtures the tests share: pi_p885's twin, and the smoke DAG (run once per test run, shared
by the pytest-xdist workers). Plain helpers are in tests/helpers.py."""

import compileall
import fcntl
import json
import os
from pathlib import Path

import pytest

from selfsense.io.manifest import load_dataset
from selfsense.twin.experiment import daq_plan
from selfsense.twin.params import TwinParams

from .helpers import ROOT, copy_repo, run_snakemake


@pytest.fixture(scope="session")
def stack_manifest():
    return load_dataset(ROOT / "raw", "pi_p885")


@pytest.fixture(scope="session")
def stack_params(stack_manifest):
    return TwinParams.from_manifest(stack_manifest["twin"])


@pytest.fixture(scope="session")
def stack_daq(stack_manifest):
    return daq_plan(stack_manifest)


def pytest_configure(config):
    """The controller compiles the library to bytecode once, before the workers start: the suite
    starts some hundreds of Python processes (Snakemake's jobs, its parses of the workflow), and
    where the environment forbids Python to write bytecode (PYTHONDONTWRITEBYTECODE) each of them
    compiled the library's 70 modules again, about 0.3 s of CPU apiece. py_compile writes the
    files whatever that setting says; a module edited later is compiled afresh from its source."""
    if not hasattr(config, "workerinput"):
        compileall.compile_dir(ROOT / "src", quiet=1)


#: module-scoped fixtures that run a DAG of their own (or copy the smoke tree): a worker builds its
#: own instance of a module's fixture, so the tests sharing one go to one worker (split over two,
#: the DAG ran twice)
OWN_DAGS = ("bench", "lab_csv", "config_tree", "batches", "lab_examples", "hostile", "lab_roles")

#: the group of every test that does not need the smoke DAG: the first group, so that one worker
#: runs it while the other runs the smoke DAG that every other test waits for
BESIDE_THE_SMOKE_DAG = "beside_the_smoke_dag"

#: the groups and tests that come next, in this order: the long ones start first, so that they do
#: not end the run alone while the other worker idles; a worker takes the next one when it starts
#: its last test but one, so the first two go to the worker that is done first (the SLURM test
#: waits for the cluster's queue, beside the dry runs of config_tree on the same worker)
LONG_FIRST = (
    "test_slurm.py::",
    "@config_tree",
    "test_a_measured_ripple_bench_runs_every_analysis_to_the_end",
    "@bench",
)


@pytest.hookimpl(tryfirst=True)  # before xdist reads the groups off the markers
def pytest_collection_modifyitems(items):
    """The suite runs on pytest-xdist workers (addopts, which keep the scopes in the order of
    collection): the tests that do not need the smoke DAG go to one worker together
    (:data:`BESIDE_THE_SMOKE_DAG`), first; the tests that run Snakemake inside the shared smoke
    tree, edit it or copy it whole (``smoke_tree``) go to one worker, one after another, next,
    and so do those that share a fixture of :data:`OWN_DAGS`; the long ones follow
    (:data:`LONG_FIRST`), and the tests that only read the smoke tree's captures and tables fill
    the gaps at the end."""
    groups = {}
    for item in items:
        group = next((f for f in ("smoke_tree", *OWN_DAGS) if f in item.fixturenames), None)
        if "smoke_run" not in item.fixturenames:
            group = BESIDE_THE_SMOKE_DAG  # a module's own fixture included: one worker runs both
        if group:
            item.add_marker(pytest.mark.xdist_group(group))
        groups[item] = group

    def order(item):
        name = f"{item.nodeid}@{groups[item]}"
        if groups[item] in (BESIDE_THE_SMOKE_DAG, "smoke_tree"):
            return (0, groups[item] != BESIDE_THE_SMOKE_DAG)
        long = [i for i, key in enumerate(LONG_FIRST) if key in name]
        return (1, long[0]) if long else (2, 0)

    items.sort(key=order)


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
            except AssertionError as err:
                # every worker fails with the same reason, none runs it again
                done.write_text(json.dumps({"failed": str(err)}))
    state = json.loads(done.read_text())
    assert "failed" not in state, state.get("failed")
    return Path(state["repo"])


def _smoke_dag(folder: Path) -> Path:
    repo = copy_repo(folder / "repo")
    run = run_snakemake(repo)
    assert run.returncode == 0, run.stderr[-3000:]
    return repo


@pytest.fixture(scope="session")
def smoke_report(smoke_tree):
    """`snakemake --report report.html` in the smoke tree, built once for the tests that read it:
    (path of the page, the build's stderr)."""
    run = run_snakemake(smoke_tree, "--report", "report.html")
    assert run.returncode == 0, run.stderr[-3000:]
    return smoke_tree / "report.html", run.stderr


@pytest.fixture(scope="session")
def smoke_tree(smoke_run):
    """``smoke_run`` for a test that runs Snakemake inside it, edits it or copies it whole: these
    run on one pytest-xdist worker, one at a time (pytest_collection_modifyitems)."""
    return smoke_run
