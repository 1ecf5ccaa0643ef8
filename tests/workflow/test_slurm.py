"""The smoke envelope's members through SLURM (profiles/slurm) on a real single-node cluster:
their tables must be byte-identical to a local run's.

The cluster is the one scripts/slurm_local.sh brings up (installing Debian's munge, slurmctld and
slurmd where they are missing), or finds running. Where it cannot (not root, no apt, no network,
daemons that will not start), the test skips and says why; `pytest -m "not slurm"` leaves it out.

Two members of Chapter 3 (stages ripple and ch3), 12 jobs: each member's manifest, capture,
ripple, table and scorecard, then the plan and the verdicts; the capture, ripple and table of each
are SLURM jobs (6), the rest local rules. Every SLURM job starts Snakemake twice (the batch
script, then the job step), a few seconds of core time each, so the whole smoke DAG (≈ 140 jobs)
would take ≈ 15 minutes, where these already go every way a job can: a manifest written from the
plan, a capture simulated and checked, read by the next job through the shared filesystem, tables
compared byte for byte with the same member run locally, and the verdicts that read every
member.
"""

import json
import re
import subprocess

import pandas as pd
import pytest
import yaml

from selfsense.envelope.unknowns import unknowns_hash
from selfsense.io.manifest import load_yaml

from ..helpers import ROOT, SMOKE_CONFIG, copy_smoke_tree, run_snakemake, snakemake_command

pytestmark = [pytest.mark.slurm, pytest.mark.slow]

SCRIPT = str(ROOT / "scripts" / "slurm_local.sh")
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


#: a two-member smoke envelope of Chapter 3 (stages ripple and ch3), its members drawn by a Latin
#: hypercube and run as their rules' jobs (in_process false: the jobs SLURM gets are a dataset's):
#: per member its manifest, the captures simulated and checked, their ripple, the tables its
#: scorecard reads and the scorecard; the plan and the verdicts
ENVELOPE = {
    "members": 2,
    "method": "latin",
    "seed": 5,
    "stages": ["ripple", "ch3"],
    "in_process": False,
}


def envelope_tree(smoke_run, folder):
    """An up-to-date copy of the smoke tree (its nominal scorecard too) with the envelope's
    config."""
    repo = copy_smoke_tree(smoke_run, folder / "repo")
    config = yaml.safe_load((ROOT / SMOKE_CONFIG).read_text()) | {"envelope": ENVELOPE}
    (repo / "envelope.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    return repo


def test_a_two_member_envelope_via_slurm_equals_the_local_run(slurm_cluster, smoke_run, tmp_path):
    """The envelope's members are jobs like any dataset's: through SLURM, on the shared
    filesystem, each member's manifest holds its row of the plan, its tables are those of the
    same member run locally, and its Chapter 3 table moves with its draws; the verdicts' table
    has every emergent row (with 2 members, none has the 3 an envelope needs)."""
    local = envelope_tree(smoke_run, tmp_path / "local")
    # beside the cluster's run, whose jobs mostly wait in the queue
    log = tmp_path / "local.log"
    with log.open("w") as out:
        alone = subprocess.Popen(
            snakemake_command("results/pi_p885~01/scorecard.csv", config="envelope.yaml"),
            cwd=local,
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    repo = envelope_tree(smoke_run, tmp_path / "slurm")
    run = run_snakemake(
        repo,
        "--workflow-profile",
        "profiles/slurm",
        *BARE_CLUSTER,
        "envelope",
        config="envelope.yaml",
    )
    assert alone.wait(timeout=1800) == 0, log.read_text()[-3000:]
    assert run.returncode == 0, run.stderr[-3000:]
    done = re.search(r"(\d+) of \1 steps \(100%\) done", run.stderr)
    # the members' captures and analyses are SLURM jobs; the envelope's bookkeeping (the plan,
    # the manifests, the scorecards, the verdicts) runs where Snakemake runs (localrule)
    on_host = re.findall(r"^localrule (\w+):", run.stderr, re.M)
    submitted = re.findall(r"^rule (\w+):", run.stderr, re.M)
    assert set(on_host) == {"envelope_plan", "envelope_member", "scorecard", "envelope"}, on_host
    assert set(submitted) == {"simulate", "extract_ripple", "ch3_hysteresis"}, submitted
    assert done and len(on_host) + len(submitted) == int(done[1]), run.stderr[-3000:]
    assert run.stderr.count("has been submitted with SLURM jobid") == len(submitted)
    # the member's manifest, capture, ripple and tables (not the sidecars: they name the host)
    made = [
        p.relative_to(local)
        for folder in ("raw", "results")
        for p in sorted((local / folder / "pi_p885~01").rglob("*"))
        if p.is_file() and p.suffix != ".json"
    ]
    assert {p.suffix for p in made} >= {".yaml", ".nc", ".csv"}, made
    for path in made:
        assert (repo / path).read_bytes() == (local / path).read_bytes(), path
    plan = pd.read_csv(repo / "results" / "envelope" / "pi_p885" / "plan.csv", index_col="member")
    assert list(plan.index) == ["pi_p885~01", "pi_p885~02"]
    phases = []
    for member, row in plan.iterrows():
        manifest = load_yaml(repo / "raw" / member / "dataset.yaml")
        # plan.csv prints 10 significant digits (write_table), the manifest 12
        assert manifest["twin"]["ripple"]["phase_deg"] == pytest.approx(
            row["ripple_phase_deg"], rel=1e-9
        )
        assert manifest["stages"] == ENVELOPE["stages"]
        phases.append(pd.read_csv(repo / "results" / member / "ch3" / "phases.csv"))
    assert not phases[0].equals(phases[1])
    card = pd.read_csv(repo / "results" / "envelope" / "pi_p885" / "scorecard.csv")
    nominal = pd.read_csv(repo / "results" / "pi_p885" / "scorecard.csv")
    assert len(card) == (nominal["kind"] == "emergent").sum()
    assert set(card["envelope verdict"]) == {"no envelope"}
    assert set(card.loc[card["chapter"].astype(str) == "3", "members"]) == {2}
    sidecar = json.loads((repo / "results/envelope/pi_p885/scorecard.csv.json").read_text())
    assert sidecar["unknowns_sha256"] == unknowns_hash(ROOT / "workflow" / "unknowns.yaml")
