"""Faults beyond the first fault matrix (docs/reliability.md): silent wrong results, tracebacks
instead of one line, progress and the failing rule's log, at the capture, manifest and
rule-script level (concurrent runs and --config through Snakemake: tests/workflow/test_faults.py).

Each case either stops with one line naming the file (and key or channel) and leaves no output,
or is shown not to damage anything.
"""

import logging
import subprocess
import sys

import netCDF4
import numpy as np
import pytest
import yaml

from selfsense.io.capture import (
    FILL,
    CaptureError,
    CaptureWriter,
    channel_spec,
    open_capture,
    scan_capture,
)
from selfsense.io.manifest import ManifestError, load_dataset, load_yaml, validate_config
from selfsense.io.provenance import script_logging

from ..helpers import ROOT, bench_manifest, leftovers, manifest, one_line, script, synthetic

# -- packing attributes and all-NaN channels (capture level, fast) -------------------------------


def _packing(attr, value):
    def make(path):
        with netCDF4.Dataset(path, "a") as nc:
            nc["U"].setncattr(attr, value)

    return make


@pytest.mark.parametrize(
    "attr,value,shown",
    [
        (
            "scale_factor",
            -0.006,
            "scale_factor -0.006",
        ),  # silently mirrored U before (Fig 3.12 from −100 to 0 V)
        ("scale_factor", 0.0, "scale_factor 0"),  # a traceback (empty reduction) before
        ("scale_factor", float("nan"), "scale_factor nan"),
        ("add_offset", float("inf"), "add_offset inf"),
    ],
)
def test_packing_attributes_are_checked_on_open(tmp_path, attr, value, shown):
    capture = synthetic(tmp_path / "ch3_sine_10hz.nc")
    _packing(attr, value)(capture)
    report = tmp_path / "qc" / "ch3_sine_10hz.json"
    with pytest.raises(CaptureError) as e:
        script("check_capture").main(str(capture), bench_manifest(tmp_path), str(report))
    one_line(str(e.value), capture, "channel U has", shown, "finite, positive scale")
    assert not report.exists()


def _all_nan(path, channel):
    with netCDF4.Dataset(path, "a") as nc:
        var = nc[channel]
        var.set_auto_maskandscale(False)
        var[:] = np.full(var.shape, FILL, dtype=np.int16)


def test_an_all_nan_channel_passes_qc_but_stops_the_analyses_that_need_it(tmp_path):
    capture = synthetic(tmp_path / "ch3_sine_10hz.nc")
    _all_nan(capture, "Ir")
    qc = scan_capture(capture)  # the capture itself is well formed: QC counts, it does not stop
    assert qc.nan["Ir"] == qc.n_samples
    series = tmp_path / "ripple" / "ch3_sine_10hz.nc"
    with pytest.raises(CaptureError) as e:
        script("extract_ripple").main(str(capture), str(series), 4)
    one_line(str(e.value), capture, "channel Ir is entirely NaN", f"all {qc.n_samples} samples")
    assert not series.exists() and leftovers(tmp_path / "ripple") == []


def test_all_nan_is_judged_per_required_channel_on_whole_reads(tmp_path):
    capture = synthetic(tmp_path / "c.nc")
    _all_nan(capture, "I")
    with open_capture(capture, require=("U", "I")) as cap:
        with pytest.raises(CaptureError, match="channel I is entirely NaN"):
            cap.read(["U", "I"])
        assert np.isnan(cap.read(["I"], 0, 100)["I"]).all()  # a part of it: no verdict
    with open_capture(capture, require=("U",)) as cap:
        assert np.isnan(cap.read(["I"])["I"]).all()  # not required: read as it is


# -- manifests: physical bounds, names, depth (fast) ----------------------------------------------


def _bench(tmp_path, edit):
    folder = tmp_path / "bench"
    folder.mkdir(exist_ok=True)
    doc = manifest("bench", ["ch3_sine_10hz"])
    doc = yaml.safe_load(yaml.safe_dump(doc))
    edit(doc)
    path = folder / "dataset.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _set(*keys, value):
    def edit(doc):
        node = doc
        for k in keys[:-1]:
            node = node[k]
        node[keys[-1]] = value

    return edit


MANIFEST_FAULTS = [  # (edit, fragments of the one line)
    pytest.param(
        _set("actuator", "moving_mass_kg", value=0.0),
        ["key actuator.moving_mass_kg", "less than or equal to"],
        id="moving mass 0",
    ),
    pytest.param(
        _set("actuator", "moving_mass_kg", value=-0.1),
        ["key actuator.moving_mass_kg"],
        id="moving mass < 0",
    ),
    pytest.param(
        _set("actuator", "moving_mass_kg", value=float("nan")),
        ["key actuator.moving_mass_kg", "nan is not a finite"],
        id="moving mass NaN",
    ),
    pytest.param(
        _set("actuator", "layer_thickness_um", value=-55.0),
        ["key actuator.layer_thickness_um"],
        id="negative layer thickness",
    ),
    pytest.param(
        _set("actuator", "dimensions_mm", value=[0, 0, 36]),
        ["key actuator.dimensions_mm.", "less than or equal to the minimum of 0"],
        id="zero dimensions",
    ),
    pytest.param(
        _set("daq", "ranges", "U", value=[0.0, 0.0]),
        ["key daq.ranges.U", "low < high"],
        id="range [0, 0]",
    ),
    pytest.param(
        _set("daq", "ranges", "U", value=[200.0, -200.0]),
        ["key daq.ranges.U", "low < high"],
        id="reversed range",
    ),
    pytest.param(
        _set("daq", "fs", value=float("nan")), ["key daq.fs", "not a finite number"], id="fs NaN"
    ),
    pytest.param(
        _set("daq", "fs", value=float("inf")), ["key daq.fs", "not a finite number"], id="fs inf"
    ),
    pytest.param(
        _set("daq", "ripple", "fr_nominal", value=float("nan")),
        ["key daq.ripple.fr_nominal", "not a finite"],
        id="fr_nominal NaN",
    ),
    pytest.param(
        _set("experiments", value=["ch3-sine-10hz"]),
        ["key experiments", "'ch3-sine-10hz'", "letters, digits"],
        id="experiment name with '-'",
    ),
]


@pytest.mark.parametrize("edit,fragments", MANIFEST_FAULTS)
def test_manifest_physical_bounds_and_names(tmp_path, edit, fragments):
    path = _bench(tmp_path, edit)
    with pytest.raises(ManifestError) as e:
        load_dataset(tmp_path, "bench")
    one_line(str(e.value), path, *fragments)


def test_the_shipped_manifests_pass_the_bounds():
    for name in ("pi_p885", "tokin_nb40"):
        load_dataset(ROOT / "raw", name)


def test_dataset_name_is_matched_whole():
    config = load_yaml(ROOT / "config.yaml") | {"datasets": ["pi_p885\n"]}
    with pytest.raises(ManifestError) as e:
        validate_config(config, "config.yaml")
    one_line(str(e.value), "config.yaml", "dataset name 'pi_p885\\n'")


def test_a_config_fault_set_with_dash_dash_config_is_blamed_on_it():
    config = load_yaml(ROOT / "config.yaml")
    config["ripple"] = {"n_periods": "four"}
    with pytest.raises(ManifestError) as e:
        validate_config(config, "config.yaml", {"ripple": {"n_periods": "four"}})
    one_line(str(e.value), "--config", "key ripple.n_periods")
    with pytest.raises(ManifestError) as e:  # the same fault from the file is the file's
        validate_config(config, "config.yaml", {"campaign": "smoke"})
    one_line(str(e.value), "config.yaml", "key ripple.n_periods")


DEEP = """
import sys
from selfsense.io.manifest import ManifestError, load_yaml
try:
    load_yaml(sys.argv[1])
except ManifestError as err:
    print(err)
"""


@pytest.mark.parametrize("depth", [100_000])
def test_deeply_nested_yaml_is_refused_with_one_line_not_a_crash(tmp_path, depth):
    path = tmp_path / "dataset.yaml"
    path.write_text("name: " + "[" * depth + "]" * depth + "\n")
    run = subprocess.run(
        [sys.executable, "-c", DEEP, str(path)], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, f"exit {run.returncode}: {run.stderr[-500:]}"  # SIGSEGV before: -11
    one_line(run.stdout.strip(), path, "nested deeper than 100 levels")


# -- the failing rule's log, progress (fast) ------------------------------------------------------

FAIL_IN_SCRIPT = """
import sys
from selfsense.io.capture import open_capture
from selfsense.io.provenance import script_logging
script_logging(sys.argv[2])
open_capture(sys.argv[1])
"""


def test_a_failing_scripts_log_holds_its_one_line_reason(tmp_path):
    log = tmp_path / "rule.log"
    run = subprocess.run(
        [sys.executable, "-c", FAIL_IN_SCRIPT, str(tmp_path / "gone.nc"), str(log)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode != 0 and "Traceback" in run.stderr
    assert log.read_text().strip() == f"ERROR {tmp_path / 'gone.nc'}: no such capture"


def test_long_writes_log_progress_while_they_run(tmp_path):
    log = tmp_path / "simulate.log"
    script_logging(log)
    seen = []
    path = tmp_path / "long.nc"
    with CaptureWriter(path, {"fs": 48000.0}, [channel_spec("U", -200, 200)], 20 * 4800) as w:
        for k in range(20):
            w.write({"U": np.zeros(4800)})
            seen.append(log.read_text().count("samples ("))  # what `tail -f` shows at this moment
    logging.getLogger("selfsense").handlers.clear()
    assert seen[1] == 1 and seen[9] == 5 and seen[-1] == 10, seen  # every 10 %, as it goes
    assert "100 % of 96000 samples" in log.read_text()
