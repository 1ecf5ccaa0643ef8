"""Reliability: the fault matrix (docs/reliability.md), through Snakemake.

Users feed the pipeline their own captures and manifests. Whatever goes wrong, the pipeline must
stop with one line naming the file and the problem and leave no partial output, or, where the
analysis can honestly continue (a short NaN burst), continue, mask and count. Measured captures
are never written to; a killed run resumes without taking a half-written file as complete; and
re-simulating from scratch gives the same capture data and the same tables.

These run Snakemake in scratch copies of the repository on small measured datasets made from the
session's smoke captures (`smoke_run`), with only the targets they need; the same faults at the
rule-script level, on small synthetic captures, are in tests/unit/test_reliability.py.
"""

import json
import os
import re
import shutil
import signal
import subprocess
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
import yaml

from selfsense.io.capture import FILL, INT16_FULL, open_capture, read_series, scan_capture
from selfsense.io.manifest import load_yaml

from ..helpers import (
    CH3,
    PI,
    ROOT,
    add_measured,
    assert_same_capture,
    copy_repo,
    error_line,
    fingerprint,
    gap_in_the_middle,
    leftovers,
    manifest,
    one_line,
    run_snakemake,
    script,
    set_codes,
    snakemake_command,
    truncate,
    write_config,
)

# -- config and manifest faults, while Snakemake reads them ---------------------------------------


@pytest.fixture(scope="module")
def parse_repo(tmp_path_factory):
    """A scratch copy for fault runs that stop while Snakemake reads config and manifests."""
    repo = copy_repo(tmp_path_factory.mktemp("parse") / "repo")
    folder = repo / "raw" / "bench_gone"
    folder.mkdir()
    (folder / "dataset.yaml").write_text(yaml.safe_dump(manifest("bench_gone", ["ch3_sine_10hz"])))
    folder = repo / "raw" / "bench_typo"
    folder.mkdir()
    doc = manifest("bench_typo", []) | {"experimnts": ["ch3_sine_10hz"]}
    (folder / "dataset.yaml").write_text(yaml.safe_dump(doc))
    folder = repo / "raw" / "bench_hyphen"
    folder.mkdir()
    (folder / "dataset.yaml").write_text(
        yaml.safe_dump(manifest("bench_hyphen", ["ch3-sine-10hz"]))
    )
    # the Chapter 4 runs (a run of each role the identify stage reads: a set that is also the
    # recovery drive, the force record, the static tests), an actuator without its moving mass
    folder = repo / "raw" / "bench_nomass"
    folder.mkdir()
    runs = ["ch4_sine_10hz_s1", "ch4_sine_50hz_s1", "ch4_static_free", "ch4_static_blocked"]
    actuator = {k: v for k, v in PI["actuator"].items() if k != "moving_mass_kg"}
    doc = manifest("bench_nomass", runs, actuator=actuator, protocols=["ch3", "ch4"])
    (folder / "dataset.yaml").write_text(yaml.safe_dump(doc, allow_unicode=True))
    for run in runs:  # present: the check is made before any capture is read
        (folder / f"{run}.nc").touch()
    # a simulated dataset whose override asks the twin for a 1e12 s record
    folder = repo / "raw" / "pi_long"
    folder.mkdir()
    doc = load_yaml(ROOT / "raw" / "pi_p885" / "dataset.yaml") | {"name": "pi_long"}
    doc["protocol_overrides"] = {"ch3:experiments.ch3_sine_10hz.smoke.segments.0.duration": 1e12}
    (folder / "dataset.yaml").write_text(yaml.safe_dump(doc, allow_unicode=True))
    return repo


PIPELINE_FAULTS = [  # config changes, the file the line must name, what it must say
    pytest.param(
        {"datasets": ["bench_gone"]},
        "raw/bench_gone/dataset.yaml",
        ["experiment ch3_sine_10hz is listed without a capture raw/bench_gone/ch3_sine_10hz.nc"],
        id="experiment listed without its capture",
    ),
    pytest.param(
        {"datasets": ["bench_typo"]},
        "raw/bench_typo/dataset.yaml",
        ["unknown key experimnts"],
        id="unknown key in a manifest",
    ),
    pytest.param(
        {"datasets": ["nope"]},
        "raw/nope/dataset.yaml",
        ["unknown dataset 'nope'"],
        id="unknown dataset",
    ),
    pytest.param(
        {"datasets": ["bench_hyphen"]},
        "raw/bench_hyphen/dataset.yaml",
        ["experiment name 'ch3-sine-10hz' must be letters, digits or '_'"],
        id="hyphenated experiment name",
    ),
    pytest.param(
        {"datasets": ["bench_nomass"]},
        "raw/bench_nomass/dataset.yaml",
        ["key actuator.moving_mass_kg is missing: the identify (Ch. 4) stage computes with it"],
        id="a key an analysis computes with",
    ),
    pytest.param(
        {"datasets": ["../pi_p885"]},
        "fault.yaml",
        ["dataset name '../pi_p885'", "no path separators"],
        id="dataset name with '..'",
    ),
    pytest.param(
        {"datasets": ["raw/pi_p885"]},
        "fault.yaml",
        ["dataset name 'raw/pi_p885'", "no path separators"],
        id="dataset name with a path separator",
    ),
    pytest.param(
        {"datasets": ["pi_long"]},
        "raw/pi_long/dataset.yaml",
        [
            "key protocol_overrides.ch3:experiments.ch3_sine_10hz.smoke.segments.0.duration: "
            "1000000000000.0 is greater than the maximum of 12000"
        ],
        id="an override of 1e12 s",
    ),
    pytest.param(
        {"campain": "smoke"}, "fault.yaml", ["unknown key campain"], id="unknown config key"
    ),
    pytest.param(
        {"twin": {"together": ["ch6"]}},
        "fault.yaml",
        ["key twin.together: protocol ch6's run ch6_p1_closed needs identified values"],
        id="a closed loop simulated together",
    ),
    pytest.param(
        {"twin": {"together": ["ch44"]}},
        "fault.yaml",
        ["key twin.together: 'ch44' is no protocol of workflow/protocols"],
        id="no such protocol simulated together",
    ),
    pytest.param(
        {"ripple": {"n_periods": "four"}},
        "fault.yaml",
        ["key ripple.n_periods", "not of type 'integer'"],
        id="wrong type in config",
    ),
]


@pytest.mark.slow
@pytest.mark.parametrize("changes,source,problem", PIPELINE_FAULTS)
def test_bad_config_or_manifest_stops_snakemake_with_one_line(parse_repo, changes, source, problem):
    changes = dict(changes)
    config = write_config(parse_repo, "fault", changes.pop("datasets", ["pi_p885"]), **changes)
    run = run_snakemake(parse_repo, "-n", config=config)
    assert run.returncode != 0
    line = error_line(run, *problem)
    assert not (parse_repo / "results").exists()
    assert f"{source}: " in line, line


@pytest.mark.slow
def test_datasets_whose_protocol_has_other_runs_get_a_rule_each(parse_repo):
    """Chapter 4's runs are simulated in one job (config twin.together). A second simulated
    dataset with three sets of one sine, not two, gets a rule of its own: every run of each
    dataset is simulated once, by its dataset's rule."""
    doc = load_yaml(ROOT / "raw" / "pi_p885" / "dataset.yaml")
    doc |= {"name": "pi_p885_sets"}
    doc["protocol_overrides"] = {"ch4:experiments.ch4_sine_10hz.smoke.sets": 3}
    (parse_repo / "raw" / "pi_p885_sets").mkdir()
    (parse_repo / "raw" / "pi_p885_sets" / "dataset.yaml").write_text(yaml.safe_dump(doc))
    config = write_config(parse_repo, "sets", ["pi_p885", "pi_p885_sets"])
    run = run_snakemake(parse_repo, "-n", "-p", config=config)
    assert run.returncode == 0, run.stderr[-3000:]
    stats = dict(re.findall(r"^(simulate_ch4\w*)\s+(\d+)$", run.stdout, re.M))
    assert stats == {"simulate_ch4": "1", "simulate_ch4_2": "1"}, stats
    assert "raw/pi_p885_sets/ch4_sine_10hz_s3.nc" in run.stdout
    assert "raw/pi_p885/ch4_sine_10hz_s3.nc" not in run.stdout


# -- measured datasets, end to end (slow) --------------------------------------------------------

NAN_N, CLIP_N = 60, 4


@pytest.fixture(scope="module")
def bench(smoke_run, tmp_path_factory):
    """Two measured datasets run through the whole DAG with their captures read-only:

    bench_nan: the three Chapter 3 captures, a 60-sample NaN burst on Ur and Ir of the 10 Hz run
    and 4 clipped samples of I in the 1 Hz run; bench_ux: the same runs recorded with U and
    x_laser only.
    """
    repo = copy_repo(tmp_path_factory.mktemp("measured") / "repo")
    nan = add_measured(repo, smoke_run, "bench_nan", CH3)
    for channel in ("Ur", "Ir"):
        set_codes(nan / "ch3_sine_10hz.nc", channel, 9000, NAN_N, FILL)
    set_codes(nan / "ch3_sine_1hz.nc", "I", 20000, CLIP_N, INT16_FULL)
    ux = add_measured(repo, smoke_run, "bench_ux", CH3, channels=("U", "x_laser"))
    for folder in (nan, ux):
        for f in folder.iterdir():
            f.chmod(0o444)
    before = {f: fingerprint(f) for f in (nan, ux)}
    run = run_snakemake(repo, config=write_config(repo, "bench", ["bench_nan", "bench_ux"]))
    return SimpleNamespace(repo=repo, run=run, before=before, smoke=smoke_run)


@pytest.mark.slow
def test_measured_short_nan_burst_runs_masks_and_counts(bench):
    assert bench.run.returncode == 0, bench.run.stderr[-4000:]
    res = bench.repo / "results" / "bench_nan"
    qc = json.loads((res / "qc" / "ch3_sine_10hz.json").read_text())
    assert qc["nan"]["Ur"] == qc["nan"]["Ir"] == NAN_N
    assert sum(qc["nan"].values()) == 2 * NAN_N
    clipped = json.loads((res / "qc" / "ch3_sine_1hz.json").read_text())["clipped"]
    assert clipped["I"] >= CLIP_N
    table = pd.read_csv(res / "qc" / "captures.csv").set_index("experiment")
    assert table.loc["ch3_sine_10hz", "NaN samples"] == 2 * NAN_N
    assert (
        table.loc["ch3_sine_1hz", "NaN samples"] == 0
        and table.loc["ch3_sine_1hz", "clipped samples"] >= CLIP_N
    )
    ce = read_series(res / "ripple" / "ch3_sine_10hz.nc", ["C_e"])["C_e"]
    assert 1 <= np.count_nonzero(~np.isfinite(ce)) <= 10  # masked windows, the rest kept
    # the loop widths are those of the clean capture to well within a percentage point
    widths = ["width along horizontal [% of range]", "width along vertical [% of range]"]
    loops = pd.read_csv(res / "ch3" / "hysteresis.csv")[widths]
    clean = pd.read_csv(bench.smoke / "results" / "pi_p885" / "ch3" / "hysteresis.csv")[widths]
    assert np.isfinite(loops.to_numpy()).all()
    np.testing.assert_allclose(loops.to_numpy(), clean.to_numpy(), atol=0.5)
    assert (bench.repo / "figures" / "bench_nan" / "fig_3_10.png").exists()


@pytest.mark.slow
def test_measured_dataset_with_fewer_channels_skips_with_a_reason(bench):
    assert bench.run.returncode == 0, bench.run.stderr[-4000:]
    res = bench.repo / "results" / "bench_ux"
    table = pd.read_csv(res / "qc" / "captures.csv")
    assert sorted(table["experiment"]) == sorted(CH3) and (table["channels"] == "U x_laser").all()
    stages = pd.read_csv(res / "stages.csv").set_index("stage")
    assert stages.loc["characterise", "status"] == "runs"  # U and x are all it needs
    thesis = stages.drop("characterise")
    # every other analysis needs more channels
    assert thesis["status"].str.startswith("skipped").all()
    assert thesis["needs"].str.contains("this dataset lacks: ").all()
    assert len(pd.read_csv(res / "characterise" / "summary.csv")) == len(CH3)
    assert "runs" in set(pd.read_csv(bench.repo / "results" / "bench_nan" / "stages.csv")["status"])
    assert not (res / "ch3").exists() and not (res / "ripple").exists()
    assert (res / "scorecard.csv").exists()


@pytest.mark.slow
def test_measured_captures_are_never_written(bench):
    assert bench.run.returncode == 0, bench.run.stderr[-4000:]
    # root ignores 0444, so the proof is that nothing about the files changed
    for folder, before in bench.before.items():
        assert fingerprint(folder) == before
        assert all(mode == 0o444 for mode, _, _ in before.values())


@pytest.mark.slow
def test_measured_truncated_capture_stops_with_one_line(smoke_run, tmp_path):
    repo = copy_repo(tmp_path / "repo")
    folder = add_measured(repo, smoke_run, "bench_cut", CH3)
    truncate(folder / "ch3_sine_1hz.nc")
    config = write_config(repo, "cut", ["bench_cut"])
    run = run_snakemake(repo, "results/bench_cut/qc/captures.csv", config=config)
    assert run.returncode != 0
    line = error_line(run, "CaptureError: raw/bench_cut/ch3_sine_1hz.nc: ")
    assert "not a readable netCDF4 capture" in line or "unreadable capture" in line
    qc = repo / "results" / "bench_cut" / "qc"
    assert not (qc / "ch3_sine_1hz.json").exists() and not (qc / "captures.csv").exists()
    assert leftovers(repo / "results") == []


@pytest.mark.slow
def test_observer_masks_a_nan_burst_and_records_it(smoke_run, tmp_path):
    res = smoke_run / "results" / "pi_p885"
    capture = tmp_path / "ch5_sine_10hz.nc"
    shutil.copyfile(smoke_run / "raw" / "pi_p885" / "ch5_sine_10hz.nc", capture)
    with open_capture(capture) as cap:
        start = int(cap.n * 0.7)  # after the warm-up
    set_codes(capture, "Ur", start, NAN_N, FILL)
    stats = tmp_path / "stats.json"
    script("observe").main(
        str(capture),
        str(res / "ch5" / "gamma.json"),
        str(res / "ch5" / "observer.json"),
        str(tmp_path / "traces.nc"),
        str(stats),
        4,
        transient_s=None,
        inputs=[str(capture)],
    )
    hurt = json.loads(stats.read_text())
    clean = json.loads((res / "observer" / "ch5_sine_10hz.json").read_text())
    assert hurt["NaN samples"]["Ur"] == NAN_N and clean["masked ripple windows"] == 0
    assert 1 <= hurt["masked ripple windows"] <= 10
    assert np.isfinite(hurt["max error [µm]"])
    assert hurt["max error [µm]"] < 2 * clean["max error [µm]"] + 0.5


# -- interruption and determinism (slow) ---------------------------------------------------------


def start_snakemake(repo, config, *targets):
    """Snakemake in the background, in a process group of its own (to be killed whole)."""
    log = open(repo / "killed-run.log", "a")
    return subprocess.Popen(
        snakemake_command(*targets, config=config),
        cwd=repo,
        stdout=log,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )


class WriterTemporary:
    """The temporary a writer makes beside ``path`` (``<name>.<pid>-<random>.part``: unique per
    writer, so that two runs never write into one file)."""

    def __init__(self, path):
        self.path = Path(path)
        self.name = self.path.name + ".part"

    def exists(self):
        return any(self.path.parent.glob(self.path.name + ".*.part"))


def kill_when_any_exists(proc, paths, timeout=900):
    """SIGKILL the whole process group as soon as one of paths exists; the path seen, or None."""
    deadline = time.monotonic() + timeout
    try:
        while time.monotonic() < deadline:
            seen = next((p for p in paths if p.exists()), None)
            if seen is not None:
                return seen
            if proc.poll() is not None:
                return None
            time.sleep(0.005)
        pytest.fail(f"none of {paths} appeared within {timeout} s")
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


def incomplete_markers(repo):
    return [f for _, _, files in os.walk(repo / ".snakemake" / "incomplete") for f in files]


@pytest.mark.slow
def test_killed_run_resumes_and_never_takes_a_half_written_file(smoke_run, tmp_path):
    repo = copy_repo(tmp_path / "repo")
    config = write_config(repo, "pi", ["pi_p885"])
    capture = repo / "raw" / "pi_p885" / "ch3_sine_10hz.nc"
    series = repo / "results" / "pi_p885" / "ripple" / "ch3_sine_10hz.nc"
    table = repo / "results" / "pi_p885" / "ch3" / "hysteresis.csv"
    target = "results/pi_p885/ch3/hysteresis.csv"

    # 1. killed in the middle of `simulate`: the capture exists only as its .part file
    seen = kill_when_any_exists(start_snakemake(repo, config, target), [WriterTemporary(capture)])
    assert seen is not None, "simulate finished before it could be killed"
    assert not capture.exists()
    assert incomplete_markers(repo)

    # 2. resumed (Snakemake's lock outlives a SIGKILL: --unlock first), killed in an analysis rule
    assert run_snakemake(repo, "--unlock", config=config).returncode == 0
    proc = start_snakemake(repo, config, target)
    seen = kill_when_any_exists(
        proc, [WriterTemporary(series), repo / "logs" / "pi_p885" / "ch3_hysteresis.log"]
    )
    assert seen is not None, "the analysis finished before it could be killed"
    assert capture.exists() and not table.exists()
    assert incomplete_markers(repo)
    half = series if seen.name.endswith(".part") else table
    # a tool that wrote in place would leave this behind; Snakemake's incomplete record must
    # catch it
    half.write_bytes(b"half-written")

    # 3. the rerun (profiles/default sets rerun-incomplete) completes and equals a clean run
    assert run_snakemake(repo, "--unlock", config=config).returncode == 0
    run = run_snakemake(repo, target, config=config)
    assert run.returncode == 0, run.stderr[-4000:]
    assert incomplete_markers(repo) == []
    scan_capture(capture)
    read_series(series)
    assert_same_capture(capture, smoke_run / "raw" / "pi_p885" / "ch3_sine_10hz.nc")
    assert table.read_bytes() == (smoke_run / target).read_bytes()
    # what the kill left is only writers' temporaries (reaped by age, never by PID), which no
    # rule reads
    left = leftovers(repo / "raw") + leftovers(repo / "results")
    assert all(re.search(r"\.[0-9a-f]{16}\.part", Path(p).name) for p in left), left


@pytest.mark.slow
def test_resimulating_from_scratch_gives_identical_captures_and_tables(smoke_run, tmp_path):
    repo = copy_repo(tmp_path / "repo")  # no captures, no results: a clean second run
    tables = ["results/pi_p885/ch3/hysteresis.csv", "results/pi_p885/twin/ce_recovery.csv"]
    run = run_snakemake(repo, *tables, config=write_config(repo, "pi", ["pi_p885"]))
    assert run.returncode == 0, run.stderr[-4000:]
    for e in CH3:
        assert_same_capture(
            repo / "raw" / "pi_p885" / f"{e}.nc", smoke_run / "raw" / "pi_p885" / f"{e}.nc"
        )
        qc = [
            json.loads((r / "results" / "pi_p885" / "qc" / f"{e}.json").read_text())
            for r in (repo, smoke_run)
        ]
        assert [{k: q[k] for k in ("n_samples", "nan", "clipped")} for q in qc] == 2 * [
            {k: qc[1][k] for k in ("n_samples", "nan", "clipped")}
        ]
    for t in tables:
        assert (repo / t).read_bytes() == (smoke_run / t).read_bytes(), t


@pytest.mark.slow
def test_a_bad_capture_stops_everything_made_from_it_even_with_keep_going(smoke_run, tmp_path):
    # every rule that reads a capture takes its QC report, so check_capture's failure on
    # ch4_static_free leaves the stiffness, the Chapter 4 tables and figures, the model and the
    # scorecard unmade; what does not read that capture is still made under --keep-going
    repo = copy_repo(tmp_path / "repo")
    runs = sorted(p.stem for p in (smoke_run / "raw" / "pi_p885").glob("ch4_*.nc"))
    folder = add_measured(repo, smoke_run, "bench_k", runs)
    doc = load_yaml(folder / "dataset.yaml") | {"protocols": ["ch4"]}
    (folder / "dataset.yaml").write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
    gap_in_the_middle(folder / "ch4_static_free.nc")
    run = run_snakemake(repo, "--keep-going", config=write_config(repo, "k", ["bench_k"]))
    assert run.returncode != 0
    one_line(
        error_line(run, "CaptureError: ").split("CaptureError: ", 1)[1],
        "raw/bench_k/ch4_static_free.nc",
        "time axis breaks at sample 4000",
    )
    res, figs = repo / "results" / "bench_k", repo / "figures" / "bench_k"
    unmade = [
        res / "ch4" / f"{t}.csv"
        for t in (
            "static_stiffness",
            "sets",
            "table_4_1",
            "table_4_2",
            "table_4_3",
            "hysteresis_voltage",
        )
    ]
    unmade += [
        res / "ch4" / "model.json",
        res / "scorecard.csv",
        repo / "results" / "scorecard_summary.rst",
        res / "qc" / "ch4_static_free.json",
        res / "qc" / "captures.csv",
    ]
    assert [p for p in unmade if p.exists()] == []
    assert not list(figs.glob("fig_4_*.png"))
    made = [
        res / "qc" / "ch4_static_blocked.json",
        res / "ripple" / "ch4_sine_10hz_s1.nc",
        res / "ch3" / "table_3_1.csv",
        res / "stages.csv",
    ]
    assert [p for p in made if not p.exists()] == []
