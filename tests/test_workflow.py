"""End to end: the whole DAG on the smoke campaign, in a scratch copy of the repository."""

import subprocess
import sys

import pandas as pd
import pytest

pytestmark = pytest.mark.slow


def snakemake(repo, *args):
    return subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2",
                           "--configfile", "tests/config/smoke.yaml", *args],
                          cwd=repo, capture_output=True, text=True, timeout=1800)


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    from .conftest import ROOT
    import shutil

    repo = tmp_path_factory.mktemp("dag") / "repo"
    shutil.copytree(ROOT, repo, ignore=shutil.ignore_patterns(
        ".venv", ".git", ".snakemake", "results", "figures", "logs", "*.nc", "out", "__pycache__",
        ".hypothesis", ".pytest_cache"))
    run = snakemake(repo)
    assert run.returncode == 0, run.stderr[-3000:]
    return repo


def test_every_capture_is_made_and_checked(smoke_run):
    table = pd.read_csv(smoke_run / "results/pi_p885/qc/captures.csv")
    made = sorted(p.stem for p in (smoke_run / "raw/pi_p885").glob("*.nc"))
    assert sorted(table["experiment"]) == made and len(made) > 20
    assert (table["NaN samples"] == 0).all() and (table["clipped samples"] == 0).all()
    assert (smoke_run / "results/pi_p885/qc/captures.csv.json").exists()


def test_every_rule_leaves_a_log_and_a_benchmark(smoke_run):
    assert list((smoke_run / "logs/pi_p885/simulate").glob("*.log"))
    assert list((smoke_run / "benchmarks/out/pi_p885/simulate").glob("*.tsv"))


def test_up_to_date_tree_has_nothing_to_do(smoke_run):
    dry = snakemake(smoke_run, "-n")
    assert dry.returncode == 0
    assert "Nothing to be done" in dry.stdout + dry.stderr
