"""Reliability: the fault matrix (docs/reliability.md).

Users feed the pipeline their own captures and manifests. Whatever goes wrong, the pipeline must
stop with one line naming the file and the problem and leave no partial output, or, where the
analysis can honestly continue (a short NaN burst), continue, mask and count. Measured captures
are never written to; a killed run resumes without taking a half-written file as complete; and
re-simulating from scratch gives the same capture data and the same tables.

The fast tests work on small synthetic captures and call the rules' scripts directly. The slow
ones run Snakemake in scratch copies of the repository on small measured datasets made from the
session's smoke captures (`smoke_run`), with only the targets they need.
"""

import hashlib
import importlib.util
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import netCDF4
import numpy as np
import pandas as pd
import pytest
import yaml

from selfsense.io.capture import (
    FILL,
    INT16_FULL,
    CaptureError,
    CaptureWriter,
    channel_spec,
    open_capture,
    read_series,
    scan_capture,
)
from selfsense.io.manifest import ManifestError, load_dataset, load_yaml

from .conftest import ROOT, copy_repo

CH3 = ("ch3_sine_10hz", "ch3_sine_1hz", "ch3_sine_0p1hz")
FS = 48000.0
PI = load_yaml(ROOT / "raw" / "pi_p885" / "dataset.yaml")
RANGES = PI["daq"]["ranges"]


# -- helpers -------------------------------------------------------------------------------------


def script(name):
    """A rule's script from workflow/scripts, imported as a module (its main() is the rule)."""
    spec = importlib.util.spec_from_file_location(
        f"rule_{name}", ROOT / "workflow" / "scripts" / f"{name}.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def synthetic(path, n=9600, channels=("U", "I", "Ur", "Ir", "x_laser")):
    """A small capture in the contract: a 10 Hz drive and a ripple folded to 4 kHz."""
    t = np.arange(n) / FS
    values = {
        "U": 50 - 50 * np.cos(2 * np.pi * 10 * t),
        "I": 0.05 * np.sin(2 * np.pi * 10 * t),
        "Ur": 0.1 * np.sin(2 * np.pi * 4000 * t),
        "Ir": 0.05 * np.cos(2 * np.pi * 4000 * t),
        "x_laser": 1.5e-5 * (1 - np.cos(2 * np.pi * 10 * t)),
    }
    attrs = {
        "fs": FS,
        "fr_nominal": 1e5,
        "ns": 12,
        "nf": 4,
        "warmup_s": 0.0,
        "dataset": "bench",
        "experiment": Path(path).stem,
        "source": "measured",
    }
    with CaptureWriter(path, attrs, [channel_spec(c, *RANGES[c]) for c in channels], n) as w:
        w.write({c: values[c] for c in channels})
    return Path(path)


def bench_manifest(tmp_path, **changes):
    """raw/bench/dataset.yaml under tmp_path for the synthetic captures (check_capture compares
    a capture with its manifest); its path as text."""
    folder = tmp_path / "manifests" / "bench"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "dataset.yaml").write_text(
        yaml.safe_dump(manifest("bench", []) | changes, sort_keys=False, allow_unicode=True)
    )
    return str(folder / "dataset.yaml")


def set_codes(path, channel, start, n, code):
    """Overwrite n raw int16 samples of a channel (FILL = a NaN burst, ±INT16_FULL = clipped)."""
    with netCDF4.Dataset(path, "a") as nc:
        var = nc[channel]
        var.set_auto_maskandscale(False)
        var[start : start + n] = np.full(n, code, dtype=np.int16)


def edit_time(path, fn):
    with netCDF4.Dataset(path, "a") as nc:
        t = nc["time"][:]
        nc["time"][:] = fn(np.asarray(t))


def one_line(message, path, *fragments):
    assert "\n" not in message
    assert message.startswith(str(path)), message
    for f in fragments:
        assert f in message, message


def run_snakemake(repo, config, *args):
    """Snakemake in a scratch copy; targets go before --configfile (which takes several values)."""
    return subprocess.run(
        [sys.executable, "-m", "snakemake", "--cores", "2", *args, "--configfile", config],
        cwd=repo,
        capture_output=True,
        text=True,
        timeout=1800,
    )


def error_line(run, *fragments):
    """The one line of Snakemake's output that carries all fragments (the error, whole)."""
    lines = [
        line for line in (run.stdout + run.stderr).splitlines() if all(f in line for f in fragments)
    ]
    assert lines, f"no line with {fragments}:\n{run.stderr[-4000:]}"
    return lines[0]


def leftovers(folder):
    """Half-written files: capture/series .part files and atomic_path's hidden temporaries."""
    folder = Path(folder)
    if not folder.exists():
        return []
    return sorted(
        str(p)
        for p in folder.rglob("*")
        if p.is_file() and (p.name.endswith(".part") or p.name.startswith("."))
    )


def fingerprint(folder):
    """{file: (mode, mtime_ns, sha256)} of every file in a folder."""
    return {
        p.name: (
            p.stat().st_mode & 0o777,
            p.stat().st_mtime_ns,
            hashlib.sha256(p.read_bytes()).hexdigest(),
        )
        for p in sorted(Path(folder).iterdir())
    }


def write_config(repo, name, datasets, **changes):
    """A config in the scratch copy: the smoke config with only these datasets (path relative to repo)."""
    config = yaml.safe_load((ROOT / "tests" / "config" / "smoke.yaml").read_text())
    config |= {"datasets": list(datasets)} | changes
    (repo / f"{name}.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    return f"{name}.yaml"


def manifest(name, experiments, channels=None, **changes):
    channels = list(channels or PI["daq"]["channels"])
    daq = dict(PI["daq"], channels=channels, ranges={c: RANGES[c] for c in channels})
    doc = {
        "name": name,
        "description": f"{name}: a measured bench dataset made for the fault tests",
        "source": "measured",
        "model": "stack",
        "actuator": PI["actuator"],
        "daq": daq,
        "protocols": ["ch3"],
        "experiments": list(experiments),
    }
    return doc | changes


def add_measured(repo, smoke, name, experiments, channels=None):
    """raw/<name>/ in a scratch copy: a measured dataset made of smoke captures (only `channels`)."""
    folder = repo / "raw" / name
    folder.mkdir(parents=True)
    for e in experiments:
        src, dst = smoke / "raw" / "pi_p885" / f"{e}.nc", folder / f"{e}.nc"
        if channels is None:
            shutil.copyfile(src, dst)
            with netCDF4.Dataset(dst, "a") as nc:
                nc.dataset, nc.source = name, "measured"
        else:  # a DAQ that records fewer channels
            with open_capture(src) as cap:
                data, n = cap.read(list(channels)), cap.n
                attrs = {
                    k: v
                    for k, v in cap.attrs.items()
                    if k not in ("Conventions", "clipped_samples")
                }
            with CaptureWriter(
                dst,
                attrs | {"dataset": name, "source": "measured"},
                [channel_spec(c, *RANGES[c]) for c in channels],
                n,
            ) as w:
                w.write(data)
    doc = manifest(name, experiments, channels)
    (folder / "dataset.yaml").write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
    return folder


def capture_arrays(path):
    """Every variable of a capture (groups included) as raw arrays, and its global attributes."""
    out = {}
    with netCDF4.Dataset(path) as nc:
        attrs = {k: nc.getncattr(k) for k in nc.ncattrs()}
        for group in (nc, *nc.groups.values()):
            group.set_auto_maskandscale(False)
            for name, var in group.variables.items():
                out[f"{group.path}/{name}"] = np.asarray(var[:])
    return attrs, out


def assert_same_capture(a, b):
    attrs_a, data_a = capture_arrays(a)
    attrs_b, data_b = capture_arrays(b)
    assert attrs_a == attrs_b
    assert data_a.keys() == data_b.keys()
    for key in data_a:
        np.testing.assert_array_equal(data_a[key], data_b[key], err_msg=f"{a} {key}")


# -- capture faults, at the rule-script level (fast) ---------------------------------------------


def _truncate(p):
    data = p.read_bytes()
    p.write_bytes(data[: len(data) // 2])


def _not_netcdf(p):
    p.write_text("time,U\n0,1\n")


def _units(p):
    with netCDF4.Dataset(p, "a") as nc:
        nc["U"].units = "mV"


def _wrong_fs(p):
    with netCDF4.Dataset(p, "a") as nc:
        nc.fs = 50000.0


def _folding(p):
    with netCDF4.Dataset(p, "a") as nc:
        nc.nf = 2  # fr = 100 kHz, ns = 12, nf = 2 needs fs = 80 kHz


def _empty(p):
    p.unlink()
    with CaptureWriter(
        p, {"fs": FS, "fr_nominal": 1e5, "ns": 12, "nf": 4}, [channel_spec("U", -200, 200)], 0
    ):
        pass


def _gap_end(p):
    edit_time(p, lambda t: np.where(np.arange(len(t)) >= 4000, t + 0.01, t))


def _gap_middle(p):
    edit_time(
        p, lambda t: np.where((np.arange(len(t)) >= 4000) & (np.arange(len(t)) < 4100), t + 0.5, t)
    )


CAPTURE_FAULTS = {  # fault: (make it, what the one line must say)
    "truncated file": (_truncate, ""),
    "not a netCDF file": (_not_netcdf, "not a readable netCDF4 capture"),
    "wrong units attribute": (_units, "channel U is in 'mV', the manifest declares 'V'"),
    "time axis with a gap": (_gap_end, "gap or wrong fs"),
    "gap inside the time axis": (_gap_middle, "time axis breaks at sample 4000"),
    "wrong fs": (_wrong_fs, "fs = 50000"),
    "fs violates the folding equation": (_folding, "violates the folding equation"),
    "empty capture": (_empty, "empty capture"),
}


@pytest.mark.parametrize("fault", CAPTURE_FAULTS)
def test_bad_capture_stops_check_capture_with_one_line_and_no_output(tmp_path, fault):
    make, fragment = CAPTURE_FAULTS[fault]
    capture = synthetic(tmp_path / "raw" / "ch3_sine_10hz.nc")
    make(capture)
    report = tmp_path / "qc" / "ch3_sine_10hz.json"
    with pytest.raises(CaptureError) as e:
        script("check_capture").main(str(capture), bench_manifest(tmp_path), str(report))
    one_line(str(e.value), capture, fragment)
    assert not report.exists() and leftovers(tmp_path / "qc") == []


def test_missing_channel_stops_the_analysis_with_one_line_and_no_output(tmp_path):
    capture = synthetic(tmp_path / "ch3_sine_10hz.nc", channels=("U", "x_laser"))
    series = tmp_path / "ripple" / "ch3_sine_10hz.nc"
    with pytest.raises(CaptureError) as e:
        script("extract_ripple").main(str(capture), str(series), 4)
    one_line(str(e.value), capture, "missing channel(s) Ur, Ir, I needed by this analysis")
    assert not series.exists() and leftovers(tmp_path / "ripple") == []


def test_short_nan_burst_and_clipping_are_counted_and_the_ripple_is_masked(tmp_path):
    capture = synthetic(tmp_path / "ch3_sine_10hz.nc")
    set_codes(capture, "Ur", 5000, 50, FILL)
    set_codes(capture, "I", 7000, 3, INT16_FULL)
    report = tmp_path / "qc.json"
    script("check_capture").main(str(capture), bench_manifest(tmp_path), str(report))
    qc = json.loads(report.read_text())
    assert qc["nan"] == {"U": 0, "I": 0, "Ur": 50, "Ir": 0, "x_laser": 0}
    assert qc["clipped"]["I"] == 3
    series = tmp_path / "series.nc"
    script("extract_ripple").main(str(capture), str(series), 4)
    ce = read_series(series, ["C_e"])["C_e"]
    bad = np.count_nonzero(~np.isfinite(ce))
    assert 1 <= bad <= 10, bad  # only the ripple windows that touch the 50 NaN samples
    assert len(ce) > 700


KILL_MID_WRITE = """
import os, signal, sys
import numpy as np
from selfsense.io.capture import CaptureWriter, SeriesWriter, channel_spec
from selfsense.io.provenance import atomic_path
kind, out = sys.argv[1], sys.argv[2]
if kind == "capture":
    with CaptureWriter(out, {"fs": 48000.0}, [channel_spec("U", -200, 200)], 4800) as w:
        w.write({"U": np.zeros(2400)})
        os.kill(os.getpid(), signal.SIGKILL)
elif kind == "series":
    with SeriesWriter(out, {"C_e": "F"}) as w:
        w.write({"C_e": np.zeros(100)})
        os.kill(os.getpid(), signal.SIGKILL)
else:
    with atomic_path(out) as tmp:
        tmp.write_text("experiment,NaN samples\\nch3_sine_10hz,")
        os.kill(os.getpid(), signal.SIGKILL)
"""


@pytest.mark.parametrize("kind,name", [("capture", "c.nc"), ("series", "s.nc"), ("table", "t.csv")])
def test_writer_killed_mid_write_never_leaves_a_complete_looking_file(tmp_path, kind, name):
    out = tmp_path / name
    if kind == "table":
        out.write_text("experiment,NaN samples\nch3_sine_10hz,0\n")  # the previous complete table
    before = out.read_bytes() if out.exists() else None
    run = subprocess.run(
        [sys.executable, "-c", KILL_MID_WRITE, kind, str(out)], capture_output=True, timeout=300
    )
    assert run.returncode == -signal.SIGKILL, run.stderr
    assert (
        out.read_bytes() if out.exists() else None
    ) == before  # absent, or the old complete file
    # what is left is under a name no rule reads: <name>.part, or atomic_path's hidden temporary
    assert all(
        p.name.endswith(".part") or p.name.startswith(".") for p in tmp_path.iterdir() if p != out
    )


# -- manifest and config faults ------------------------------------------------------------------


def _manifest_dir(tmp_path, **changes):
    folder = tmp_path / "bench"
    folder.mkdir()
    doc = manifest("bench", ["ch3_sine_10hz"]) | changes
    for key in [k for k, v in doc.items() if v is None]:
        del doc[key]
    (folder / "dataset.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    return folder / "dataset.yaml"


@pytest.mark.parametrize(
    "change,fragments",
    [
        pytest.param(
            {"experiment": ["ch3_sine_10hz"]}, ["unknown key experiment"], id="unknown key"
        ),
        pytest.param({"daq": None}, ["'daq' is a required property"], id="missing required field"),
        pytest.param(
            {"experiments": "ch3_sine_10hz"},
            ["key experiments", "not of type 'array'"],
            id="wrong type",
        ),
        pytest.param(
            {"source": "measurd"}, ["key source", "is not one of"], id="value not allowed"
        ),
    ],
)
def test_bad_manifest_is_one_line_naming_file_and_key(tmp_path, change, fragments):
    path = _manifest_dir(tmp_path, **change)
    with pytest.raises(ManifestError) as e:
        load_dataset(tmp_path, "bench")
    one_line(str(e.value), path, *fragments)


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
    folder = (
        repo / "raw" / "bench_nomass"
    )  # the Chapter 4 runs, an actuator without its moving mass
    folder.mkdir()
    runs = ["ch4_sine_10hz_s1", "ch4_static_free", "ch4_static_blocked"]
    actuator = {k: v for k, v in PI["actuator"].items() if k != "moving_mass_kg"}
    doc = manifest("bench_nomass", runs, actuator=actuator, protocols=["ch3", "ch4"])
    (folder / "dataset.yaml").write_text(yaml.safe_dump(doc, allow_unicode=True))
    for run in runs:  # present: the check is made before any capture is read
        (folder / f"{run}.nc").touch()
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
        {"campain": "smoke"}, "fault.yaml", ["unknown key campain"], id="unknown config key"
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
    run = run_snakemake(parse_repo, config, "-n")
    assert run.returncode != 0
    line = error_line(run, *problem)
    assert not (parse_repo / "results").exists()
    assert f"{source}: " in line, line


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
    run = run_snakemake(repo, write_config(repo, "bench", ["bench_nan", "bench_ux"]))
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
    assert (
        thesis["status"].str.startswith("skipped").all()
    )  # every other analysis needs more channels
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
    _truncate(folder / "ch3_sine_1hz.nc")
    run = run_snakemake(
        repo, write_config(repo, "cut", ["bench_cut"]), "results/bench_cut/qc/captures.csv"
    )
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
    )
    hurt = json.loads(stats.read_text())
    clean = json.loads((res / "observer" / "ch5_sine_10hz.json").read_text())
    assert hurt["NaN samples"]["Ur"] == NAN_N and clean["masked ripple windows"] == 0
    assert 1 <= hurt["masked ripple windows"] <= 10
    assert np.isfinite(hurt["max error [µm]"])
    assert hurt["max error [µm]"] < 2 * clean["max error [µm]"] + 0.5


# -- interruption and determinism (slow) ---------------------------------------------------------


def start_snakemake(repo, config, *targets):
    log = open(repo / "killed-run.log", "a")
    return subprocess.Popen(
        [sys.executable, "-m", "snakemake", "--cores", "2", *targets, "--configfile", config],
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
    assert run_snakemake(repo, config, "--unlock").returncode == 0
    proc = start_snakemake(repo, config, target)
    seen = kill_when_any_exists(
        proc, [WriterTemporary(series), repo / "logs" / "pi_p885" / "ch3_hysteresis.log"]
    )
    assert seen is not None, "the analysis finished before it could be killed"
    assert capture.exists() and not table.exists()
    assert incomplete_markers(repo)
    half = series if seen.name.endswith(".part") else table
    # a tool that wrote in place would leave this behind; Snakemake's incomplete record must catch it
    half.write_bytes(b"half-written")

    # 3. the rerun (profiles/default sets rerun-incomplete) completes and equals a clean run
    assert run_snakemake(repo, config, "--unlock").returncode == 0
    run = run_snakemake(repo, config, target)
    assert run.returncode == 0, run.stderr[-4000:]
    assert incomplete_markers(repo) == []
    scan_capture(capture)
    read_series(series)
    assert_same_capture(capture, smoke_run / "raw" / "pi_p885" / "ch3_sine_10hz.nc")
    assert table.read_bytes() == (smoke_run / target).read_bytes()
    assert leftovers(repo / "raw") + leftovers(repo / "results") == []


@pytest.mark.slow
def test_resimulating_from_scratch_gives_identical_captures_and_tables(smoke_run, tmp_path):
    repo = copy_repo(tmp_path / "repo")  # no captures, no results: a clean second run
    tables = ["results/pi_p885/ch3/hysteresis.csv", "results/pi_p885/twin/ce_recovery.csv"]
    run = run_snakemake(repo, write_config(repo, "pi", ["pi_p885"]), *tables)
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
    _gap_middle(folder / "ch4_static_free.nc")
    run = run_snakemake(repo, write_config(repo, "k", ["bench_k"]), "--keep-going")
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
