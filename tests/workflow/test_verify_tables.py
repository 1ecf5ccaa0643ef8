"""The twin's verification studies (selfsense.verify) on the smoke DAG: each study's totals are
the numbers of the chapter tables it splits or refits, and the scorecard quotes it. The studies
themselves, on synthetic data, are in tests/unit/ (test_error_budget.py, test_tracking_budget.py,
test_loop_leak.py, test_gamma_truth.py, test_powerloss_truth.py, test_twin_calibration.py)."""

import json

import numpy as np
import pandas as pd
import pytest

from selfsense.io.manifest import load_yaml
from selfsense.scorecard.calibration import load_targets
from selfsense.scorecard.registry import BUDGET_TABLE, LEFT_OUT, parse_registry
from selfsense.verify.error_budget import SOURCES
from selfsense.verify.gamma_truth import DISTANCE, MEASURED, RESIDUAL, SLOPE_T_T
from selfsense.verify.tracking_budget import CLOSED_SOURCES, CONTROLLER_SOURCES, OPEN_SOURCES

from ..helpers import ROOT

REGISTRY = ROOT / "workflow" / "scorecard.yaml"


# -- the observer's error budget (Table 5.4, Chapter 6's ε_OCL) ------------------------------------


@pytest.mark.slow
def test_smoke_budget_totals_are_table_5_4s_errors_and_chapter_6s_observer_errors(smoke_run):
    res = smoke_run / "results/pi_p885"
    budget = pd.read_csv(res / "twin/error_budget.csv")
    columns = [
        f"{s} {stat}"
        for s in SOURCES
        for stat in ("rms [µm]", "max [µm]", "at total max [µm]", "share of mean square")
    ]
    assert {
        "segment",
        "frequency [Hz]",
        "total max error [µm]",
        "cross terms share of mean square",
        *columns,
    } <= set(budget)
    t54 = pd.read_csv(res / "ch5/table_5_4.csv")
    assert sorted(budget["frequency [Hz]"].dropna()) == sorted(t54["frequency [Hz]"])
    # the creep run in its phases as its table counts them; the smoke run's 5 s hold has no steady
    # state
    assert list(budget.loc[budget["run"] == "ch5_creep", "segment"]) == ["transient"]
    creep = pd.read_csv(res / "ch5/creep.csv").set_index("phase")["max error [µm]"]
    assert np.isnan(creep["steady state"])
    # Chapter 6's rows are its tables' ε_OCL: the logged estimate, which the offline chain equals
    # to the audit's margin
    audit = (
        pd.read_csv(res / "ch6/audit.csv").set_index("run")["max |offline − logged| [nm]"] * 1e-3
    )
    t62 = pd.read_csv(res / "ch6/table_6_2.csv").set_index(["profile", "error"])
    t61 = (
        pd.read_csv(res / "ch6/table_6_1.csv")
        .set_index(["error", "statistic"])
        .loc[("e_OCL", "max")]
    )
    closed = budget[budget["run"].str.startswith("ch6_")]
    assert sorted(closed["run"].unique()) == sorted(
        audit.index[audit.index.str.startswith(("ch6_p1_", "ch6_p2"))]
    )
    assert list(closed.loc[closed["run"] == "ch6_p1_closed", "segment"]) == list("abcdefgh")
    for _, row in closed.iterrows():
        if (
            row["run"] == "ch6_p1_closed"
        ):  # P1's tests one after another: each segment's largest max |ε_OCL|
            table = t61[f"{row['segment']} [µm]"]
        else:
            table = t62.loc[("P" + row["run"].split("_")[1][1:], "e_OCL"), "max [µm]"]
        assert abs(row["total max error [µm]"] - table) <= audit[row["run"]] + 1e-9 * table, row[
            "run"
        ]
    p2a = t62.loc[("P2a", "e_OCL")]
    p2_stroke = 100 * p2a["max [µm]"] / p2a["% of stroke"]
    for _, row in budget.iterrows():
        run, stroke = row["run"], p2_stroke
        if not run.startswith("ch6_"):
            stats = json.loads((res / f"observer/{run}.json").read_text())
            # the same chain on the same chunks: equal but for the CSV's 10 significant digits
            table = (
                stats["max error by phase [µm]"][row["segment"]]
                if run == "ch5_creep"
                else stats["max error [µm]"]
            )
            assert row["total max error [µm]"] == pytest.approx(table, rel=1e-9), run
            stroke = stats["stroke [µm]"]
        at_max = sum(row[f"{s} at total max [µm]"] for s in SOURCES)
        assert at_max == pytest.approx(row["total at max [µm]"], rel=1e-8), run
        shares = (
            sum(row[f"{s} share of mean square"] for s in SOURCES)
            + row["cross terms share of mean square"]
        )
        assert shares == pytest.approx(1.0, rel=1e-8)
        assert row["max |sum of sources − total| [µm]"] <= 1e-9 * stroke
    charge = pd.read_csv(res / "twin/charge_budget.csv").set_index("frequency [Hz]")
    table = pd.read_csv(res / "ch5/charge_sensing.csv").set_index("frequency [Hz]")[
        "max error [µm]"
    ]
    assert list(charge.index) == list(table.index)
    # the same series and the same fit: equal but for the CSV's 10 significant digits
    assert charge["total max error [µm]"].to_numpy() == pytest.approx(table.to_numpy(), rel=1e-9)
    assert (charge["max |sum of sources − total| [µm]"] <= 1e-9 * 30).all()
    assert (smoke_run / "figures/pi_p885/fig_5_error_budget.png").exists()
    assert not (
        smoke_run / "results/tokin_nb40/twin/error_budget.csv"
    ).exists()  # no observer runs there
    # the scorecard's note of each number the budget splits names its measured sources
    card = pd.read_csv(res / "scorecard.csv").set_index(["source", "quantity"])
    caused = [
        (e.source, e.quantity)
        for e in parse_registry(load_yaml(REGISTRY))
        if e.cause and e.model == "stack" and e.cause.table == BUDGET_TABLE
    ]
    # Table 5.4, the creep run's phases, P1's ε_OCL (Table 6.1, its σ over the tests, the
    # summary); P2's quote rule loop_leak
    assert len(caused) == 39
    left_out = card.loc[caused, "note"].str.startswith(
        LEFT_OUT
    )  # the smoke run's creep has no steady state
    assert list(card.loc[caused][left_out].index.get_level_values("quantity")) == [
        "HPO error in steady state"
    ]
    assert (
        card.loc[caused][~left_out]["note"]
        .str.contains("Measured cause (twin/error_budget.csv", regex=False)
        .all()
    )
    charged = [
        (e.source, e.quantity)
        for e in parse_registry(load_yaml(REGISTRY))
        if e.cause and e.cause.table == "twin/charge_budget.csv"
    ]
    assert len(charged) == 8
    assert (
        card.loc[charged, "note"]
        .str.contains("at the charge–position error's max", regex=False)
        .all()
    )


# -- the tracking budget (Tables 6.1–6.2) ----------------------------------------------------------


@pytest.mark.slow
def test_smoke_tracking_budget_totals_are_tables_6_1_and_6_2s_errors(smoke_run):
    res = smoke_run / "results/pi_p885"
    budget = pd.read_csv(res / "twin/tracking_budget.csv")
    t61 = pd.read_csv(res / "ch6/table_6_1.csv").set_index(["error", "statistic"])
    t62 = pd.read_csv(res / "ch6/table_6_2.csv").set_index(["profile", "error"])
    assert sorted(budget["run"].unique()) == sorted(
        f"ch6_p{p}_{loop}" for p in ("1", "2a", "2b", "2c", "2d") for loop in ("open", "closed")
    )
    for _, row in budget.iterrows():
        closed = row["run"].endswith("_closed")
        error, sources = ("e_TCL", CLOSED_SOURCES) if closed else ("e_TOL", OPEN_SOURCES)
        if row["run"].startswith("ch6_p1_"):
            table = t61.loc[(error, "max"), f"{row['segment']} [µm]"]
            # Table 6.1's σ is over the tests (the smoke run has 2) of each test's max
            assert row["tests"] == t61.loc[(error, "σ"), "tests"] == 2
            assert row["total max σ over tests [µm]"] == pytest.approx(
                t61.loc[(error, "σ"), f"{row['segment']} [µm]"], rel=1e-9, abs=1e-12
            )
        else:
            table = t62.loc[("P" + row["run"].split("_")[1][1:], error), "max [µm]"]
        # the same 4 kHz means of the same run: equal but for the CSV's 10 significant digits
        assert row["total max error [µm]"] == pytest.approx(table, rel=1e-9), (
            row["run"],
            row["segment"],
        )
        at_max = sum(row[f"{s} at total max [µm]"] for s in sources)
        assert at_max == pytest.approx(row["total at max [µm]"], rel=1e-8)
        assert row["max |sum of sources − total| [µm]"] <= 1e-9 * 30  # a 30 µm stroke
        others = {s for s in OPEN_SOURCES + CLOSED_SOURCES if s not in sources}
        assert row[[f"{s} at total max [µm]" for s in others]].isna().all()
        # the twin's open loop drives U = x_R·k/α with its own α/k: only the drive's hold is left
        if not closed:
            assert abs(row["feedforward at total max [µm]"]) < 0.1
    controller = pd.read_csv(res / "twin/controller_budget.csv")
    assert sorted(controller["run"].unique()) == sorted(
        f"ch6_p{p}_closed" for p in ("1", "2a", "2b", "2c", "2d")
    )
    for _, row in controller[
        controller["run"] != "ch6_p1_closed"
    ].iterrows():  # Table 6.1 has no ε_CCL
        profile = "P" + row["run"].split("_")[1][1:]
        assert row["total max error [µm]"] == pytest.approx(
            t62.loc[(profile, "e_CCL"), "max [µm]"], rel=1e-9
        )
        assert sum(row[f"{s} at total max [µm]"] for s in CONTROLLER_SOURCES) == pytest.approx(
            row["total at max [µm]"], rel=1e-8
        )
    assert not (
        smoke_run / "results/tokin_nb40/twin/tracking_budget.csv"
    ).exists()  # no Chapter 6 there
    card = pd.read_csv(res / "scorecard.csv").set_index(["source", "quantity"])
    caused = [
        (e.source, e.quantity)
        for e in parse_registry(load_yaml(REGISTRY))
        if e.cause and e.cause.table == "twin/tracking_budget.csv"
    ]
    assert (
        len(caused) == 65
    )  # Tables 6.1–6.2's ε_TOL and ε_TCL, Table 6.1's σ of them over the tests, P1's summary
    assert (
        card.loc[caused, "note"]
        .str.contains(r"(?:at|σ over the tests of) the tracking error's max")
        .all()
    )


# -- the closed loop's drive in the ripple channels (Table 6.2) ------------------------------------


@pytest.mark.slow
def test_smoke_study_measures_the_campaigns_capture_and_a_leak_free_one(smoke_run):
    res = smoke_run / "results/pi_p885"
    study = pd.read_csv(res / "twin/loop_leak.csv").set_index("run")
    t62 = pd.read_csv(res / "ch6/table_6_2.csv").set_index(["profile", "error"])
    audit = (
        pd.read_csv(res / "ch6/audit.csv").set_index("run")["max |offline − logged| [nm]"] * 1e-3
    )
    assert sorted(study.index) == [f"ch6_p2{p}_closed" for p in "abcd"]
    for run, row in study.iterrows():
        table = t62.loc[("P" + run.split("_")[1][1:], "e_OCL"), "max [µm]"]
        # the study's budget runs the offline chain, the table reads the logged estimate: the
        # audit's margin
        assert abs(row["max |ε_OCL| [µm], as simulated"] - table) <= audit[run] + 1e-9 * table, run
        assert abs(row["C_e error mean [%], no drive leak"]) < abs(
            row["C_e error mean [%], as simulated"]
        ), run
    assert not (smoke_run / "results/tokin_nb40/twin/loop_leak.csv").exists()
    # Table 6.2's P2 ε_OCL rows, in µm and in % of stroke, quote the study
    card = pd.read_csv(res / "scorecard.csv")
    quoting = card[card["note"].str.contains("Measured (twin/loop_leak.csv", regex=False, na=False)]
    assert sorted(quoting["quantity"]) == sorted(
        f"P2{p}, ε_OCL{unit}" for p in "abcd" for unit in ("", ", % of stroke")
    )


# -- Γ and Γ_T refitted on the truth (Tables 5.2, 7.2, 7.3) ----------------------------------------


@pytest.mark.slow
def test_smoke_refits_with_the_measured_inputs_are_the_pipelines_own(smoke_run):
    """The 'measured' variant is the fit the pipeline made: its distance is curve_vs_thesis's, its
    scatter and g those of Tables 7.2 and 7.3."""
    res = smoke_run / "results/pi_p885"
    for folder, fit in (("ch5", "gamma"), ("ch7", "gamma_t")):
        ours = pd.read_csv(res / folder / f"{fit}_vs_thesis.csv").set_index("fit")
        truth = pd.read_csv(res / "twin" / f"{fit}_truth.csv").set_index("fit")
        for name in ours.index:
            assert truth.loc[name, f"{DISTANCE}, {MEASURED}"] == pytest.approx(
                ours.loc[name, DISTANCE], rel=1e-9
            )
    n5 = truth.loc["thesis order"]
    assert n5[f"{RESIDUAL}, {MEASURED}"] == pytest.approx(
        pd.read_csv(res / "ch7/table_7_2.csv").set_index("model").loc["n=5", "standard error [µm]"],
        rel=1e-9,
    )
    assert n5[f"{SLOPE_T_T}, {MEASURED}"] == pytest.approx(
        pd.read_csv(res / "ch7/table_7_3_coefficients.csv")
        .set_index("coefficient")
        .loc["g", "t Stat"],
        rel=1e-9,
    )


# -- Ronkanen's performance table on the truth -----------------------------------------------------


@pytest.mark.slow
def test_smoke_measured_column_is_the_performance_table(smoke_run):
    res = smoke_run / "results/tokin_nb40"
    truth = pd.read_csv(res / "powerloss/performance_truth.csv")
    table = pd.read_csv(res / "powerloss/performance.csv")
    assert truth["measured"].tolist() == pytest.approx(table["value"].tolist(), rel=1e-12)
    assert not (smoke_run / "results/pi_p885/powerloss/performance_truth.csv").exists()


# -- the twin's calibration table ------------------------------------------------------------------


@pytest.mark.slow
def test_the_smoke_dag_writes_the_calibration_table(smoke_run):
    table = pd.read_csv(smoke_run / "results/pi_p885/twin/calibration.csv").set_index("signature")
    calibration = load_targets(smoke_run / "workflow/twin_calibration.yaml")
    assert list(table.index) == [t.signature for t in calibration.targets]
    results = smoke_run / "results/pi_p885"
    for t in calibration.targets:
        row = table.loc[t.signature]
        if pd.isna(row["twin value"]):  # the smoke runs are too short to identify τ
            assert row["note"].startswith(f"not measured ({t.locate.table}: not computed"), t.id
            continue
        upstream_table = pd.read_csv(results / t.locate.table)
        where = np.ones(len(upstream_table), dtype=bool)
        for key, value in t.locate.where:
            column = upstream_table[key]
            where &= (
                np.isclose(column.astype(float), value)
                if isinstance(value, (int, float))
                else (column.astype(str) == value).to_numpy()
            )
        assert row["twin value"] == pytest.approx(
            upstream_table.loc[where, t.locate.column].iloc[0], rel=1e-9
        )
        assert bool(row["within"]) is t.within(row["twin value"])
    assert not (
        smoke_run / "results/tokin_nb40/twin/calibration.csv"
    ).exists()  # not the thesis's actuator
