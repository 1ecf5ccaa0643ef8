"""The small configuration through SLURM (profiles/slurm) on a real single-node cluster: its
tables must be byte-identical to the local run's.

The cluster is the one scripts/slurm_local.sh brings up (installing Debian's munge, slurmctld and
slurmd where they are missing), or finds running. Where it cannot (not root, no apt, no network,
daemons that will not start), the test skips and says why; `pytest -m "not slurm"` leaves it out.

Chapter 3 only (9 SLURM jobs: 3 captures simulated and checked, their ripple extracted, the
Ch. 3 tables and the twin's C_e recovery, ≈ 50 s on 2 cores): every SLURM job starts Snakemake
twice (the batch script, then the job step), ≈ 7 s of extra core time per job, so the whole smoke
DAG (≈ 130 jobs) would take ≈ 15 minutes and Chapters 3 and 4 (26 jobs) ≈ 2½, where this subset
already goes every way a job can (a capture written and checked, read by the next job through the
shared filesystem, tables compared byte for byte).
"""

import re
import subprocess

import pytest

from ..helpers import ROOT, copy_repo, run_snakemake

pytestmark = [pytest.mark.slurm, pytest.mark.slow]

SCRIPT = str(ROOT / "scripts" / "slurm_local.sh")
TABLES = [
    f"results/pi_p885/{t}.csv"
    for t in ("ch3/table_3_1", "ch3/table_3_2", "ch3/hysteresis", "ch3/phases", "twin/ce_recovery")
]
# A bare cluster has no accounting database, so job states come from squeue (finished jobs stay
# there for slurm.conf's MinJobAge); the first status check after 1 s, not the default 40 s,
# because these jobs take seconds. No account is given: the plugin then submits without one.
BARE_CLUSTER = [
    "--slurm-status-command",
    "squeue",
    "--slurm-init-seconds-before-status-checks",
    "1",
]


@pytest.fixture(scope="module")
def slurm_cluster():
    """The local cluster, up; stopped afterwards if this fixture started it."""
    pytest.importorskip(
        "snakemake_executor_plugin_slurm",
        reason="SLURM not available: the plugin is not installed (pip install -e '.[slurm]')",
    )
    was_up = subprocess.run(["bash", SCRIPT, "status"], capture_output=True).returncode == 0
    start = subprocess.run(["bash", SCRIPT, "start"], capture_output=True, text=True, timeout=900)
    if start.returncode != 0:
        pytest.skip(f"SLURM not available: {(start.stderr.strip().splitlines() or ['?'])[-1]}")
    yield
    if not was_up:
        subprocess.run(["bash", SCRIPT, "stop"], capture_output=True, check=True, timeout=120)


def test_chapter_3_tables_via_slurm_equal_the_local_run(slurm_cluster, smoke_run, tmp_path):
    repo = copy_repo(tmp_path / "repo")
    run = run_snakemake(repo, "--workflow-profile", "profiles/slurm", *BARE_CLUSTER, *TABLES)
    assert run.returncode == 0, run.stderr[-3000:]
    done = re.search(r"(\d+) of \1 steps \(100%\) done", run.stderr)
    assert done and run.stderr.count("has been submitted with SLURM jobid") == int(done[1]), (
        run.stderr[-3000:]
    )
    made = sorted(str(p.relative_to(repo)) for p in (repo / "results").rglob("*.csv"))
    assert made == sorted(TABLES)
    for table in TABLES:
        assert (repo / table).read_bytes() == (smoke_run / table).read_bytes(), table
