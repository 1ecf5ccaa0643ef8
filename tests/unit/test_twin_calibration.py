"""The twin's calibration: targets and their bands, the table rule twin_calibration writes from the
pipeline's tables, the signatures measured on short twin runs (scripts/calibrate_twin.py). The
smoke DAG's calibration table: tests/workflow/test_verify_tables.py."""

import dataclasses
import math
import shutil

import pandas as pd
import pytest

from selfsense.io.manifest import (
    ManifestError,
    expand_protocols,
    load_config,
    load_dataset,
    load_yaml,
)
from selfsense.methods.electromech import geometry_from_actuator
from selfsense.scorecard.calibration import Target, calibration_table, load_targets, parse_targets
from selfsense.scorecard.registry import Locator, applicable, parse_registry
from selfsense.scorecard.scoring import band
from selfsense.twin.experiment import daq_plan
from selfsense.twin.params import TwinParams
from selfsense.verify.signatures import ShortRuns

from ..helpers import ROOT, load_module, script

TARGETS = ROOT / "workflow" / "twin_calibration.yaml"


def target(low=10.0, high=14.0):
    return Target(
        "t",
        "a signature",
        "Table 6.2",
        "about 12",
        12.0,
        "%",
        low,
        high,
        "why",
        Locator("ch6/table_6_2.csv", "% of stroke", (("profile", "P2a"),)),
    )


# --- the band check -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "value, within, distance",
    [
        (12.0, True, 0.0),
        (10.0, True, 0.0),
        (14.0, True, 0.0),  # inside, and both edges count as inside
        (14.0 * (1 + 1e-12), True, 0.0),  # a CSV round trip off an edge is still on it
        (9.0, False, 0.25),
        (16.0, False, 0.5),  # in band widths (4) beyond the nearer edge
    ],
)
def test_band_check(value, within, distance):
    assert target().within(value) is within
    assert target().distance(value) == pytest.approx(distance, abs=1e-9)


def test_a_margin_narrows_the_band_at_both_edges():
    assert target().distance(10.2, margin=0.1) == pytest.approx(0.05)
    assert target().distance(13.8, margin=0.1) == pytest.approx(0.05)
    assert target().distance(12.0, margin=0.1) == 0


# --- the targets file -----------------------------------------------------------------------------


def test_the_targets_file_parses_and_names_every_signature_of_the_issue():
    calibration = load_targets(TARGETS)
    assert [t.id for t in calibration.targets] == [
        "feedforward_error",
        "ce_u_loop",
        "ce_x_loop",
        "re_ce_loop",
        "ripple_phase",
        "stroke",
        "up_top",
        "steady_temperature",
        "tau",
    ]
    assert {
        "hysteresis.v_total",
        "hysteresis.q_sat_min",
        "hysteresis.q_sat_max",
        "hysteresis.R_visc",
        "ripple.phase_deg",
        "ripple.R_slope",
        "ripple.dC_H",
        "ripple.dR_H",
        "thermal.k_T",
    } == set(calibration.free)
    assert all(t.low < t.thesis <= t.high or t.id == "ce_x_loop" for t in calibration.targets)


@pytest.mark.parametrize(
    "edit, message",
    [
        (
            lambda d: d["signatures"][0].update(band=[14, 10]),
            "key signatures.0.band: [14, 10] must be [low, high]",
        ),
        (
            lambda d: d["signatures"][1].update(id=d["signatures"][0]["id"]),
            "signature id 'feedforward_error' is listed twice",
        ),
        (
            lambda d: d["signatures"][0].pop("justification"),
            "'justification' is a required property",
        ),
        (
            lambda d: d["free"].update({"thermal.k_T": [40, 20]}),
            "key free.thermal.k_T: [40, 20] must be [low, high]",
        ),
        (lambda d: d["signatures"][0]["locate"].pop("column"), "'column' is a required property"),
    ],
)
def test_a_bad_targets_file_stops_with_one_line_naming_it(edit, message):
    doc = load_yaml(TARGETS)
    edit(doc)
    with pytest.raises(ManifestError, match="^bad.yaml: ") as err:
        parse_targets(doc, "bad.yaml")
    assert message in str(err.value) and "\n" not in str(err.value)


def test_one_band_per_number():
    """The scorecard registry holds the number each target reads (as calibration,
    test_scorecard_bands.py), with the same published value and band, so calibration.csv and the
    scorecard never disagree; the C_e–x loop's lower edge is the one exception the targets state."""
    registry = applicable(
        parse_registry(load_yaml(ROOT / "workflow" / "scorecard.yaml")), {"model": "stack"}
    )
    by_cell = {e.locate: e for e in registry if e.locate}
    for t in load_targets(TARGETS).targets:
        entry = by_cell[t.locate]
        assert entry.published == t.thesis, entry.quantity
        low, high = band(entry.published, entry)
        assert high == pytest.approx(t.high, rel=1e-4), entry.quantity
        assert (low == pytest.approx(t.low, rel=1e-4)) or (
            t.id == "ce_x_loop" and low == -math.inf
        ), entry.quantity


# --- the table from the pipeline's tables ---------------------------------------------------------


def upstream(results):
    """A results folder with synthetic tables for every target but τ: Table 7.1 is not made, and
    the frequency trend says why it has no numbers (as a smoke campaign's does)."""
    tables = {
        "ch6/table_6_2.csv": pd.DataFrame(
            {"profile": ["P2a", "P2a"], "error": ["e_TOL", "e_TCL"], "% of stroke": [12.0, 4.0]}
        ),
        "ch3/hysteresis.csv": pd.DataFrame(
            {
                "loop": ["C_e–U", "C_e–x_laser", "R_e–C_e"],
                "width along horizontal [% of range]": [18.5, 0.67, 1.64],
            }
        ),
        "ch3/phases.csv": pd.DataFrame(
            {"signal": ["drive", "ripple"], "current leads voltage by [°]": [80.0, 66.5]}
        ),
        "ch5/table_5_4.csv": pd.DataFrame(
            {"frequency [Hz]": [0.01, 0.1], "max stroke [µm]": [34.0, 33.8]}
        ),
        "ch4/table_4_3.csv": pd.DataFrame(
            {"parameter": ["k", "U_P_max"], "no change": [25.0, 85.7]}
        ),
        "ch7/freq_trend.csv": pd.DataFrame(
            {"note": ["not computed: no heating run long enough to identify τ"]}
        ),
    }
    for name, table in tables.items():
        (results / name).parent.mkdir(parents=True, exist_ok=True)
        table.to_csv(results / name, index=False)
    return tables


def test_the_rule_script_reads_the_pipelines_tables(tmp_path):
    results = tmp_path / "results" / "pi_p885"
    upstream(results)
    out = tmp_path / "calibration.csv"
    script("twin_calibration").main(str(TARGETS), str(results), str(out))
    table = pd.read_csv(out).set_index("signature")
    assert (out.parent / "calibration.csv.json").exists()
    rows = {t.id: t.signature for t in load_targets(TARGETS).targets}
    expected = {
        "feedforward_error": (12.0, True),
        "ce_u_loop": (18.5, False),
        "ce_x_loop": (0.67, False),
        "re_ce_loop": (1.64, False),
        "ripple_phase": (66.5, True),
        "stroke": (33.8, True),
        "up_top": (85.7, True),
    }
    for key, (value, within) in expected.items():
        assert table.loc[rows[key], "twin value"] == value
        assert bool(table.loc[rows[key], "within"]) is within, key
    assert (
        table.loc[rows["ce_u_loop"], "source table"]
        == "ch3/hysteresis.csv [loop = C_e–U] width along horizontal [% of range]"
    )
    # a table not made, and a table whose stage says why it has no number: rows that say so
    assert table.loc[rows["tau"], "note"] == "not measured (no ch7/table_7_1.csv)"
    assert table.loc[rows["steady_temperature"], "note"] == (
        "not measured (ch7/freq_trend.csv: not computed: no heating run long enough to identify τ)"
    )
    assert (
        table.loc[[rows["tau"], rows["steady_temperature"]], ["twin value", "within"]]
        .isna()
        .all()
        .all()
    )


def test_a_locator_that_no_longer_fits_its_table_fails():
    tables = {"ch6/table_6_2.csv": pd.DataFrame({"profile": ["P2a"], "max [µm]": [4.7]})}
    with pytest.raises(LookupError, match="ch6/table_6_2.csv has no column '% of stroke'"):
        calibration_table([target()], tables)


# --- the signatures on short runs -----------------------------------------------------------------


@pytest.fixture(scope="module")
def short_runs(tmp_path_factory):
    manifest, config = load_dataset(ROOT / "raw", "pi_p885"), load_config(ROOT / "config.yaml")
    return manifest, ShortRuns(
        daq_plan(manifest),
        expand_protocols(manifest["protocols"], "smoke", ROOT / "workflow/protocols"),
        geometry_from_actuator(manifest["actuator"]),
        manifest["actuator"]["moving_mass_kg"],
        manifest["seed"],
        config["ripple"]["n_periods"],
        config["control"]["omega_c"],
        tmp_path_factory.mktemp("runs"),
    )


def test_the_short_runs_measure_the_stroke_of_a_twin_without_hysteresis(short_runs):
    """With the hysteresis and creep voltages made negligible (U_H ≤ 1 nV, U_c ≈ 0.3 µV) and the
    laser's resolution and drift off, the stroke at 100 V is α/k·100 V: at 0.5 Hz against a 2500 Hz
    mode the dynamic amplification is 1 + 4e-8 (1.5 pm), so what is left is the laser channel's
    16-bit quantisation, one step of its ±100 µm range (3.05 nm). Table 4.3's U_P at the top is
    then the applied 100 V, within the identification's ±2 % (the registry's twin-input band)."""
    manifest, runs = short_runs
    p = TwinParams.from_manifest(manifest["twin"])
    p = dataclasses.replace(
        p,
        hysteresis=dataclasses.replace(p.hysteresis, v_total=1e-9),
        creep=dataclasses.replace(p.creep, C=(1e3, 1e3)),
        instruments=dataclasses.replace(p.instruments, laser_resolution=0.0, laser_drift=0.0),
    )
    tables = runs.tables(p, ["ch5/table_5_4.csv", "ch4/table_4_3.csv"])
    lo, hi = manifest["daq"]["ranges"]["x_laser"]
    step_um = (hi - lo) / 2**16 * 1e6
    stroke = tables["ch5/table_5_4.csv"].set_index("frequency [Hz]").loc[0.1, "max stroke [µm]"]
    assert stroke == pytest.approx(p.stack.alpha / p.stack.k * 100.0 * 1e6, abs=step_um)
    up_top = tables["ch4/table_4_3.csv"].set_index("parameter").loc["U_P_max", "no change"]
    assert up_top == pytest.approx(100.0, rel=0.02)


def test_the_short_runs_give_every_targets_table_and_the_closed_forms(short_runs):
    manifest, runs = short_runs
    p = TwinParams.from_manifest(manifest["twin"])
    calibration = load_targets(TARGETS)
    table = calibration_table(calibration.targets, runs.tables(p)).set_index("signature")
    assert table["twin value"].notna().all()
    tau = table.loc[next(t.signature for t in calibration.targets if t.id == "tau"), "twin value"]
    th = p.thermal
    assert tau == pytest.approx(th.rho * th.c * th.volume / (th.k_T * th.area))  # Eq 7.5
    with pytest.raises(ValueError, match="no short run gives ch6/table_6_1.csv"):
        runs.tables(p, ["ch6/table_6_1.csv"])


# --- the search script ----------------------------------------------------------------------------


def test_the_search_writes_its_values_into_a_manifest_copy(tmp_path):
    raw = tmp_path / "raw"
    shutil.copytree(
        ROOT / "raw" / "pi_p885", raw / "pi_p885", ignore=shutil.ignore_patterns("*.nc")
    )
    path = raw / "pi_p885" / "dataset.yaml"
    # the comment line of a search's values, if the manifest has one
    written = "scripts/calibrate_twin.py"
    before = [line for line in path.read_text().splitlines() if written not in line]
    calibrate = load_module(ROOT / "scripts" / "calibrate_twin.py")
    calibrate.write_manifest(path, {"hysteresis.v_total": 7.36, "thermal.k_T": 27.59})
    calibrate.write_manifest(path, {"hysteresis.v_total": 7.5})  # again: one comment line, not two
    twin = TwinParams.from_manifest(load_dataset(raw, "pi_p885")["twin"])
    assert (twin.hysteresis.v_total, twin.thermal.k_T) == (7.5, 27.59)
    after = path.read_text().splitlines()
    comments = [line for line in after if written in line]
    assert comments == [
        "# twin: hysteresis.v_total found by scripts/calibrate_twin.py against "
        "workflow/twin_calibration.yaml"
    ]
    assert after[after.index("twin:") - 1] == comments[0]
    changed = [
        (a, b) for a, b in zip(before, [line for line in after if line not in comments]) if a != b
    ]
    assert len(changed) == 2 and all(a.split(":")[0] == b.split(":")[0] for a, b in changed)
    assert "# [V]" in next(b for a, b in changed if "v_total" in b)  # the line's own comment stays
    with pytest.raises(ManifestError, match="dataset.yaml: key twin.hysteresis.nothing not found"):
        calibrate.write_manifest(path, {"hysteresis.nothing": 1.0})


def test_the_search_refuses_a_free_parameter_the_twin_lacks():
    calibrate = load_module(ROOT / "scripts" / "calibrate_twin.py")
    params = TwinParams.from_manifest(load_dataset(ROOT / "raw", "pi_p885")["twin"])
    with pytest.raises(ManifestError, match="^targets.yaml: key free.ripple.nothing: not a number"):
        calibrate.check_free({"ripple.nothing": (0, 1)}, params, "targets.yaml")
