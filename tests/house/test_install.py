"""The package works installed the ordinary way (not editable): its schemas are package data and
nothing walks up from the installed module to find the checkout."""

import os
import subprocess
import sys

import pytest

from ..helpers import copy_repo, run_snakemake

WHERE = "import selfsense, selfsense.io.manifest as m; print(selfsense.__file__); print(m.SCHEMAS)"


@pytest.mark.slow
def test_a_non_editable_install_runs_the_workflow_from_the_checkout(tmp_path):
    repo = copy_repo(tmp_path / "repo")  # pip builds in the source tree: keep the checkout clean
    site = tmp_path / "site"
    install = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "-q",
            "--no-deps",
            "--target",
            str(site),
            str(repo),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert install.returncode == 0, install.stderr[-3000:]
    env = os.environ | {"PYTHONPATH": str(site)}
    where = subprocess.run(
        [sys.executable, "-c", WHERE],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert where.returncode == 0, where.stderr[-2000:]
    module, schemas = where.stdout.split()
    assert module.startswith(str(site)) and schemas.startswith(str(site)), where.stdout
    dry = run_snakemake(repo, "-n", cores=1, timeout=600, env=env)
    assert dry.returncode == 0, dry.stderr[-3000:]
    assert "simulate" in dry.stdout and "scorecard" in dry.stdout
