"""Chapter 6's tracking budget: each source is the term of the voltage balance it names, the sources
add up to the error, and on the smoke DAG the totals are Tables 6.1–6.2's tracking errors."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.manifest import load_yaml
from selfsense.scorecard import parse_registry
from selfsense.tracking_budget import CLOSED_SOURCES, OPEN_SOURCES, TRUTH_STATES, split

from .conftest import ROOT
from .tolerances import CLOSED_FORM

ALPHA_OVER_K = 9.36 / 25.1e6  # Table 4.2–4.3's α and k [m/V]


@settings(max_examples=50, deadline=None)
@given(st.floats(0, 100), st.floats(-5, 5), st.floats(-1, 1), st.floats(-1e-7, 1e-7), st.floats(-1e-7, 1e-7))
def test_each_open_loop_source_is_its_term_of_the_voltage_balance(U, U_H, U_c, lag, laser):
    """U = U_P + U_H + U_c (Eq 1.6), x = (α/k)·U_P − lag, x_laser = x + laser: the budget gives each
    term back, and they add up to x_R − x_laser."""
    U_P = U - U_H - U_c
    x = ALPHA_OVER_K * U_P - lag
    x_ref = ALPHA_OVER_K * U + 2e-8  # a feedforward that misses x_R by 20 nm
    run = {"x_ref": np.array([x_ref]), "x_laser": np.array([x + laser])}
    true = {"x": np.array([x]), "U_P": np.array([U_P]), "U_H": np.array([U_H]), "U_drive": np.array([U])}
    total, parts = split(run, true, ALPHA_OVER_K, closed=False)
    scale = ALPHA_OVER_K * 100 * CLOSED_FORM
    expected = {"feedforward": 2e-8, "hysteresis": ALPHA_OVER_K * U_H, "creep": ALPHA_OVER_K * U_c,
                "stack dynamics": lag, "laser": -laser}
    assert list(parts) == list(OPEN_SOURCES)
    for name, value in expected.items():
        assert parts[name][0] == pytest.approx(value, abs=scale), name
    assert abs(sum(parts.values())[0] - total[0]) <= scale


def test_a_closed_loop_splits_into_controller_observer_and_laser():
    run = {"x_ref": np.array([10e-6]), "x_laser": np.array([8e-6]), "x_hat": np.array([9.5e-6])}
    total, parts = split(run, {"x": np.array([9e-6])}, ALPHA_OVER_K, closed=True)
    assert list(parts) == list(CLOSED_SOURCES)
    assert [p[0] for p in parts.values()] == pytest.approx([0.5e-6, 0.5e-6, 1e-6], rel=CLOSED_FORM)
    assert total[0] == pytest.approx(2e-6, rel=CLOSED_FORM)


@pytest.mark.slow
def test_smoke_tracking_budget_totals_are_tables_6_1_and_6_2s_errors(smoke_run):
    res = smoke_run / "results/pi_p885"
    budget = pd.read_csv(res / "twin/tracking_budget.csv")
    t61 = pd.read_csv(res / "ch6/table_6_1.csv").set_index(["error", "statistic"])
    t62 = pd.read_csv(res / "ch6/table_6_2.csv").set_index(["profile", "error"])
    assert sorted(budget["run"].unique()) == sorted(f"ch6_p{p}_{loop}" for p in ("1", "2a", "2b", "2c", "2d")
                                                     for loop in ("open", "closed"))
    for _, row in budget.iterrows():
        closed = row["run"].endswith("_closed")
        error, sources = ("e_TCL", CLOSED_SOURCES) if closed else ("e_TOL", OPEN_SOURCES)
        if row["run"].startswith("ch6_p1_"):
            table = t61.loc[(error, "max"), f"{row['segment']} [µm]"]
            # Table 6.1's σ is over the tests (the smoke run has 2) of each test's max
            assert row["tests"] == t61.loc[(error, "σ"), "tests"] == 2
            assert row["total max σ over tests [µm]"] == pytest.approx(t61.loc[(error, "σ"), f"{row['segment']} [µm]"],
                                                                       rel=1e-9, abs=1e-12)
        else:
            table = t62.loc[("P" + row["run"].split("_")[1][1:], error), "max [µm]"]
        # the same 4 kHz means of the same run: equal but for the CSV's 10 significant digits
        assert row["total max error [µm]"] == pytest.approx(table, rel=1e-9), (row["run"], row["segment"])
        at_max = sum(row[f"{s} at total max [µm]"] for s in sources)
        assert at_max == pytest.approx(row["total at max [µm]"], rel=1e-8)
        assert row["max |sum of sources − total| [µm]"] <= 1e-9 * 30  # a 30 µm stroke
        others = {s for s in OPEN_SOURCES + CLOSED_SOURCES if s not in sources}
        assert row[[f"{s} at total max [µm]" for s in others]].isna().all()
        if not closed:  # the twin's open loop drives U = x_R·k/α with its own α/k: only the drive's hold is left
            assert abs(row["feedforward at total max [µm]"]) < 0.1
    assert not (smoke_run / "results/tokin_nb40/twin/tracking_budget.csv").exists()  # no Chapter 6 there
    card = pd.read_csv(res / "scorecard.csv").set_index(["source", "quantity"])
    caused = [(e.source, e.quantity) for e in parse_registry(load_yaml(ROOT / "workflow" / "scorecard.yaml"))
              if e.cause and e.cause.table == "twin/tracking_budget.csv"]
    assert len(caused) == 62  # Tables 6.1–6.2's ε_TOL and ε_TCL, Table 6.1's σ of them over the tests too
    assert card.loc[caused, "note"].str.contains(r"(?:at|σ over the tests of) the tracking error's max").all()
