"""A lab's datasets grow by batches and run one at a time (docs/bring-your-own-data.md): a new
batch of recordings imported into a measured dataset runs only its own captures' check and
characterisation jobs (and the dataset's tables), never an earlier capture's; and a run of one
dataset keeps every other dataset's scorecard in the project-wide summary, as an earlier run
left it.

One scratch copy, two measured datasets imported from a lab's CSV (no twin runs): both run, a
third capture is imported into one of them, and that one runs alone.
"""

import re
import time
from types import SimpleNamespace

import pandas as pd
import pytest
import yaml

from selfsense.io.audit import report as audit

from ..helpers import copy_repo, imported, run_snakemake, write_config, write_csv

pytestmark = pytest.mark.slow

GROWS, OTHER = "lab_batch", "lab_other"
FIRST, NEW = ["sine_a", "sine_b"], "sine_c"
#: the rules of a dataset's own tables, which a new capture re-makes
DATASET_LEVEL = {"stage_plan", "capture_summary", "characterise", "scorecard", "scorecard_summary"}
#: a data sheet's stroke: a scorecard row for a dataset without a source's published numbers
REFERENCE = "reference:\n  stroke_um: {value: 31, tolerance_percent: 10, source: data sheet}\n"


def import_csv(repo, source, dataset, experiment):
    """The lab's CSV imported by its columns' names (not their positions)."""
    channels = ("U=U [V]:V", "x_laser=x [um]:um")
    extra = ["--time", "t [s]:s"]
    return imported(repo, source, *channels, experiment=experiment, dataset=dataset, extra=extra)


def planned(run):
    """(rule, wildcards) of every job of a dry run's output."""
    out = run.stdout + run.stderr
    jobs = re.findall(r"^(?:local)?rule (\w+):\n((?:    .*\n)*)", out, re.M)
    wildcards = (re.findall(r"^    wildcards: (.*)$", body, re.M) for _, body in jobs)
    return {(rule, (w or [""])[0]) for (rule, _), w in zip(jobs, wildcards, strict=True)}


def stamps(repo, dataset):
    """{file: mtime_ns} of the per-capture outputs of a dataset: QC reports, loop pages."""
    files = [
        *(repo / "results" / dataset / "qc").glob("sine_*.json"),
        *(repo / "results" / dataset / "characterise").glob("page_*.json"),
        *(repo / "figures" / dataset / "characterise").glob("loops_*.png"),
    ]
    return {str(p.relative_to(repo)): p.stat().st_mtime_ns for p in files}


def every_file(repo, dataset):
    return {
        str(p.relative_to(repo)): p.stat().st_mtime_ns
        for top in ("results", "figures")
        for p in sorted((repo / top / dataset).rglob("*"))
        if p.is_file()
    }


@pytest.fixture(scope="module")
def batches(tmp_path_factory):
    repo = copy_repo(tmp_path_factory.mktemp("batches") / "repo")
    source = write_csv(repo / "sine.csv")
    for dataset, experiments in ((GROWS, FIRST), (OTHER, ["sine_1hz"])):
        for experiment in experiments:
            folder = import_csv(repo, source, dataset, experiment)
        (folder / "dataset.yaml").write_text((folder / "dataset.yaml").read_text() + REFERENCE)
    both = run_snakemake(repo, config=write_config(repo, "both", [OTHER, GROWS]))
    assert both.returncode == 0, both.stderr[-4000:]
    before, other = stamps(repo, GROWS), every_file(repo, OTHER)
    import_csv(repo, source, GROWS, NEW)  # a new batch: appended to the manifest's experiments
    alone = write_config(repo, "alone", [GROWS])
    dry = run_snakemake(repo, "--dry-run", config=alone)
    assert dry.returncode == 0, dry.stderr[-4000:]
    run = run_snakemake(repo, config=alone)
    assert run.returncode == 0, run.stderr[-4000:]
    return SimpleNamespace(repo=repo, before=before, other=other, dry=dry, alone=alone)


def test_a_new_batch_plans_only_its_own_captures_jobs_and_the_datasets_tables(batches):
    jobs = planned(batches.dry)
    per_capture = {(r, w) for r, w in jobs if r in ("check_capture", "characterise_page")}
    assert per_capture == {
        ("check_capture", f"dataset={GROWS}, experiment={NEW}"),
        ("characterise_page", f"dataset={GROWS}, page={NEW}"),
    }
    assert {r for r, _ in jobs} - {"check_capture", "characterise_page", "all"} == DATASET_LEVEL
    assert all(GROWS in w for r, w in jobs if r not in ("scorecard_summary", "all"))


def test_a_new_batch_leaves_every_earlier_captures_outputs_as_they_were(batches):
    repo, before = batches.repo, batches.before
    assert len(before) == 3 * len(FIRST)  # a QC report, a page and its figure per capture
    after = stamps(repo, GROWS)
    assert {f: after[f] for f in before} == before
    assert sorted(set(after) - set(before)) == [
        f"figures/{GROWS}/characterise/loops_{NEW}.png",
        f"results/{GROWS}/characterise/page_{NEW}.json",
        f"results/{GROWS}/qc/{NEW}.json",
    ]
    table = pd.read_csv(repo / "results" / GROWS / "characterise" / "summary.csv")
    assert list(table["experiment"]) == [*FIRST, NEW]
    # every output of the dataset still describes its inputs: the earlier QC reports record the
    # parts of the manifest they checked against, not the manifest the batch changed
    lines, stale = audit([repo / "results" / GROWS], root=repo)
    assert not stale, lines
    run = run_snakemake(repo, "--dry-run", config=batches.alone)
    assert run.returncode == 0 and "Nothing to be done" in run.stdout + run.stderr


def test_a_run_of_one_dataset_keeps_the_others_in_the_summary_from_their_earlier_run(batches):
    repo = batches.repo
    assert every_file(repo, OTHER) == batches.other  # not one of its files made again
    counts = pd.read_csv(repo / "results" / "scorecard_counts.csv")
    assert list(dict.fromkeys(counts["dataset"])) == [GROWS, OTHER]
    summary = (repo / "results" / "scorecard_summary.rst").read_text(encoding="utf-8")
    when = time.strftime(
        "%Y-%m-%d %H:%M UTC",
        time.gmtime((repo / "results" / OTHER / "scorecard.csv").stat().st_mtime),
    )
    assert summary.startswith(
        f"Datasets: ``{GROWS}`` (this run); ``{OTHER}`` (scorecard of an earlier run, {when})."
    )
    assert "**lab\\_other**" in summary  # its tally, as before
    for page in ("scorecard_out_of_band.html", "scorecard_not_yet.html"):
        assert f"scorecard of an earlier run, {when}" in (repo / "results" / page).read_text()


def test_a_change_to_what_a_capture_is_checked_against_checks_every_capture_again(batches):
    repo = batches.repo
    path = repo / "raw" / GROWS / "dataset.yaml"

    def checks(sensor):
        doc = yaml.safe_load(path.read_text())
        path.write_text(yaml.safe_dump(doc | {"sensors": {"x_laser": sensor}}, sort_keys=False))
        run = run_snakemake(repo, "--dry-run", config=batches.alone)
        assert run.returncode == 0, run.stderr[-4000:]
        return {w for r, w in planned(run) if r == "check_capture"}

    # the report's description of a sensor is not what a capture is checked against ...
    assert checks({"type": "laser vibrometer", "resolution": 3.0e-7}) == set()
    # ... its units are
    assert checks({"type": "laser vibrometer", "units": "m"}) == {
        f"dataset={GROWS}, experiment={e}" for e in [*FIRST, NEW]
    }
