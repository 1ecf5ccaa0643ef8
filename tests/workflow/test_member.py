"""A member run as one job (rule member, selfsense.envelope.member) gives, byte for byte, the files
its rules' jobs give: one smoke validation member of Chapters 3–6 (the twin in open and closed
loop, the ripple, identification, Γ, the observer, the loops), its scorecard and the tables the
validation reads of it, made both ways in one scratch copy of the repository."""

import pytest
import yaml

from ..helpers import ROOT, SMOKE_CONFIG, copy_repo, run_snakemake

SMOKE = yaml.safe_load((ROOT / SMOKE_CONFIG).read_text())["validation"]
MEMBER = f"{SMOKE['name']}~001"
FOLDER = f"results/validation/{SMOKE['name']}/members/{MEMBER}"


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    """The member's one job's folder, and the same files from its rules, in a scratch copy."""
    repo = copy_repo(tmp_path_factory.mktemp("member") / "repo")
    overlay = repo / "one_member.yaml"
    overlay.write_text(yaml.safe_dump({"validation": {"members": 1, "batch": 1}}))
    args = ["--configfile", SMOKE_CONFIG, str(overlay)]
    one_job = run_snakemake(repo, FOLDER, *args, config=None)
    assert one_job.returncode == 0, one_job.stderr[-3000:]
    files = [p for p in (repo / FOLDER).rglob("*") if p.is_file() and not p.name.startswith(".")]
    kept = sorted(p.relative_to(repo / FOLDER) for p in files)  # not Snakemake's timestamp
    assert not (repo / "raw" / MEMBER / "ch6_p1_closed.nc").exists()  # nothing materialised
    targets = [f"results/{MEMBER}/{name}" for name in kept]
    rules = run_snakemake(repo, *targets, *args, config=None)
    assert rules.returncode == 0, rules.stderr[-3000:]
    return repo, kept


def test_the_member_keeps_its_scorecard_and_the_tables_the_validation_reads(both):
    _, kept = both
    names = {str(k) for k in kept}
    assert "scorecard.csv" in names
    assert {"ch3/hysteresis.csv", "ch5/table_5_4.csv", "ch6/p3.csv"} <= names, sorted(names)


def test_the_member_in_one_job_gives_its_rules_numbers_byte_for_byte(both):
    repo, kept = both
    differ = [
        str(name)
        for name in kept
        if (repo / FOLDER / name).read_bytes() != (repo / "results" / MEMBER / name).read_bytes()
    ]
    assert not differ, f"differ between the member's one job and its rules: {differ}"
    card = (repo / FOLDER / "scorecard.csv").read_text().splitlines()
    assert len(card) > 100 and sum(",emergent," in line for line in card) > 50
