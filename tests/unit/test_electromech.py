"""Chapter 4 identification on exact synthetic data: what goes in must come out."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.methods.electromech import (
    Geometry,
    Kinematics,
    ModelParameters,
    alpha_from_slope,
    capacitance_line,
    fit_charge_position,
    identify_set,
    material_properties,
    sensitivity,
    slope_is_consistent,
)

FS = 4000.0
TRUE = ModelParameters(2, 3.13e-6, -0.03, 25.1e6, 9.36, 160.0, 0.1017)
GEOMETRY = Geometry(4.95e-3 * 4.67e-3, 55e-6, 32e-3)


def synthetic(p=TRUE, f=10.0, cycles=5, I0=1e-3, q0=2e-6):
    t = np.arange(int(cycles / f * FS)) / FS
    w = 2 * np.pi * f
    x = 16e-6 * (1 - np.cos(w * t))
    kin = Kinematics(t, x, 16e-6 * w * np.sin(w * t), 16e-6 * w * w * np.cos(w * t))
    q = p.charge(kin) + q0 + I0 * t
    C_e = p.capacitance(x)
    I = np.gradient(q, t)
    return t, C_e, x, q, I


@settings(max_examples=20, deadline=None)
@given(
    k=st.floats(10e6, 40e6),
    alpha=st.floats(5, 15),
    dC=st.floats(-0.05, -0.01),
    f=st.sampled_from([10.0, 50.0]),
)
def test_case_2_recovers_k_alpha_and_capacitance(k, alpha, dC, f):
    p = ModelParameters(2, 3.0e-6, dC, k, alpha, 0.0, 0.0)
    t, C_e, x, q, I = synthetic(p, f)
    fit = identify_set(t, C_e, x, q, I, k_static=20e6, m=0.0)
    # positions are re-smoothed for the derivatives: agreement to 1e-4, not to rounding
    assert fit.case2.k == pytest.approx(k, rel=1e-4)
    assert fit.case2.alpha == pytest.approx(alpha, rel=1e-4)
    assert fit.case2.dC_x == pytest.approx(dC, rel=1e-4)
    assert fit.charge_quadratic.I0 == pytest.approx(1e-3, rel=1e-4)
    assert fit.alpha_from_current == pytest.approx(alpha, rel=0.02)


def test_damping_is_found_when_the_motion_is_dynamic():
    t, C_e, x, q, I = synthetic(f=100.0)
    fit = identify_set(t, C_e, x, q, I, k_static=25e6, m=TRUE.m)
    assert fit.case2.b == pytest.approx(TRUE.b, rel=0.05)


def test_offset_drift_is_separated_from_the_charge():
    t, C_e, x, q, _ = synthetic(ModelParameters(2, 3.13e-6, -0.03, 25.1e6, 9.36, 0.0, 0.0), I0=5e-3)
    fit = fit_charge_position(t, x, q, quadratic=True)
    assert fit.I0 == pytest.approx(5e-3, rel=1e-8) and fit.rms_residual < 1e-12


def test_capacitance_line():
    x = np.linspace(0, 32e-6, 100)
    assert capacitance_line(3.13e-6 - 0.03 * x, x) == pytest.approx((3.13e-6, -0.03))


def test_case_1_alpha_from_the_slope():
    C_P, k, alpha = 3.13e-6, 11.2e6, 12.0
    slope = C_P * k / alpha + alpha
    assert alpha_from_slope(slope, C_P, k) == pytest.approx(alpha)
    assert slope_is_consistent(slope, C_P, k)
    assert not slope_is_consistent(5.0, C_P, 25e6)
    assert alpha_from_slope(5.0, C_P, 25e6) == pytest.approx(2.5)


def test_material_properties_of_the_thesis_parameters():
    mp = material_properties(
        ModelParameters(2, 3.13e-6, -0.03, 25.1e6, 9.36, 0, 0), GEOMETRY, 32e-6
    )
    assert mp.C_T == pytest.approx(3.13e-6 + 9.36**2 / 25.1e6)
    assert mp.k33 == pytest.approx(0.72, abs=0.01)  # Table 4.3
    assert mp.d33 == pytest.approx(9.36 * 55e-6 / (32e-3 * 25.1e6))
    assert mp.U_P_max == pytest.approx(32e-6 * 25.1e6 / 9.36)


def test_sensitivity_follows_eq_4_18():
    t, C_e, x, q, I = synthetic()
    fit = identify_set(t, C_e, x, q, I, k_static=25e6, m=0.0)
    table = sensitivity(
        fit.charge_quadratic,
        TRUE.C_P0,
        TRUE.dC_x,
        GEOMETRY,
        32e-6,
        {"none": (1, 1), "C": (1.2, 1), "dC": (1, 1.2)},
    )
    # +20 % C_P0 keeps k/α and lowers α; +20 % ΔCx lowers k/α by 1.2 and raises α
    assert table["C"]["k"] / table["C"]["alpha"] == pytest.approx(
        table["none"]["k"] / table["none"]["alpha"]
    )
    assert table["C"]["alpha"] < table["none"]["alpha"] < table["dC"]["alpha"]
    assert table["dC"]["k"] / table["dC"]["alpha"] == pytest.approx(
        table["none"]["k"] / table["none"]["alpha"] / 1.2
    )


def test_the_u_h_share_is_held_to_the_peak_of_the_twins_hysteresis_voltage_over_the_peak_drive():
    import pandas as pd

    from selfsense.verify.recovery import hysteresis_share_recovery

    t = np.linspace(0, 1, 4001)
    states = {
        "U_drive": 50 - 50 * np.cos(2 * np.pi * 10 * t),
        "U_H": 8 * np.sin(2 * np.pi * 10 * t - 0.3) + 2,
    }
    identified = pd.DataFrame(
        {
            "frequency [Hz]": [10.0, 10.0, 100.0],
            "case": [1, 2, 2],
            "U_H share of max U [%]": [12.0, 5.0, 30.0],
        }
    )
    rows = hysteresis_share_recovery(identified, states, 10.0).set_index("case")
    assert list(rows.index) == [1, 2]
    assert rows["truth"].tolist() == pytest.approx(
        [10.0, 10.0], rel=1e-5
    )  # (8 + 2) V of a 100 V peak
    assert rows.loc[2, "error [%]"] == pytest.approx(-50.0, rel=1e-4)


def test_model_on_truth_is_the_built_set_where_eq_4_4_holds_and_reads_a_domain_share_as_slope():
    """rule model_recovery's "model on truth": Case 2 on the twin's noiseless states over the
    ripple's windows. With C_e = C_P0 + ΔCx·x it is the built set; a domain share d·u_H with u_H =
    β·x + (a loop term orthogonal to x over whole cycles) is read as the slope ΔCx + d·β, and α
    through k/α = 2a₂/ΔCx (Eq 4.18) as a₁ − C_P0·(k/α)·ΔCx/(ΔCx + d·β): the pseudo-true values."""
    from selfsense.chapters.ch4 import identify_sets
    from selfsense.verify.recovery import truth_series
    from selfsense.verify.truth import Truth

    fs, block, f = 48000.0, 12, 10.0
    p = ModelParameters(2, 3.13e-6, -0.03, 25.1e6, 9.36, 0.0, 0.0)
    t = np.arange(int(5 / f * fs)) / fs
    w = 2 * np.pi * f
    x = 16e-6 * (1 - np.cos(w * t))
    q = p.charge(Kinematics(t, x, 16e-6 * w * np.sin(w * t), 16e-6 * w * w * np.cos(w * t)))
    last = np.arange(block - 1, len(t), block)
    noisy = np.random.default_rng(1).normal(size=len(last))  # what the ripple measured: replaced
    series = {
        "time": (last - (block - 1) / 2) / fs,
        "C_e": 3e-6 + 1e-9 * noisy,
        "x_laser": 1e-6 * noisy,
        "q": noisy,
        "I": noisy,
    }
    d, beta = -1.6e-9, 2e5  # [F/V], [V/m]
    identified = {}
    for share in (0.0, d):
        C_e = p.capacitance(x) + share * (beta * x + 4.0 * np.sin(w * t))
        truth = Truth({"C_e": C_e, "x": x, "q": q}, 1, len(t), names=("C_e", "x", "q"))
        per_set, _ = identify_sets(
            {"ch4_sine_10hz_s1": truth_series(series, truth, fs, block)}, 20e6, 0.0, GEOMETRY
        )
        identified[share] = per_set[per_set["case"] == 2].iloc[0]
    assert identified[0.0]["dC_x"] == pytest.approx(p.dC_x, rel=1e-4)
    assert identified[0.0]["alpha"] == pytest.approx(p.alpha, rel=1e-3)
    assert identified[0.0]["k"] == pytest.approx(p.k, rel=1e-3)
    slope = p.dC_x + d * beta
    assert identified[d]["dC_x"] == pytest.approx(slope, rel=1e-4)
    a1 = p.C_P0 * p.k_over_alpha + p.alpha
    assert identified[d]["alpha"] == pytest.approx(
        a1 - p.C_P0 * p.k_over_alpha * p.dC_x / slope, rel=1e-3
    )
