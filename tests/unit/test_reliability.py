"""Reliability: the fault matrix (docs/reliability.md), at the rule-script level.

Users feed the pipeline their own captures and manifests. Whatever goes wrong, the pipeline must
stop with one line naming the file and the problem and leave no partial output, or, where the
analysis can honestly continue (a short NaN burst), continue, mask and count.

These work on small synthetic captures and call the rules' scripts directly; the same matrix
through Snakemake, on measured datasets made from the smoke captures, is in
tests/workflow/test_reliability.py.
"""

import json
import signal
import subprocess
import sys

import netCDF4
import numpy as np
import pytest
import yaml

from selfsense.io.capture import (
    FILL,
    INT16_FULL,
    CaptureError,
    CaptureWriter,
    channel_spec,
    read_series,
)
from selfsense.io.manifest import ManifestError, load_dataset

from ..helpers import (
    FS,
    bench_manifest,
    edit_time,
    gap_in_the_middle,
    leftovers,
    manifest,
    one_line,
    script,
    set_codes,
    synthetic,
    truncate,
)

# -- capture faults, at the rule-script level (fast) ---------------------------------------------


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


CAPTURE_FAULTS = {  # fault: (make it, what the one line must say)
    "truncated file": (truncate, ""),
    "not a netCDF file": (_not_netcdf, "not a readable netCDF4 capture"),
    "wrong units attribute": (_units, "channel U is in 'mV', the manifest declares 'V'"),
    "time axis with a gap": (_gap_end, "gap or wrong fs"),
    "gap inside the time axis": (gap_in_the_middle, "time axis breaks at sample 4000"),
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
    with SeriesWriter(out, {"C_e": "F"}, inputs=[]) as w:
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
    # absent, or the old complete file
    assert (out.read_bytes() if out.exists() else None) == before
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
        pytest.param(
            {"twin": {"instruments": {"adc_bits": 20}}},
            ["key twin.instruments.adc_bits", "20 is greater than the maximum of 16"],
            id="twin value out of bounds",
        ),
    ],
)
def test_bad_manifest_is_one_line_naming_file_and_key(tmp_path, change, fragments):
    path = _manifest_dir(tmp_path, **change)
    with pytest.raises(ManifestError) as e:
        load_dataset(tmp_path, "bench")
    one_line(str(e.value), path, *fragments)
