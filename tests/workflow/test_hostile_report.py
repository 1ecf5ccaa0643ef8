"""A manifest is data, never markup, through the whole report: a measured dataset (one smoke
capture, U and x_laser) whose manifest carries the issue's payloads (a live script, /etc/passwd
pulled in, a javascript: link, a spreadsheet formula) in its reference values' sources, its
description, its actuator and its sensors is run to its scorecard, then `snakemake --report`;
neither the report, the pages in results/ nor the CSV tables hold a script, a javascript: link, a
line of /etc/passwd or a formula a spreadsheet would run. The renderers on their own:
tests/unit/test_hostile_text.py."""

import base64
import csv
import html
import json
import re
from types import SimpleNamespace

import pytest
import yaml

from selfsense.io.manifest import load_yaml

from ..helpers import add_measured, copy_repo, run_snakemake, write_config

pytestmark = pytest.mark.slow

SCRIPT = "x\n\n.. raw:: html\n\n   <script>alert(1)</script>"
PASSWD = ".. include:: /etc/passwd\n   :literal:"
LINK = "javascript:alert(1)"
FORMULA = '=HYPERLINK("http://evil.example","click")'
#: the first line of /etc/passwd on any Linux
ROOT_LINE = "root:x:0:0"


@pytest.fixture(scope="module")
def hostile(smoke_run, tmp_path_factory):
    """raw/hostile/ in a scratch copy (one smoke capture) with the payloads in its manifest, run
    once to its scorecard and report: the repository, and both runs."""
    repo = copy_repo(tmp_path_factory.mktemp("hostile") / "repo")
    folder = add_measured(repo, smoke_run, "hostile", ["ch3_sine_10hz"], channels=("U", "x_laser"))
    doc = load_yaml(folder / "dataset.yaml")
    doc["description"] = "\n\n".join((SCRIPT, PASSWD, LINK, FORMULA))
    doc["actuator"] = dict(doc["actuator"], model=FORMULA)
    doc["sensors"] = {"U": {"type": PASSWD}, "x_laser": {"type": SCRIPT}}
    doc["reference"] = {  # all out of band or missing from the table: every list names them
        "stroke_um": {"value": 1000, "tolerance_percent": 1, "source": SCRIPT},
        "gain_um_per_V": {
            "value": 1000,
            "tolerance_percent": 1,
            "source": PASSWD,
            "experiment": LINK,
        },
        "loop_width_percent": {"value": 1000, "tolerance_percent": 1, "source": FORMULA},
        "capacitance_uF": {"value": 1000, "tolerance_percent": 1, "source": LINK},
    }
    (folder / "dataset.yaml").write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
    config = write_config(repo, "hostile", ["hostile"])
    run = run_snakemake(repo, config=config)
    report = (
        run_snakemake(repo, "--report", "report.html", config=config)
        if not run.returncode
        else None
    )
    return SimpleNamespace(repo=repo, run=run, report=report)


#: the only javascript: links a report may hold: Snakemake's own, to a result or a category
SNAKEMAKE_LINK = re.compile(r"javascript:app\.show(?:ResultInfo|Category)\('[\w./-]+'\)")


def assert_inert(text, where):
    """No script, no javascript: link but Snakemake's own, no line of /etc/passwd."""
    assert "<script" not in text.lower(), where
    urls = re.findall(r"""(?:href|src)\s*=\s*("[^"]*"|'[^']*'|[^\s>]+)""", text, re.I)
    urls = [re.sub(r"[\x00-\x20]", "", html.unescape(u.strip("\"'"))) for u in urls]
    scripts = [u for u in urls if u.lower().startswith("javascript:")]
    assert all(SNAKEMAKE_LINK.fullmatch(u) for u in scripts), (where, scripts)
    assert ROOT_LINE not in text, where


def embedded(page):
    """{where: (shown as HTML, text)}: the report's landing text and captions (HTML it shows
    inline), and every result it embeds as a base64 data URI (an HTML page in a frame; a table or
    other text in a <pre>, as text)."""
    blocks = dict(re.findall(r'<script id="([\w-]+)">\s*var \w+ = (.*?);\s*</script>', page, re.S))
    results = json.loads(blocks["results"])
    found = {"landing text": (True, html.unescape(json.loads(blocks["workflow-desc"])))}
    for path, result in results.items():
        head, _, data = result["data_uri"].partition(",")
        assert head.endswith(";base64"), head
        if not result["mime_type"].startswith("image/"):
            text = base64.b64decode(data).decode("utf-8")
            found[path] = (result["mime_type"] == "text/html", text)
        found[f"caption of {path}"] = (True, result["caption"])
    return found


def test_a_hostile_manifest_reaches_the_report_as_text_only(hostile):
    assert hostile.run.returncode == 0, hostile.run.stderr[-4000:]
    assert hostile.report.returncode == 0, hostile.report.stderr[-4000:]
    page = (hostile.repo / "report.html").read_text(encoding="utf-8")
    # the page itself: Snakemake's own scripts and javascript: links are there, the payloads not
    assert "<script>alert" not in page and "javascript:alert" not in page
    assert ROOT_LINE not in page
    results = embedded(page)
    for where, (shown_as_html, text) in results.items():
        if shown_as_html:
            assert_inert(text, where)
        assert ROOT_LINE not in text, where
    # the payloads are there, as text: the test reached the pages it means to
    _, out_of_band = results["results/scorecard_out_of_band.html"]
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in out_of_band
    assert ".. include:: /etc/passwd :literal:" in out_of_band
    assert "javascript:alert(1)" in out_of_band
    _, not_yet = results["results/scorecard_not_yet.html"]
    assert "javascript:alert(1)" in not_yet
    _, card = results["results/hostile/scorecard.html"]
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in card


def test_the_pages_in_results_hold_no_script_link_or_file(hostile):
    assert hostile.run.returncode == 0, hostile.run.stderr[-4000:]
    pages = sorted((hostile.repo / "results").rglob("*.html"))
    assert {p.name for p in pages} >= {"scorecard_out_of_band.html", "scorecard.html"}
    for p in pages:
        assert_inert(p.read_text(encoding="utf-8"), p)
    rst = (hostile.repo / "results" / "scorecard_summary.rst").read_text(encoding="utf-8")
    assert not re.search(r"^\s*\.\. (?:raw|include)::", rst, re.M) and ROOT_LINE not in rst


def test_the_tables_hold_no_formula_a_spreadsheet_would_run(hostile):
    assert hostile.run.returncode == 0, hostile.run.stderr[-4000:]
    tables = sorted((hostile.repo / "results").rglob("*.csv"))
    cells = {}
    for table in tables:
        with open(table, newline="", encoding="utf-8") as fh:
            cells[table.relative_to(hostile.repo).as_posix()] = [
                c for r in csv.reader(fh) for c in r
            ]
    for path, found in cells.items():
        assert not [c for c in found if c.startswith(("=", "@", "\t", "\r"))], path
        assert not [c for c in found if ROOT_LINE in c], path
    # the manifest's formula is in both tables, quoted
    assert "'" + FORMULA in cells["results/hostile/characterise/instruments.csv"]
    assert "'" + FORMULA in cells["results/hostile/scorecard.csv"]
