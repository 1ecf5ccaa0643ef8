"""`snakemake validate` on the smoke config, by dry runs: its DAG builds (the members of wave 1's
first batches, their batches' tables, the verdicts); the default DAG has none of it; a batch
whose tables exist is done (its members do not join the DAG) and one from another draw is refused
in one line; a bad `validation:` key is refused in one line before anything runs."""

import re

import pytest
import yaml

from selfsense.envelope import campaign
from selfsense.envelope.unknowns import load_unknowns
from selfsense.envelope.validation import load_validation

from ..helpers import ROOT, SMOKE_CONFIG, copy_repo, error_line, run_snakemake

SMOKE = yaml.safe_load((ROOT / SMOKE_CONFIG).read_text())["validation"]
FOLDER = f"results/validation/{SMOKE['name']}"


def jobs(run):
    """{rule: count} of a dry run's job table."""
    return {
        rule: int(n)
        for rule, n in re.findall(r"^(\w+)\s+(\d+)$", run.stdout + run.stderr, re.M)
        if rule not in ("total", "job")
    }


def validation_config(tmp_path, **validation):
    path = tmp_path / "validation.yaml"
    path.write_text(yaml.safe_dump({"validation": validation}))
    return ["--configfile", str(ROOT / SMOKE_CONFIG), str(path)]


def test_the_validate_targets_dry_run_builds_the_first_batches_members():
    run = run_snakemake(ROOT, "-n", "validate")
    assert run.returncode == 0, run.stderr[-3000:]
    planned = jobs(run)
    batches = -(-SMOKE["members"] // SMOKE["batch"])
    assert planned["validate"] == planned["validation_verdicts"] == 1
    assert planned["validation_review"] == 1
    assert planned["validation_batch"] == batches
    assert planned["envelope_member"] == SMOKE["members"]
    assert planned["member"] == SMOKE["members"]  # each member one job: no nominal run
    assert planned["member_steps"] == batches
    assert "scorecard" not in planned
    assert "validation_wave" not in planned  # one wave asked


def test_with_in_process_false_the_members_are_their_rules_jobs(tmp_path):
    args = validation_config(tmp_path, in_process=False)
    run = run_snakemake(ROOT, "-n", "validate", *args, config=None)
    assert run.returncode == 0, run.stderr[-3000:]
    planned = jobs(run)
    assert planned["scorecard"] == SMOKE["members"]  # the members' only: no nominal run
    assert "member" not in planned and "member_steps" not in planned


def test_the_default_dag_has_no_validation_job():
    run = run_snakemake(ROOT, "-n", "--quiet", "rules")
    assert run.returncode == 0, run.stderr[-3000:]
    planned = jobs(run)
    assert planned.get("all") == 1
    validation = {"validate", "validation_verdicts", "validation_review", "validation_batch"}
    assert not (validation | {"validation_wave", "envelope_member"}) & set(planned)
    assert "_validation~" not in run.stdout + run.stderr


def expected_batch(number):
    """members × inputs of the smoke validation's batch ``number``, as the workflow draws it."""
    decl = load_validation(ROOT / "workflow" / "validation.yaml")
    prior, _ = campaign.varied(load_unknowns(ROOT / "workflow" / "unknowns.yaml"), "pi_p885")
    ids = [u.id for u in prior]
    runs = campaign.first_wave(decl.settings["waves"], len(ids)).head(SMOKE["members"])
    batch = campaign.batches(runs, SMOKE["name"], SMOKE["batch"])[number - 1]
    return campaign.run_frame(runs, batch.rows, SMOKE["name"], ids, "smoke")


def write_batch(repo, frame):
    folder = repo / FOLDER / "wave1" / "batch01"
    folder.mkdir(parents=True, exist_ok=True)
    frame.to_csv(folder / "inputs.csv", index=False)
    for name in ("plan.csv", "rows.csv", "targets.csv"):
        frame[["member"]].to_csv(folder / name, index=False)
    return folder


@pytest.fixture(scope="module")
def repo(tmp_path_factory):
    return copy_repo(tmp_path_factory.mktemp("validation") / "repo")


def test_a_done_batch_is_never_made_again_and_its_members_do_not_run(repo):
    folder = write_batch(repo, expected_batch(1))
    try:
        run = run_snakemake(repo, "-n", "validate")
        assert run.returncode == 0, run.stderr[-3000:]
        planned = jobs(run)
        assert planned["validation_batch"] == 1  # the second batch only
        assert planned["envelope_member"] == SMOKE["batch"]
        text = run.stdout + run.stderr
        assert "wave1/batch01/inputs.csv" in text  # read by the verdicts, as a source
        assert f"{SMOKE['name']}~001" not in text
    finally:
        for path in folder.iterdir():
            path.unlink()


def test_a_done_batch_from_another_draw_stops_the_parse_in_one_line(repo):
    frame = expected_batch(1)
    frame.loc[0, "seed"] = int(frame.loc[0, "seed"]) + 1
    folder = write_batch(repo, frame)
    try:
        run = run_snakemake(repo, "-n", "validate")
        assert run.returncode != 0
        line = error_line(run, "wave1/batch01/inputs.csv: its seeds are not the current draw's")
        assert "move its folder away" in line
    finally:
        for path in folder.iterdir():
            path.unlink()


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("members", 10_000, "key validation.members: 10000 is greater than the maximum of 1000"),
        ("batch", 0, "key validation.batch: 0 is less than the minimum of 1"),
        ("name", "../elsewhere", "key validation.name"),
        ("waves", 9, "key validation.waves: 9 is more than the 4 waves"),
        ("stray", 1, "validation"),
    ],
)
def test_a_bad_validation_key_is_refused_in_one_line(tmp_path, key, value, message):
    args = validation_config(tmp_path, **{key: value})
    run = run_snakemake(ROOT, "-n", "validate", *args, config=None)
    assert run.returncode != 0
    line = error_line(run, message)
    assert len(line) < 400
    if key == "stray":
        assert "stray" in line


def test_the_default_run_does_not_read_the_validations_draw(tmp_path):
    """A plan the declaration refuses (more waves than it declares): the default run's parse
    never draws it; the validation's refuses it."""
    args = validation_config(tmp_path, waves=9)
    listed = run_snakemake(ROOT, "--list-target-rules", *args, config=None)
    assert listed.returncode == 0, listed.stderr[-2000:]


def test_a_variant_validation_joins_the_committed_runs_and_judges_every_model(tmp_path):
    args = validation_config(tmp_path, variants=True, joins=["pi_p885_ch3_6"])
    run = run_snakemake(ROOT, "-n", "validate", *args, config=None)
    assert run.returncode == 0, run.stderr[-3000:]
    planned = jobs(run)
    assert planned["validation_variants"] == planned["validation_verdicts"] == 1
    text = run.stdout + run.stderr
    joined = "docs/snapshot/validation/pi_p885_ch3_6/wave1/batch10/rows.csv"
    assert joined in text  # the base validation's runs, read as tables, never run again
    assert "pi_p885_ch3_6~" not in text.replace("pi_p885_ch3_6/", "")
