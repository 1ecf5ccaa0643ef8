"""Γ and Γ_T refitted on the twin's truth (selfsense.verify.gamma_truth): every combination of true
and measured inputs, and a fit on noiseless data that gives the generating relation back. On the
smoke DAG the measured refits are the pipeline's own: tests/workflow/test_verify_tables.py."""

import numpy as np
import pytest

from selfsense.io.manifest import load_yaml
from selfsense.methods.gamma import fit_gamma
from selfsense.scorecard.registry import parse_registry, printed_gamma
from selfsense.verify.gamma_truth import (
    ALL_TRUE,
    DISTANCE,
    INTERACTION,
    MEASURED,
    RESIDUAL,
    curve_rows,
    variants,
)

from ..helpers import ROOT
from ..tolerances import rtol

ENTRIES = parse_registry(load_yaml(ROOT / "workflow" / "scorecard.yaml"))


def test_variants_replace_every_subset_of_the_inputs_by_the_truth():
    measured = {n: np.array([0.0]) for n in ("C_e", "x", "T")}
    true = {n: np.array([1.0]) for n in measured}
    out = variants(measured, true)
    assert len(out) == 8 and list(out)[0] == MEASURED and list(out)[-1] == ALL_TRUE
    assert {n: float(v[0]) for n, v in out["true C_e + T"].items()} == {
        "C_e": 1.0,
        "x": 0.0,
        "T": 1.0,
    }
    assert all(float(v[0]) == 1.0 for v in out[ALL_TRUE].values())


def _stroke_of(printed, stroke, n, rng):
    """C [F] and x [m] along the printed curve's own C range (Table 5.2's fit), dense at the
    ends."""
    from selfsense.methods.gamma import printed_range

    lo, hi = printed_range(printed, stroke)
    return (lo + (hi - lo) * 0.5 * (1 - np.cos(rng.uniform(0, 2 * np.pi, n)))) * 1e-6


def test_the_fit_on_noiseless_data_is_the_relation_it_was_made_with():
    """x = Γ_thesis(C) + 0.5 µm exactly ('all true'): that fit lies 0.5 µm from the printed curve
    everywhere, to the raw power basis's conditioning (GammaPolynomial evaluates it); measured
    inputs with 1 % of C's range and 0.3 µm of noise move the fit, which the 'measured' row shows,
    and leave at least the laser's 0.3 µm as the residual's scatter (less by the estimate's own
    sampling spread, 1/√(2n) relative: 5 of those)."""
    printed, stroke = printed_gamma(ENTRIES, "Table 5.2", [f"b{i}" for i in range(6)])
    rng = np.random.default_rng(1)
    C = _stroke_of(printed, stroke, 4000, rng)
    x = printed.predict(C) + 0.5e-6
    measured = {
        "C_e": C + rng.normal(0, 0.01 * np.ptp(C), C.size),
        "x": x + rng.normal(0, 0.3e-6, C.size),
    }
    rows = curve_rows(
        variants(measured, {"C_e": C, "x": x}), {"thesis order": 5}, printed, stroke
    ).iloc[0]
    kappa = fit_gamma(C, x, 5).condition_number
    assert rows[f"{DISTANCE}, {ALL_TRUE}"] == pytest.approx(0.5, abs=rtol(kappa) * stroke)
    assert rows[f"{DISTANCE}, {MEASURED}"] > 0.5 + 10 * rtol(kappa) * stroke
    assert rows[f"{RESIDUAL}, {ALL_TRUE}"] == pytest.approx(0.0, abs=rtol(kappa) * stroke)
    assert rows[f"{RESIDUAL}, {MEASURED}"] > 0.3 * (1 - 5 / np.sqrt(2 * C.size))


def test_the_interaction_of_a_noiseless_relation_is_its_own():
    """Γ_T with a C·T term of 0.2 µm/(µF·K) on noiseless data: the interaction fit gives it back (to
    the raw basis's conditioning); without it the fitted coefficient is zero to the same bound."""
    printed, stroke = printed_gamma(
        ENTRIES, "Table 7.3", [f"bT{i}" for i in range(6)], "g (temperature coefficient)"
    )
    rng = np.random.default_rng(2)
    C = _stroke_of(printed, stroke, 4000, rng)
    T = 23 + 15 * rng.uniform(0, 1, C.size)
    for g_ct in (0.2, 0.0):
        x = printed.predict(C, T) + g_ct * (C * 1e6) * T * 1e-6
        data = variants({"C_e": C, "x": x, "T": T}, {"C_e": C, "x": x, "T": T})
        row = curve_rows(data, {}, printed, stroke, (23.0,), interaction_order=5).iloc[0]
        kappa = fit_gamma(C, x, 5, temperature=T, interaction=True).condition_number
        assert row[f"{INTERACTION}, {ALL_TRUE}"] == pytest.approx(g_ct, abs=rtol(kappa) * stroke)
