"""The report, the scorecard, provenance and re-runs, on the smoke DAG (run once per session)."""

import base64
import html
import io
import json
import os
import re
import shutil
from collections import namedtuple
from pathlib import Path
from types import SimpleNamespace

import docutils.core
import jinja2
import pandas as pd
import pytest
import yaml

from selfsense.io.capture import open_capture
from selfsense.io.manifest import load_dataset, load_yaml
from selfsense.io.provenance import sha256
from selfsense.scorecard.registry import (
    INFORMATION,
    LEFT_OUT,
    MISSING,
    NOT_YET,
    OUT,
    WITHIN,
    applicable,
    parse_registry,
)

from ..helpers import SMOKE_CONFIG, measured_copy_remakes, run_snakemake

pytestmark = pytest.mark.slow


def outputs(repo):
    """Every table and figure the DAG made, relative to the repository."""
    found = [*(repo / "results").rglob("*.csv"), *(repo / "figures").rglob("*.png")]
    return sorted(p.relative_to(repo).as_posix() for p in found)


def datasets(repo):
    return load_yaml(repo / SMOKE_CONFIG)["datasets"]


@pytest.fixture(scope="module")
def report(smoke_report):
    """`snakemake --report` on the smoke run; the report's embedded JSON (results, categories,
    description) and the build's stderr."""
    path, stderr = smoke_report
    page = path.read_text(encoding="utf-8")
    blocks = dict(re.findall(r'<script id="([\w-]+)">\s*var \w+ = (.*?);\s*</script>', page, re.S))
    found = {name: json.loads(blocks[name]) for name in ("workflow-desc", "results", "categories")}
    return found | {"stderr": stderr}


def embedded(report, path):
    """The text of a result embedded in the report (a base64 data URI)."""
    head, _, data = report["results"][path]["data_uri"].partition(",")
    assert head.endswith(";base64"), head
    return base64.b64decode(data).decode("utf-8")


# --- the report -----------------------------------------------------------------------------------


def test_report_is_one_self_contained_page(smoke_run, report):
    page = (smoke_run / "report.html").read_text(encoding="utf-8")
    # every result is embedded as a data URI: nothing points back at the results folder
    assert all(r["data_uri"].startswith("data:") for r in report["results"].values())
    assert not re.search(r'(src|href)="(results|figures)/', page)


def test_every_table_and_figure_is_in_the_report_with_a_caption(smoke_run, report):
    made = outputs(smoke_run)
    absent = [p for p in made if p not in report["results"]]
    assert not absent
    uncaptioned = [
        p for p in made if len(re.sub("<[^>]+>", "", report["results"][p]["caption"]).strip()) < 40
    ]
    assert not uncaptioned


def test_results_are_grouped_by_dataset_then_chapter(smoke_run, report):
    for dataset in datasets(smoke_run):
        for path in outputs(smoke_run):
            if path.split("/")[1] == dataset:
                placed = [
                    (c, s)
                    for c, subs in report["categories"].items()
                    for s, ps in subs.items()
                    if path in ps
                ]
                assert len(placed) == 1 and placed[0][0] == dataset, (path, placed)
    subcategories = set(report["categories"]["pi_p885"])
    assert {"Captures", "Chapter 3", "Twin validation", "Scorecard"} <= subcategories


def test_report_opens_with_the_scorecard_summary(smoke_run, report):
    description = html.unescape(report["workflow-desc"])
    assert "summary is missing" not in description
    assert description.index("Scorecard") < description.index("How the results are organised")
    out_of_band = html.unescape(embedded(report, "results/scorecard_out_of_band.html"))
    not_yet = html.unescape(embedded(report, "results/scorecard_not_yet.html"))
    for dataset in datasets(smoke_run):
        card = pd.read_csv(smoke_run / f"results/{dataset}/scorecard.csv")
        emergent = card[card["kind"] == "emergent"]
        reproduced = emergent["verdict"].isin([WITHIN, OUT]).sum()
        if reproduced:  # the opening leads with the emergent numbers, the reproduction proper
            tally = f"emergent {(emergent['verdict'] == WITHIN).sum()} within band of {reproduced}"
            assert tally in description and tally in out_of_band and tally in not_yet
        for quantity in card.loc[card["verdict"] == OUT, "quantity"]:
            assert quantity in out_of_band  # every number out of band is named, with its note
        for source in card.loc[card["verdict"] == NOT_YET, "source"]:
            assert source in not_yet
    # the long lists are report items of their own, linked from the opening, not part of it
    assert (
        "Out of band, by source" not in description and "by chapter and source (" not in description
    )
    for page in ("results/scorecard_out_of_band.html", "results/scorecard_not_yet.html"):
        assert report["results"][page]["caption"]
        assert f"app.showResultInfo('{page}')" in description, page


# --- docutils: no caption, landing text or page shows a "problematic" marker ----------------------

DOCUTILS_MESSAGE = re.compile(r"\((?:WARNING/2|ERROR/3|SEVERE/4)\)")


def docutils_messages(text):
    """Every docutils warning or error of rendering reStructuredText, as the report renders it."""
    stream = io.StringIO()
    docutils.core.publish_parts(
        text,
        writer="html",
        settings_overrides={
            "report_level": 2,
            "halt_level": 5,
            "warning_stream": stream,
            "_disable_config": True,
        },
    )
    return stream.getvalue()


def test_every_caption_and_the_landing_text_render_without_a_docutils_message(smoke_run, report):
    """Each workflow/report/*.rst through Jinja and docutils as `snakemake --report` does (with the
    link targets it appends: categories and result file names)."""
    Category = namedtuple("Category", "name")
    categories = {Category(c): subs for c, subs in report["categories"].items()}
    files = [SimpleNamespace(name=Path(p).name, path=smoke_run / p) for p in report["results"]]
    targets = [
        "Workflow",
        "Statistics",
        *report["categories"],
        *dict.fromkeys(f.name for f in files),
    ]
    links = "\n\n" + "\n".join(f".. _{t}: javascript:void(0)" for t in targets) + "\n"
    config = load_yaml(smoke_run / SMOKE_CONFIG) | {"campaign": "smoke"}
    snake = SimpleNamespace(config=config, wildcards=SimpleNamespace(dataset="pi_p885"))
    env = jinja2.Environment(trim_blocks=True, lstrip_blocks=True, undefined=jinja2.StrictUndefined)
    failures = {}
    for caption in sorted((smoke_run / "workflow/report").glob("*.rst")):
        text = env.from_string(caption.read_text() + links).render(
            snakemake=snake, categories=categories, files=files
        )
        if messages := docutils_messages(text):
            failures[caption.name] = messages
    assert not failures, failures
    assert not docutils_messages((smoke_run / "results/scorecard_summary.rst").read_text())


# docutils' HTML of a message: <a class="problematic" ...>, <aside class="system-message"> (or a
# <div>), <p class="system-message-title">System Message: ERROR/3 ...; the embedded pages' own
# stylesheet names the classes too, so only elements count
MARKER = re.compile(r'class=\\?"(?:problematic|system-message)|System Message:')


def test_built_report_shows_no_docutils_message(smoke_run, report):
    page = (smoke_run / "report.html").read_text(encoding="utf-8")
    assert not MARKER.search(page)  # the landing text and every caption (JSON-escaped)
    rendered = [
        html.unescape(report["workflow-desc"]),
        *(r["caption"] for r in report["results"].values()),
    ]
    rendered += [
        embedded(report, p)
        for p in ("results/scorecard_out_of_band.html", "results/scorecard_not_yet.html")
    ]
    assert not [text for text in rendered if MARKER.search(text)]


def test_report_build_prints_no_docutils_message(report):
    assert not DOCUTILS_MESSAGE.search(report["stderr"]), report["stderr"][-3000:]


# --- the scorecard --------------------------------------------------------------------------------


def test_scorecard_reproduces_every_entry_whose_table_exists(smoke_run):
    """A reproduced value that goes missing (renamed column, table no longer made) fails here, and
    so does a "not reproduced yet" row whose table exists (a locator to add or fix)."""
    entries = parse_registry(load_yaml(smoke_run / "workflow/scorecard.yaml"))
    for dataset in datasets(smoke_run):
        results = smoke_run / "results" / dataset
        mine = applicable(entries, load_dataset(smoke_run / "raw", dataset))
        card = pd.read_csv(results / "scorecard.csv")
        assert len(card) == len(mine)  # nothing dropped
        expected = {
            (e.source, e.quantity) for e in mine if e.locate and (results / e.locate.table).exists()
        }
        # a stage may leave a number out (and say why): shown as not reproduced yet, with its reason
        scored = card["verdict"].isin([WITHIN, OUT, INFORMATION]) | card["note"].str.startswith(
            LEFT_OUT, na=False
        )
        reproduced = set(zip(card.loc[scored, "source"], card.loc[scored, "quantity"]))
        assert reproduced == expected, card.loc[
            card["verdict"] == MISSING, ["quantity", "note"]
        ].to_string()
        assert set(card["verdict"]) <= {WITHIN, OUT, NOT_YET, INFORMATION}
        pending = card[
            (card["verdict"] == NOT_YET) & ~card["note"].str.startswith(LEFT_OUT, na=False)
        ]
        made = [
            (src, q)
            for src, q, table in zip(
                pending["source"], pending["quantity"], pending["read from"].fillna("")
            )
            if table and (results / table.split(" ")[0]).exists()
        ]
        assert not made, f"{dataset}: not reproduced yet although their table exists: {made}"


def test_every_results_folder_is_read_by_the_scorecard(smoke_run):
    """Every folder of tables a dataset's stages make (chapters, powerloss, twin …) has numbers on
    its scorecard: a stage that lands without its registry entries being located fails here."""
    for dataset in datasets(smoke_run):
        results = smoke_run / "results" / dataset
        card = pd.read_csv(results / "scorecard.csv")
        scored = card[card["verdict"].isin([WITHIN, OUT, INFORMATION])]
        read = {src.split("/")[0] for src in scored["read from"].dropna()}
        # qc/ and characterise/ describe the captures (validation; stroke, gain, loop width
        # whatever the protocol), not numbers of the sources; a dataset's own reference values
        # read the latter
        folders = {d.name for d in results.iterdir() if d.is_dir() and any(d.glob("*.csv"))} - {
            "qc",
            "characterise",
        }
        unread = sorted(folders - read)
        assert not unread, (
            f"results/{dataset}/{unread}: no scorecard entry reads them; give their entries a "
            "locate: in workflow/scorecard.yaml"
        )
    stack = pd.read_csv(smoke_run / "results/pi_p885/scorecard.csv")
    assert {"published", "twin recovery"} <= set(
        stack.loc[stack["verdict"].isin([WITHIN, OUT]), "section"]
    )


# --- provenance -----------------------------------------------------------------------------------


def test_every_table_and_figure_has_a_provenance_sidecar_matching_its_inputs(smoke_run):
    for path in outputs(smoke_run):
        side = json.loads((smoke_run / f"{path}.json").read_text())
        assert {"inputs", "config", "config_sha256", "code", "seed"} <= set(side), path
        assert (
            side["code"]["git_describe"]
            and side["code"]["packages"]["selfsense"] != "not installed"
        )
        for source, digest in side["inputs"].items():
            assert sha256(smoke_run / source) == digest, (path, source)


# Outputs of rules that run the twin themselves (not from captures) must name its seed.
TWIN_RUNS = ["results/pi_p885/twin/ce_np_study.csv", "figures/pi_p885/fig_3_np_study.png"]


@pytest.mark.parametrize("path", TWIN_RUNS)
def test_outputs_of_twin_runs_record_the_seed(smoke_run, path):
    side = json.loads((smoke_run / f"{path}.json").read_text())
    assert side["seed"] == load_dataset(smoke_run / "raw", path.split("/")[1])["seed"]


def test_the_seed_of_every_capture_an_output_hashes_is_the_datasets(smoke_run):
    """An output made from captures reaches the twin's seed through the captures' sha256."""
    seeds = {d: load_dataset(smoke_run / "raw", d).get("seed") for d in datasets(smoke_run)}
    captures = set()
    for path in outputs(smoke_run):
        side = json.loads((smoke_run / f"{path}.json").read_text())
        if side["seed"] is not None:
            assert side["seed"] == seeds[path.split("/")[1]], path
        captures |= {s for s in side["inputs"] if s.startswith("raw/") and s.endswith(".nc")}
    assert captures
    for capture in sorted(captures):
        with open_capture(smoke_run / capture) as cap:
            assert int(cap.attrs["seed"]) == seeds[capture.split("/")[1]], capture


# --- re-runs --------------------------------------------------------------------------------------


def jobs(dry_run_output):
    """{rule: [reasons]} of a dry run's job list."""
    found = {}
    for rule, body in re.findall(
        r"^(?:local)?rule (\w+):\n((?:[ \t]+.*\n)*)", dry_run_output, re.M
    ):
        found.setdefault(rule, []).append(re.search(r"reason: (.*)", body).group(1))
    return found


def test_changing_one_parameter_reruns_only_what_depends_on_it(smoke_tree, tmp_path):
    # a second config file, not --config: --config cannot type a nested value (ripple.n_periods)
    changed = yaml.safe_load((smoke_tree / SMOKE_CONFIG).read_text())
    changed["ripple"]["n_periods"] = 8
    # key order kept: Snakemake compares a dict param by its text, so a reordered config reruns
    (tmp_path / "np8.yaml").write_text(yaml.safe_dump(changed, sort_keys=False))
    dry = run_snakemake(smoke_tree, "-n", config=str(tmp_path / "np8.yaml"))
    assert dry.returncode == 0, dry.stderr[-3000:]
    planned = jobs(dry.stdout)
    assert any(r.startswith("Params have changed") for r in planned["extract_ripple"])
    # everything else runs only because an upstream job does: no mtime, code or input-hash reruns
    for rule, reasons in planned.items():
        assert all(
            r.startswith(("Params have changed", "Input files updated by another job"))
            for r in reasons
        ), rule
    # open-loop captures and what depends only on them or on the manifest (closed-loop captures do
    # depend on the identified Γ, so they, their checks and the capture table rightly rerun)
    untouched = {"simulate", "ch3_tables", "ch3_model_figure", "ce_np_study", "static_stiffness"}
    assert not untouched & set(planned)
    assert {"ce_recovery", "ch3_hysteresis", "scorecard", "scorecard_summary"} <= set(planned)


def made_by(repo):
    """{output file: rule} of every file the DAG makes (snakemake --summary)."""
    run = run_snakemake(repo, "--summary")
    assert run.returncode == 0, run.stderr[-3000:]
    rows = [line.split("\t") for line in run.stdout.splitlines()[1:] if line.count("\t") >= 2]
    return {row[0]: row[2] for row in rows}


def test_rebuilding_from_the_same_captures_gives_byte_identical_tables(smoke_tree, tmp_path):
    """Every table's job runs again on the same captures; its CSV must come out byte for byte.

    By default the tables the measured copy of the smoke bench does not already remake in its own
    DAG and compare byte for byte (``measured_copy_remakes``: the twin's, the scorecards and stage
    plans, the bender's) are deleted, and only the jobs that write them run again, on the same
    intermediate products (ripple series, observer runs): re-running the whole chain costs
    ≈ 3 min on the smoke campaign. SELFSENSE_FULL_REBUILD=1 deletes all of results/ instead.
    Either way the captures are kept: the rules that write raw/ are not allowed to run.
    """
    copy = tmp_path / "repo"
    shutil.copytree(smoke_tree, copy, symlinks=True)
    made = made_by(copy)
    tables = sorted(p for p in made if p.endswith(".csv"))
    assert tables == [p for p in outputs(copy) if p.endswith(".csv")]
    before = {p: (copy / p).read_bytes() for p in tables}
    captures = {p: p.stat().st_mtime_ns for p in copy.glob("raw/*/*.nc")}
    if os.environ.get("SELFSENSE_FULL_REBUILD") == "1":
        shutil.rmtree(copy / "results")
        allowed = {rule for path, rule in made.items() if not path.startswith("raw/")}
    else:
        tables = [p for p in tables if not measured_copy_remakes(p)]
        for p in tables:
            (copy / p).unlink()
        allowed = {made[p] for p in tables}
    # the flag after the rule list ends it (and --configfile's), so the tables are the targets
    run = run_snakemake(copy, "--allowed-rules", *sorted(allowed), "--rerun-incomplete", *tables)
    assert run.returncode == 0, run.stderr[-3000:]
    assert [p for p in tables if (copy / p).read_bytes() != before[p]] == []
    assert {p: p.stat().st_mtime_ns for p in copy.glob("raw/*/*.nc")} == captures
