"""`selfsense audit` and the start-of-run check: an input replaced by other bytes with an older
mtime (cp -p, rsync -t, tar x), which Snakemake does not see, is found by content."""

import json
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from selfsense.io import provenance as provenance_module
from selfsense.io.audit import Hashes, StaleInput, audit, check_inputs_unchanged
from selfsense.io.provenance import file_sha256, provenance, write_json, write_table

from ..helpers import ROOT, cli, script, set_codes, synthetic

HINT = ".venv/bin/snakemake --cores 2"


class ANY_TAIL(str):  # noqa: N801 (a matcher, used like a value)
    """Equal to any text that starts with this one."""

    def __eq__(self, other):
        return isinstance(other, str) and other.startswith(self)

    __hash__ = str.__hash__


def replace_keeping_mtime(path, data):
    """What `cp -p other path` does: other bytes, the old file's times."""
    st = path.stat()
    path.write_bytes(data)
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))


def older(path, seconds=3600):
    st = path.stat()
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns - int(seconds * 1e9)))


@pytest.fixture
def made(tmp_path, monkeypatch):
    """raw/bench/c.nc and results/bench/t.csv made from it by write_table, in a checkout at
    tmp_path (inputs are recorded relative to it, as rules name them)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "raw" / "bench").mkdir(parents=True)
    capture = tmp_path / "raw" / "bench" / "c.nc"
    capture.write_bytes(b"capture, first take " * 100)
    table = "results/bench/t.csv"
    write_table(pd.DataFrame({"x [m]": [1.0, 2.0]}), table, inputs=["raw/bench/c.nc"])
    return capture, table


def run(capsys, *args):
    code = cli(["audit", *args])
    return code, capsys.readouterr().out.splitlines()


def test_an_unchanged_output_is_up_to_date(made, capsys):
    _, table = made
    assert audit(table) == []
    assert run(capsys, table) == (0, [f"{table}: up to date (1 input)"])


@pytest.mark.parametrize("same_size", [True, False])
def test_an_input_replaced_with_its_old_mtime_is_stale_with_the_way_to_remake(
    made, capsys, same_size
):
    capture, table = made
    replace_keeping_mtime(
        capture, b"capture, other take " * 100 if same_size else b"a different capture"
    )
    (stale,) = audit(table)
    assert (stale.output, stale.input, stale.problem) == (table, "raw/bench/c.nc", "changed")
    code, lines = run(capsys, table)
    assert code == 1 and len(lines) == 1
    recorded = json.loads((capture.parents[2] / f"{table}.json").read_text())["inputs"]
    assert lines[0] == (
        f"{table}: input raw/bench/c.nc changed since it was made (sha256 recorded "
        f"{recorded['raw/bench/c.nc'][:12]}…, now {stale.now[:12]}…): re-make it with "
        f"touch raw/bench/c.nc && {HINT} {table}"
    )


def test_a_missing_input_is_stale(made, capsys):
    capture, table = made
    capture.unlink()
    code, lines = run(capsys, table)
    assert code == 1
    assert lines == [
        f"{table}: input raw/bench/c.nc is missing (sha256 recorded "
        f"{audit(table)[0].recorded[:12]}…): re-make it with {HINT} -f {table}"
    ]


@pytest.mark.parametrize("text", ["", "{not json", '{"config": {}}', "\xff\xfe"])
def test_a_sidecar_that_is_not_json_or_has_no_inputs_is_one_line(made, capsys, text):
    _, table = made
    with open(f"{table}.json", "w", encoding="latin-1") as fh:
        fh.write(text)
    code, lines = run(capsys, table)
    assert code == 1 and len(lines) == 1
    assert lines[0].startswith(f"{table}: provenance {table}.json ")
    assert lines[0].endswith(f"re-make it with {HINT} -f {table}")


def test_an_output_without_provenance_or_gone_is_named(made, capsys):
    _, table = made
    assert run(capsys, "results/bench/nope.csv") == (
        1,
        [
            "results/bench/nope.csv: no provenance (results/bench/nope.csv.json is missing): "
            f"re-make it with {HINT} -f results/bench/nope.csv"
        ],
    )
    os.unlink(table)
    code, lines = run(capsys, table)
    assert code == 1 and lines == [
        f"{table}: missing (its provenance is there): re-make it with {HINT} -f {table}"
    ]


def test_a_folder_is_audited_whole_and_each_input_is_read_once(made, capsys, monkeypatch):
    capture, table = made
    folder = capture.parents[2] / "results" / "bench"
    (folder / "qc").mkdir()
    # a report with its provenance inside (QC reports, models), a figure's sidecar, a temporary
    write_json({"n": 1, "provenance": provenance(["raw/bench/c.nc"])}, folder / "qc" / "c.json")
    (folder / "f.png").write_bytes(b"png")
    write_json(provenance(["raw/bench/c.nc", table]), folder / "f.png.json")
    (folder / ".t.node-a.0123456789abcdef.part.csv.json").write_text("{half")
    (folder / "stages.json").write_text('{"no": "provenance"}')
    assert run(capsys, "results/bench") == (
        0,
        [
            "results/bench/f.png: up to date (2 inputs)",
            "results/bench/qc/c.json: up to date (1 input)",
            f"{table}: up to date (1 input)",
        ],
    )
    replace_keeping_mtime(capture, b"another")
    opened = []
    # the audit reads an input's bytes only through provenance.file_sha256
    monkeypatch.setattr(
        provenance_module, "open", lambda p, *a: opened.append(p) or open(p, *a), raising=False
    )
    code, lines = run(capsys, "results/bench", f"{table}.json")  # a sidecar stands for its output
    assert code == 1
    what = "input raw/bench/c.nc changed since it was made"
    changed = f"{what} (sha256 recorded "
    assert [line.split(": ", 1) for line in lines] == [
        ["results/bench/f.png", ANY_TAIL(changed)],
        [
            "results/bench/f.png",
            ANY_TAIL(f"input {table} is stale itself ({table}: {what}): "),
        ],
        ["results/bench/qc/c.json", ANY_TAIL(changed)],
        [table, ANY_TAIL(changed)],
        [table, ANY_TAIL(changed)],
    ]
    assert all(
        line.endswith(f"touch raw/bench/c.nc && {HINT} {line.split(':')[0]}") for line in lines
    )
    # asked for four times, read once; the table (an input of the figure) once
    assert sorted(p.name for p in opened) == ["c.nc", "t.csv"]


def test_a_pdf_is_audited_by_its_pngs_sidecar(made, capsys):
    capture, table = made
    folder = capture.parents[2] / "results" / "bench"
    (folder / "f.png").write_bytes(b"png")
    (folder / "f.pdf").write_bytes(b"pdf")
    write_json(provenance([table]), folder / "f.png.json")
    assert run(capsys, "results/bench/f.pdf") == (0, ["results/bench/f.pdf: up to date (1 input)"])


def test_root_resolves_recorded_inputs_from_elsewhere(made, capsys, monkeypatch, tmp_path):
    _, table = made
    monkeypatch.chdir(tmp_path / "raw")
    code, lines = run(capsys, str(tmp_path / table))
    assert code == 1 and "is missing" in lines[0]
    assert run(capsys, "--root", str(tmp_path), str(tmp_path / table))[0] == 0


# -- the start-of-run check -------------------------------------------------------------------


@pytest.fixture
def checked(tmp_path, monkeypatch):
    """A measured dataset's capture and manifest, and the QC report made from them (its
    provenance records each one's sha256, size and mtime), older than the report."""
    monkeypatch.chdir(tmp_path)
    folder = tmp_path / "raw" / "lab"
    folder.mkdir(parents=True)
    capture, manifest = folder / "c.nc", folder / "dataset.yaml"
    capture.write_bytes(b"first take " * 1000)
    manifest.write_text("source: measured\n")
    for path in (capture, manifest):
        older(path)
    qc = tmp_path / "results" / "lab" / "qc" / "c.json"
    inputs = ["raw/lab/c.nc", "raw/lab/dataset.yaml"]
    write_json({"n_samples": 1, "provenance": provenance(inputs)}, qc)
    write_table(
        pd.DataFrame({"n": [1]}), qc.parent / "captures.csv", inputs=[qc.relative_to(tmp_path)]
    )
    return capture, manifest, qc


def stops(*fragments, datasets=("lab",)):
    with pytest.raises(StaleInput) as err:
        check_inputs_unchanged(datasets)
    message = str(err.value)
    assert "\n" not in message
    for f in fragments:
        assert f in message, message
    return message


def no_reading(monkeypatch):
    def fail(self, path, st=None):
        raise AssertionError(f"{path} was read")

    monkeypatch.setattr(Hashes, "__call__", fail)


def test_the_start_check_reads_no_capture_when_nothing_changed(checked, monkeypatch):
    no_reading(monkeypatch)
    check_inputs_unchanged(["lab", "not_run_yet"])


def test_the_start_check_stops_on_a_replacement_of_another_size_without_reading_it(
    checked, monkeypatch
):
    capture, _, qc = checked
    replace_keeping_mtime(capture, b"a shorter, different capture")
    no_reading(monkeypatch)
    message = stops(
        "raw/lab/c.nc: not the file results/lab/qc/c.json checked (size 11000 bytes recorded, "
        "now 28)",
        "touch raw/lab/c.nc and run again (selfsense audit results/lab lists what is stale)",
    )
    assert message.startswith("raw/lab/c.nc")


def test_the_start_check_hashes_a_same_size_file_whose_mtime_differs(checked):
    capture, manifest, _ = checked
    replace_keeping_mtime(capture, b"other take " * 1000)
    older(capture, 60)  # copied from a file with another, still older, mtime
    replace_keeping_mtime(manifest, b"source: measure\n")
    stops(
        "raw/lab/c.nc (and 1 more: raw/lab/dataset.yaml): not the file",
        "same size, other mtime, sha256 now",
        "touch raw/lab/c.nc raw/lab/dataset.yaml and run again",
    )


def test_the_start_check_passes_a_copy_of_the_same_bytes_and_a_newer_file(checked):
    capture, manifest, _ = checked
    older(capture, 60)  # the same bytes, another mtime (cp -p from a backup)
    check_inputs_unchanged(["lab"])
    replace_keeping_mtime(manifest, b"source: measure\n")
    os.utime(manifest)  # newer than the report: Snakemake re-makes it, no need to stop
    check_inputs_unchanged(["lab"])


def test_what_the_start_check_cannot_see_the_audit_finds(checked, capsys):
    """A replacement with the same size and the same mtime costs a hash to find: the start check
    does not read captures, `selfsense audit` does."""
    capture, _, qc = checked
    replace_keeping_mtime(capture, b"other take " * 1000)
    check_inputs_unchanged(["lab"])
    code, lines = run(capsys, "results/lab")
    assert code == 1
    assert lines[0].startswith("results/lab/qc/c.json: input raw/lab/c.nc changed since it was")
    # a table made from that report is stale through it
    assert lines[1:] == [
        "results/lab/qc/captures.csv: input results/lab/qc/c.json is stale itself "
        "(results/lab/qc/c.json: input raw/lab/c.nc changed since it was made): re-make it with "
        f"touch raw/lab/c.nc && {HINT} results/lab/qc/captures.csv"
    ]


def test_the_start_check_skips_reports_without_sizes_and_files_that_are_gone(checked):
    capture, manifest, qc = checked
    doc = json.loads(qc.read_text())
    del doc["provenance"]["input_files"]  # a report from before sizes were recorded
    qc.write_text(json.dumps(doc))
    replace_keeping_mtime(capture, b"x")
    check_inputs_unchanged(["lab"])
    write_json({"provenance": provenance(["raw/lab/c.nc"])}, qc)
    capture.unlink()
    check_inputs_unchanged(["lab"])  # Snakemake names a missing input itself


def test_the_snakefile_runs_the_check_on_measured_datasets_at_parse_time():
    """At parse time, not in onstart: Snakemake runs onstart neither in a dry run nor when there
    is nothing to be done, which is what a replaced capture gives."""
    lines = (ROOT / "Snakefile").read_text().splitlines()
    assert "check_inputs_unchanged(MEASURED)" in lines  # top level, after the includes
    assert lines.index("check_inputs_unchanged(MEASURED)") > max(
        i for i, line in enumerate(lines) if line.startswith("include:")
    )


def test_an_output_made_from_a_stale_output_is_stale_down_to_the_first_cause(made, capsys):
    capture, table = made
    root = capture.parents[2]
    write_table(pd.DataFrame({"y": [1]}), "results/bench/u.csv", inputs=[table])
    write_table(pd.DataFrame({"z": [1]}), "results/bench/v.csv", inputs=["results/bench/u.csv"])
    assert run(capsys, "results/bench/v.csv") == (0, ["results/bench/v.csv: up to date (1 input)"])
    capture.unlink()
    code, lines = run(capsys, "results/bench/v.csv")
    assert code == 1
    assert lines == [
        "results/bench/v.csv: input results/bench/u.csv is stale itself (the first cause: "
        f"{table}: input raw/bench/c.nc is missing): re-make it with {HINT} -f {table} && {HINT} "
        "results/bench/v.csv"
    ]
    # an output among its inputs' inputs (never made so, but a hand-edited sidecar could say it)
    side = json.loads((root / f"{table}.json").read_text())
    side["inputs"]["results/bench/v.csv"] = side["inputs"].pop("raw/bench/c.nc")
    (root / f"{table}.json").write_text(json.dumps(side))
    assert run(capsys, "results/bench/v.csv")[0] == 1


def test_a_manifest_every_report_names_is_named_once(checked):
    _, manifest, qc = checked
    other = qc.parents[3] / "raw" / "lab" / "d.nc"
    other.write_bytes(b"second capture")
    older(other)
    inputs = ["raw/lab/d.nc", "raw/lab/dataset.yaml"]
    write_json({"provenance": provenance(inputs)}, qc.with_name("d.json"))
    replace_keeping_mtime(manifest, b"source: measure\n")
    message = stops("raw/lab/dataset.yaml: not the file results/lab/qc/c.json checked")
    assert "more" not in message and message.count("raw/lab/dataset.yaml") == 2  # and its touch


def test_the_start_check_finds_a_replaced_manifest_through_the_stage_plan(checked):
    """The QC reports hold the capture only (a new batch in the manifest re-checks nothing); the
    stage plan's sidecar holds the manifest, and the start check reads it too."""
    capture, manifest, qc = checked
    write_json({"provenance": provenance(["raw/lab/c.nc"])}, qc)
    plan = qc.parents[1] / "stages.csv"
    write_table(pd.DataFrame({"stage": ["characterise"]}), plan, inputs=["raw/lab/dataset.yaml"])
    replace_keeping_mtime(manifest, b"source: measured, other\n")
    stops("raw/lab/dataset.yaml: not the file results/lab/stages.csv.json checked (size")


# -- the whole chain: a table, the series it was made from, the capture ---------------------------


@pytest.fixture
def chain(tmp_path, monkeypatch):
    """A simulated capture raw/bench/ch3_sine_10hz.nc, its ripple series (rule extract_ripple)
    and the two Chapter 3 tables made from the series (rule ch3_hysteresis), made by the rules'
    own scripts in a checkout at tmp_path."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "raw" / "bench").mkdir(parents=True)
    capture = "raw/bench/ch3_sine_10hz.nc"
    synthetic(capture)
    series = "results/bench/ripple/ch3_sine_10hz.nc"
    script("extract_ripple").main(capture, series, 4)
    tables = ["results/bench/ch3/hysteresis.csv", "results/bench/ch3/phases.csv"]
    with np.errstate(divide="ignore"):  # the synthetic loops are closed: their widths divide by 0
        script("ch3_hysteresis").main(series, *tables, skip_s=0.05, frequency=10.0, inputs=[series])
    return tmp_path / capture, series, tables


def test_a_series_records_the_capture_it_was_made_from(chain, capsys):
    capture, series, tables = chain
    recorded = json.loads(Path(f"{series}.json").read_text())
    assert recorded["inputs"] == {"raw/bench/ch3_sine_10hz.nc": file_sha256(capture)}
    assert recorded["config"] == {"n_periods": 4}
    assert run(capsys, "results/bench") == (
        0,
        [
            f"{tables[0]}: up to date (1 input)",
            f"{tables[1]}: up to date (1 input)",
            f"{series}: up to date (1 input)",
        ],
    )


@pytest.mark.parametrize("fault", ["changed in place", "deleted"])
def test_a_changed_or_deleted_capture_names_every_table_made_from_it(chain, capsys, fault):
    """The tables record only the series; the audit follows the series' provenance down to the
    capture, which Snakemake does not see changed when its mtime is kept."""
    capture, series, tables = chain
    if fault == "deleted":
        capture.unlink()
        cause = "input raw/bench/ch3_sine_10hz.nc is missing"
    else:
        st = capture.stat()
        set_codes(capture, "Ur", 100, 50, 1000)  # a few samples of the ripple, mtime kept
        os.utime(capture, ns=(st.st_atime_ns, st.st_mtime_ns))
        cause = "input raw/bench/ch3_sine_10hz.nc changed since it was made"
    code, lines = run(capsys, *tables)
    assert code == 1
    assert [line.split(": ", 1)[0] for line in lines] == tables
    for line in lines:
        assert f"input {series} is stale itself ({series}: {cause})" in line
    code, lines = run(capsys, "results/bench")
    assert code == 1 and [line.split(": ", 1)[0] for line in lines] == [*tables, series]
