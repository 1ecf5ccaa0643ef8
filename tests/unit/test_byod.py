"""Bring your own data (docs/bring-your-own-data.md): a lab's recording imported with `selfsense
import`, analysed by what its channels allow (stage characterise), refused in one line where it
contradicts its manifest; a foreign actuator gets no published numbers, its own reference values
instead. An imported dataset and a measured copy of the smoke bench through the whole DAG are in
tests/workflow/test_byod.py."""

import json

import numpy as np
import pandas as pd
import pytest
import yaml
from scipy.io import savemat

from selfsense.chapters import characterise as ch
from selfsense.chapters.figure_names import loop_pages
from selfsense.cli import main as cli
from selfsense.io.capture import INT16_FULL, CaptureError, open_capture
from selfsense.io.manifest import ManifestError, load_dataset, load_yaml
from selfsense.scorecard.reference_values import KIND, reference_rows
from selfsense.scorecard.registry import PUBLISHED, WITHIN, applicable, parse_registry
from selfsense.scorecard.scoring import scorecard

from ..helpers import (
    LAB_A,
    LAB_B,
    LAB_FS,
    LAB_PHI,
    PAGE_SETTINGS,
    ROOT,
    bench_manifest,
    ellipse,
    imported,
    leftovers,
    one_line,
    script,
    set_codes,
    synthetic,
    write_csv,
)


def characterised(tmp_path, folder, experiment="sine_1hz"):
    """The rules characterise_page and characterise on one capture: its row and its loop figure's
    page."""
    out = tmp_path / folder.name
    out.mkdir()
    table, page, figure = out / "summary.csv", out / "page_01.json", out / "loops_01.png"
    capture = str(folder / f"{experiment}.nc")
    script("characterise_page").main(
        [capture], str(page), str(figure), folder.name, **PAGE_SETTINGS, inputs=[capture]
    )
    script("characterise").main(
        str(folder / "dataset.yaml"),
        [str(page)],
        str(table),
        str(out / "instruments.csv"),
        str(out / "hysteresis_model.csv"),
        inputs=[str(page)],
    )
    return pd.read_csv(table).iloc[0].to_dict(), figure


def test_a_csv_of_u_and_x_gives_stroke_gain_loop_width_and_the_loop_figure(tmp_path):
    folder = imported(
        tmp_path,
        write_csv(tmp_path / "sine.csv"),
        "U=U [V]:V",
        "x_laser=x [um]:um",
        extra=["--time", "t [s]:s"],
    )
    manifest = load_dataset(folder.parent, "lab_stack")  # scaffolded, valid, no model
    assert (
        "model" not in manifest
        and manifest["daq"]["fs"] == LAB_FS
        and manifest["experiments"] == ["sine_1hz"]
    )
    with open_capture(folder / "sine_1hz.nc") as cap:
        assert cap.n == 3 * LAB_FS and "shifted to 0" in cap.attrs["import_note"]
        steps = {c: cap.resolution(c) for c in ("U", "x_laser")}
    row, figure = characterised(tmp_path, folder)
    assert figure.exists() and figure.with_suffix(".pdf").exists()
    # the ellipse's loop: width 100·sin φ % of stroke, gain B·cos φ / A by either definition
    assert abs(row["x–U loop width [% of stroke]"] - 100 * np.sin(LAB_PHI)) < 0.5
    assert (
        abs(row["stroke [µm]"] - 2e6 * LAB_B) <= 2 * steps["x_laser"] * 1e6
    )  # the ADC's steps at the two peaks
    gain = 1e6 * LAB_B * np.cos(LAB_PHI) / LAB_A
    # quantisation of both channels bounds either gain's error: a few steps relative to the
    # amplitudes
    quantisation = 4 * (steps["x_laser"] / LAB_B + steps["U"] / LAB_A)
    assert abs(row["gain (least squares) [µm/V]"] / gain - 1) < quantisation
    assert abs(row["gain (end points) [µm/V]"] / gain - 1) < quantisation
    assert (
        row["nonlinearity vs end-point chord [% of stroke]"] < 0.05
    )  # an ellipse's middle line is straight
    assert np.isnan(row["creep after step [µm]"]) and np.isnan(
        row["dx/dq [µm/µC]"]
    )  # no step, no current


def test_a_mat_file_with_the_same_content_gives_the_same_table(tmp_path):
    t, u, x = ellipse()
    savemat(tmp_path / "sine.mat", {"rec": {"t": t, "data": np.column_stack([u, x * 1e6])}})
    from_mat = imported(
        tmp_path,
        tmp_path / "sine.mat",
        "U=rec.data[1]:V",
        "x_laser=rec.data[2]:um",
        dataset="lab_mat",
        extra=["--fs", str(LAB_FS)],
    )
    from_csv = imported(
        tmp_path,
        write_csv(tmp_path / "sine.csv", t0=0.0),
        "U=2:V",
        "x_laser=3:um",
        dataset="lab_csv",
        extra=["--time", "t [s]:s"],
    )
    rows = [characterised(tmp_path, f)[0] for f in (from_mat, from_csv)]
    pd.testing.assert_frame_equal(*(pd.DataFrame([r]) for r in rows))


def test_nonlinearity_is_the_middle_lines_largest_distance_from_the_end_point_chord():
    # a parabola added to the ellipse bends its middle line by d·(u² − A²) from the chord: d·A² at
    # u = 0
    t, u, x = ellipse()
    d = 2e-6 / LAB_A**2
    out = ch.loop_measures(u, x + d * u**2, ch.rising(u))
    # the chord's ends are means over the last 2 % of the range, where u² is ≈ 2 % short of A²
    assert abs(out["nonlinearity"] / (100 * d * LAB_A**2 / out["stroke"]) - 1) < 0.05
    assert abs(out["loop_width"] - 100 * 2 * LAB_B * np.sin(LAB_PHI) / out["stroke"]) < 0.5


def test_a_held_step_gives_its_creep_and_the_current_its_charge_slope():
    fs, n = 1000.0, 20000
    t = np.arange(n) / fs
    u = np.where(t < 2.0, 0.0, 100.0)
    creep = 1e-6 * (1 - np.exp(-(t - 2.0) / 5.0)) * (t >= 2.0)
    x = 2e-7 * u + creep
    out = ch.creep_after_step(t, u, x, settle_s=0.1, min_hold_s=1.0)
    expected = 1e-6 * (np.exp(-0.1 / 5.0) - np.exp(-(t[-1] - 2.0) / 5.0))
    assert abs(out["creep"] / expected - 1) < 0.01  # the last 1 % of the hold is averaged
    assert out["hold_s"] == pytest.approx(t[-1] - 2.0, abs=2 / fs)
    # q = C·U through the current I = C·dU/dt: the q–U slope is C, dx/dq = gain / C
    u = 50 * np.sin(2 * np.pi * t)
    current, C = 3e-6 * np.gradient(u, 1 / fs), 3e-6
    q = ch.charge(current, fs)
    measures = ch.charge_measures(u, 2e-7 * u, q, ch.rising(u))
    assert (
        abs(measures["capacitance"] / C - 1) < 1e-3
        and abs(measures["dx_dq"] / (2e-7 / C) - 1) < 1e-3
    )


# -- the manifest and the captures must agree (one line each, naming both files) ------------------


def _check(tmp_path, capture, manifest):
    report = tmp_path / "qc" / "report.json"
    with pytest.raises(CaptureError) as e:
        script("check_capture").main(str(capture), manifest, str(report))
    assert not report.exists() and leftovers(tmp_path / "qc") == []
    return str(e.value)


@pytest.mark.parametrize(
    "change,fragments",
    [
        pytest.param(
            {"daq": {"fs": 50000.0}},
            ["fs = 48000 Hz, the manifest declares daq.fs = 50000 Hz"],
            id="fs",
        ),
        pytest.param(
            {"daq": {"channels": ["U", "I", "Ur", "Ir"], "ranges": {}}},
            ["channel x_laser is not declared in the manifest's daq.channels"],
            id="channels",
        ),
        pytest.param(
            {"sensors": {"x_laser": {"type": "laser vibrometer", "units": "um"}}},
            ["channel x_laser is in 'm', the manifest declares 'um'"],
            id="units",
        ),
    ],
)
def test_a_capture_that_contradicts_its_manifest_stops_in_one_line_naming_both(
    tmp_path, change, fragments
):
    capture = synthetic(tmp_path / "raw" / "ch3_sine_10hz.nc")
    doc = load_yaml(bench_manifest(tmp_path))
    for key, value in change.items():
        doc[key] = doc.get(key, {}) | value if isinstance(value, dict) and key == "daq" else value
    manifest = bench_manifest(tmp_path, **doc)
    message = _check(tmp_path, capture, manifest)
    one_line(message, capture, *fragments)
    assert message.endswith(f"({manifest})")


def test_a_missing_attribute_the_analyses_read_stops_in_one_line(tmp_path):
    capture = synthetic(tmp_path / "raw" / "ch3_sine_10hz.nc")
    import netCDF4

    with netCDF4.Dataset(capture, "a") as nc:
        nc.delncattr("warmup_s")
    one_line(
        _check(tmp_path, capture, bench_manifest(tmp_path)),
        capture,
        "global attribute warmup_s is missing",
    )


def test_a_channel_clipped_beyond_1_percent_names_the_channel_and_the_likely_cause(tmp_path):
    capture = synthetic(tmp_path / "raw" / "ch3_sine_10hz.nc")  # 9600 samples
    set_codes(capture, "x_laser", 100, 97, INT16_FULL)  # 1.01 %
    message = _check(tmp_path, capture, bench_manifest(tmp_path))
    one_line(
        message,
        capture,
        "channel x_laser is clipped in 1.01 % of its 9600 samples",
        "daq.ranges.x_laser",
        "too narrow",
        "µm written as m",
    )
    capture = synthetic(tmp_path / "raw" / "ch3_sine_1hz.nc")
    set_codes(capture, "x_laser", 100, 96, INT16_FULL)  # 1.00 %: counted, not refused
    script("check_capture").main(str(capture), bench_manifest(tmp_path), str(tmp_path / "ok.json"))
    assert json.loads((tmp_path / "ok.json").read_text())["clipped"]["x_laser"] == 96


def test_an_import_in_the_wrong_unit_is_refused_before_anything_is_written(tmp_path, capsys):
    folder = imported(
        tmp_path,
        write_csv(tmp_path / "sine.csv"),
        "U=U [V]:V",
        "x_laser=x [um]:um",
        extra=["--time", "t [s]:s"],
    )
    before = (folder / "dataset.yaml").read_text()
    args = [
        "import",
        str(tmp_path / "sine.csv"),
        "--dataset",
        "lab_stack",
        "--experiment",
        "again",
        "--raw-dir",
        str(folder.parent),
        "--time",
        "t [s]:s",
        "--channel",
        "U=U [V]:V",
        "--channel",
        "x_laser=x [um]:m",
    ]
    assert cli(args) == 1
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert (
        line.startswith("selfsense import: ")
        and "channel x_laser is clipped" in line
        and "µm written as m" in line
    )
    assert (folder / "dataset.yaml").read_text() == before and not (folder / "again.nc").exists()
    assert leftovers(folder) == []
    # a capture is never overwritten, and experiment names follow the wildcard's rule
    args[args.index("again")] = "sine_1hz"
    assert cli(args) == 1 and "never overwritten" in capsys.readouterr().err
    args[args.index("sine_1hz")] = "sine-1hz"
    assert (
        cli(args) == 1
        and "experiment name 'sine-1hz' must be letters, digits or '_'" in capsys.readouterr().err
    )


def test_a_hyphenated_experiment_name_in_a_manifest_is_one_line(tmp_path):
    folder = tmp_path / "lab"
    folder.mkdir()
    doc = {
        "name": "lab",
        "description": "x",
        "source": "measured",
        "daq": {"fs": 1000.0, "channels": ["U"], "ranges": {"U": [-10, 10]}},
        "protocols": [],
        "experiments": ["sine-1hz"],
    }
    (folder / "dataset.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(ManifestError) as e:
        load_dataset(tmp_path, "lab")
    one_line(str(e.value), folder / "dataset.yaml", "experiment name 'sine-1hz'")


# -- actuators that are not the thesis's -----------------------------------------------------------

REGISTRY = parse_registry(load_yaml(ROOT / "workflow" / "scorecard.yaml"))


@pytest.mark.parametrize("model", [None, "other"])
def test_a_foreign_actuator_gets_no_published_rows(model):
    manifest = {"name": "lab", "source": "measured"} | ({"model": model} if model else {})
    assert applicable(REGISTRY, manifest) == []
    assert scorecard(REGISTRY, {}, manifest).empty


def test_reference_values_replace_the_published_numbers():
    stack = {"name": "lab", "source": "measured", "model": "stack"}
    assert {e.section for e in applicable(REGISTRY, stack)} == {PUBLISHED}
    reference = {
        "stroke_um": {"value": 30.0, "tolerance_percent": 10, "source": "data sheet"},
        "gain_um_per_V": {
            "value": 0.2,
            "tolerance_percent": 10,
            "source": "data sheet",
            "experiment": "small",
        },
    }
    assert applicable(REGISTRY, stack | {"reference": reference}) == []
    table = pd.DataFrame(
        {
            "experiment": ["small", "full"],
            "stroke [µm]": [10.0, 31.0],
            "gain (least squares) [µm/V]": [0.3, 0.21],
        }
    )
    rows = reference_rows(stack | {"reference": reference}, {"characterise/summary.csv": table})
    assert list(rows["quantity"]) == [
        "stroke (full)",
        "gain x/U (least squares) (small)",
    ]  # default: largest stroke
    assert list(rows["reproduced"]) == [31.0, 0.3] and list(rows["verdict"]) == [
        WITHIN,
        "out of band",
    ]
    assert (rows["kind"] == KIND).all()
    # a dataset logged through a gain heads its columns with it: the same rows are found
    scaled = table.rename(
        columns={
            "stroke [µm]": "stroke [µm; x_disp = 10 × logged (sensitivity)]",
            "gain (least squares) [µm/V]": "gain (least squares) [µm/V; U = 20 × logged (gain)]",
        }
    )
    again = reference_rows(stack | {"reference": reference}, {"characterise/summary.csv": scaled})
    assert list(again["reproduced"]) == [31.0, 0.3]


def test_the_loop_figure_has_six_captures_a_page_in_catalogue_order():
    names = [f"run_{k}" for k in range(31)]
    pages = loop_pages(names)
    assert list(pages) == [
        "01",
        "02",
        "03",
        "04",
        "05",
        "06",
    ]  # 31 captures: 6 pages, the last with one
    assert [len(p) for p in pages.values()] == [6, 6, 6, 6, 6, 1]
    assert [n for p in pages.values() for n in p] == names


def test_a_page_without_loops_says_so():
    from matplotlib import pyplot as plt  # after selfsense.chapters.figures chose Agg

    before = set(plt.get_fignums())
    fig = ch.loop_page([], "lab_stack (1 of 1)")
    assert "no capture records a drive voltage U and a displacement" in [
        t.get_text() for t in fig.axes[0].texts
    ]
    plt.close(fig)
    assert set(plt.get_fignums()) == before
