"""End to end: the Ronkanen 2002 stage on the smoke campaign (session DAG of tests/conftest.py)."""

import base64
import json

import pandas as pd
import pytest

from selfsense.io.capture import open_capture
from selfsense.io.manifest import load_dataset
from selfsense.methods import powerloss as pl

pytestmark = pytest.mark.slow

TABLES = ("ramps", "table_1", "identified", "table_2", "performance", "repeatability", "recovery")


def read(run, name):
    return pd.read_csv(run / f"results/tokin_nb40/powerloss/{name}.csv")


def test_every_table_and_figure_is_made_with_provenance(smoke_run):
    for name in TABLES:
        sidecar = json.loads(
            (smoke_run / f"results/tokin_nb40/powerloss/{name}.csv.json").read_text()
        )
        assert sidecar["inputs"] and sidecar["code"]["git_describe"]
    for n in range(2, 12):
        for ext in ("png", "png.json"):  # no PDF: figures.pdf is false in the smoke config
            assert (smoke_run / f"figures/tokin_nb40/fig_ronkanen_{n}.{ext}").exists()


def test_bender_captures_are_clean_and_only_the_bender_runs_the_stage(smoke_run):
    qc = pd.read_csv(smoke_run / "results/tokin_nb40/qc/captures.csv")
    assert len(qc) == 11 and (qc["NaN samples"] == 0).all() and (qc["clipped samples"] == 0).all()
    assert not (smoke_run / "results/pi_p885/powerloss").exists()
    assert not (smoke_run / "results/tokin_nb40/ch3").exists()


def test_table_2_both_ways_picks_model_10(smoke_run):
    table = read(smoke_run, "table_2")
    paper = table[table["source"] == "paper Table 1"].set_index("equation")
    for eq, sse in pl.PAPER_TABLE_2_SSE_GOHM2.items():
        assert paper.loc[f"({eq})", "SSE [GOhm^2]"] == pytest.approx(sse, rel=0.05)
    twin = table[table["source"] == "twin captures"].set_index("equation")
    assert twin["best"].idxmax() == paper["best"].idxmax() == "(10)"
    # the twin is built with the paper's c: recovered within the scorecard's twin-input rule (±2 %)
    assert twin.loc["(10)", "c"] == pytest.approx(twin.loc["(10)", "paper c"], rel=0.02)
    assert (
        twin.loc["(10)", "SSE [GOhm^2]"]
        < twin.loc["(9)", "SSE [GOhm^2]"]
        < twin.loc["(7)", "SSE [GOhm^2]"]
    )


def test_table_1_and_the_hold_are_sane(smoke_run):
    table_1 = read(smoke_run, "table_1").set_index("current [nA]")
    assert sorted(table_1.index.round()) == [100, 300]
    assert (
        table_1.loc[table_1.index.max(), "identified X [GOhm]"]
        < table_1.loc[table_1.index.min(), "identified X [GOhm]"]
    )
    identified = read(smoke_run, "identified").set_index("key")["value"]
    assert 90.0 < identified["V_hold"] < 115.0 and 4e-9 < identified["I_hold"] < 8e-9


def test_parameter_recovery_is_within_its_tolerances(smoke_run):
    recovery = read(smoke_run, "recovery")
    assert len(recovery) == 5 and recovery["within"].all(), recovery.to_string()


def test_current_control_beats_voltage_control(smoke_run):
    perf = read(smoke_run, "performance").set_index(["measure", "control"])
    assert len(perf) == 10 and perf["paper"].notna().sum() == 7
    value = perf["value"]
    for measure in ("hysteresis [%]", "drift over the hold [%]"):
        assert abs(value[measure, "current"]) < abs(value[measure, "voltage"]) / 5
    assert (
        value["decaying-ramp max error [um]", "current"]
        < value["decaying-ramp max error [um]", "voltage"] / 5
    )
    cycles = read(smoke_run, "repeatability")
    assert (
        set(cycles["control"]) == {"current", "voltage"} and (cycles["peak-to-peak [m]"] > 0).all()
    )


#: the Eq 15 runs ({R: identified, c: identified} in workflow/protocols/ronkanen.yaml)
EQ15_RUNS = ("rk_decay_current", "rk_repeat_current", "rk_drift_current")


def job_inputs(run, output):
    """The inputs of the job that made ``output``, as Snakemake recorded them when it ran."""
    record = run / ".snakemake" / "metadata" / base64.urlsafe_b64encode(output.encode()).decode()
    return set(json.loads(record.read_text())["input"])


@pytest.mark.parametrize("experiment", EQ15_RUNS)
def test_eq15_runs_are_compensated_with_the_identified_R_and_c_not_the_twins(smoke_run, experiment):
    """A DAG edge from the identification to the Eq 15 runs: their simulate job reads the
    identified R (the hold's) and c (model (10) on the ramps), and the capture records that it ran
    with them, not with the R and c the twin is built with."""
    folder = "results/tokin_nb40/powerloss"
    capture = f"raw/tokin_nb40/{experiment}.nc"
    assert {f"{folder}/identified.csv", f"{folder}/table_2.csv"} <= job_inputs(smoke_run, capture)
    R = read(smoke_run, "identified").set_index("key").loc["R", "value"]
    table_2 = read(smoke_run, "table_2")
    c = table_2.set_index(["source", "equation"]).loc[("twin captures", "(10)"), "c"]
    with open_capture(smoke_run / capture) as cap:
        assert cap.attrs["compensation"] == "model_10"
        assert float(cap.attrs["compensation_R"]) == R
        assert float(cap.attrs["compensation_c"]) == c
    built = load_dataset(smoke_run / "raw", "tokin_nb40")["twin"]["actuator"]
    assert R != float(built["R"]) and c != float(built["c"])
    # the identification's own captures need no identification: no cycle
    for ramp in ("rk_static_hold", "rk_ramp_300na_2g"):
        assert f"{folder}/identified.csv" not in job_inputs(smoke_run, f"raw/tokin_nb40/{ramp}.nc")
