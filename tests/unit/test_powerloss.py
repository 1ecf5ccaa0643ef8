"""Tests for selfsense.methods.powerloss (Ronkanen, Kallio & Koivo, IROS 2002)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.methods import powerloss as pl

from ..tolerances import CLOSED_FORM, rtol

R_PAPER = 21e9

# Bender-like synthetic plant: 300 nA for 40 s reaches ~105 V  ->  C ~ 0.11 uF;
# 5 um/s at 100 nA  ->  a = 50 m/C.
C_SYN = 0.11e-6
A_SYN = 50.0


# ---------------------------------------------------------------------------
# Static hold
# ---------------------------------------------------------------------------
def test_hold_resistance_paper_value():
    assert pl.hold_resistance(105.0, 5e-9) == pytest.approx(21e9, rel=CLOSED_FORM)
    assert pl.hold_resistance(pl.PAPER_HOLD_VOLTAGE, pl.PAPER_HOLD_CURRENT) == pytest.approx(
        pl.PAPER_HOLD_RESISTANCE
    )


def test_hold_resistance_vectorised_and_negative_polarity():
    r = pl.hold_resistance(np.array([105.0, -52.5]), np.array([5e-9, -2.5e-9]))
    np.testing.assert_allclose(r, [21e9, 21e9])


@pytest.mark.parametrize("v,i", [(105.0, 0.0), (105.0, -5e-9)])
def test_hold_resistance_rejects_bad_input(v, i):
    with pytest.raises(ValueError):
        pl.hold_resistance(v, i)


# ---------------------------------------------------------------------------
# Models
# ---------------------------------------------------------------------------
def test_registry_has_equations_7_to_11():
    assert sorted(m.equation for m in pl.IMPEDANCE_MODELS.values()) == [7, 8, 9, 10, 11]
    for m in pl.IMPEDANCE_MODELS.values():
        assert pl.get_impedance_model(m.equation) is m
        assert pl.get_impedance_model(f"({m.equation})") is m
        assert pl.get_impedance_model(m.name) is m
        assert len(m.param_names) == len(m.initial_guess) == len(m.param_units)
    with pytest.raises(KeyError):
        pl.get_impedance_model("nope")


def test_model_formulas_explicit_values():
    R, c, i = 21e9, 3.4e7, 300e-9
    ci = c * i  # 10.2
    assert pl.get_impedance_model(7)(i, R, c) == pytest.approx(R * math.exp(-ci))
    assert pl.get_impedance_model(8)(i, R, c) == pytest.approx(R * 10.0 ** (-ci))
    assert pl.get_impedance_model(8)(i, R, c, b=2.0) == pytest.approx(R * 2.0 ** (-ci))
    assert pl.get_impedance_model(9)(i, R, c) == pytest.approx(R / (ci + 1))
    assert pl.get_impedance_model(10)(i, R, c) == pytest.approx(R / math.sqrt(ci**2 + 1))
    assert pl.get_impedance_model(11)(i, R, 1e14) == pytest.approx(R / (1e14 * i**2 + 1))
    # Eq. (12): the paper's fitted model at 100 nA and 300 nA
    x10 = pl.get_impedance_model(10)
    assert x10(100e-9, R, c) / 1e9 == pytest.approx(5.925, abs=0.001)
    assert x10(300e-9, R, c) / 1e9 == pytest.approx(2.049, abs=0.01)


@pytest.mark.parametrize("name", list(pl.IMPEDANCE_MODELS))
def test_all_models_equal_R_at_zero_current(name):
    m = pl.IMPEDANCE_MODELS[name]
    assert m(0.0, R_PAPER, *m.initial_guess) == pytest.approx(R_PAPER)


# ---------------------------------------------------------------------------
# Fitting: parameter recovery
# ---------------------------------------------------------------------------
TRUE_C = {"exp": 1.2e7, "base_b": 5e6, "abs_linear": 2.6e7, "sqrt": 3.4e7, "quadratic": 2.4e14}


@pytest.mark.parametrize("name", list(pl.IMPEDANCE_MODELS))
def test_fit_recovers_known_parameters(name):
    m = pl.IMPEDANCE_MODELS[name]
    if name == "abs_linear":
        currents = np.linspace(0, 400e-9, 9)  # printed form has a pole at i = -1/c
    else:
        currents = np.linspace(-400e-9, 400e-9, 17)
    x = m(currents, R_PAPER, TRUE_C[name])
    fit = pl.fit_impedance_model(name, currents, x, R_PAPER)
    assert fit.params["c"] == pytest.approx(TRUE_C[name], rel=1e-6)
    assert fit.sse_gohm2 < 1e-12
    assert fit.R == R_PAPER
    np.testing.assert_allclose(fit.predict(currents), x, rtol=1e-6)


def test_fit_with_noise_is_close_but_not_exact():
    rng = np.random.default_rng(0)
    currents = np.linspace(0, 400e-9, 40)
    x = pl.get_impedance_model(10)(currents, R_PAPER, 3.4e7)
    noisy = x * (1 + 0.01 * rng.standard_normal(x.size))
    fit = pl.fit_impedance_model("sqrt", currents, noisy, R_PAPER)
    assert fit.params["c"] == pytest.approx(3.4e7, rel=0.02)
    assert fit.sse > 0


def test_fit_keeps_R_fixed():
    # Data whose zero-current value disagrees with R: R must not move.
    currents = np.array([0.0, 100e-9, 300e-9])
    fit = pl.fit_impedance_model("sqrt", currents, [30e9, 6e9, 2e9], R_PAPER)
    assert fit.predict(0.0) == pytest.approx(R_PAPER)
    assert fit.sse_gohm2 >= (30 - 21) ** 2 - 1e-9


def test_fit_rejects_bad_input():
    with pytest.raises(ValueError):
        pl.fit_impedance_model("sqrt", [0, 1e-7], [21e9], R_PAPER)
    with pytest.raises(ValueError):
        pl.fit_impedance_model("sqrt", [0, 1e-7], [21e9, -1.0], R_PAPER)
    with pytest.raises(ValueError):
        pl.fit_impedance_model("sqrt", [0, 1e-7], [21e9, 6e9], -1.0)


@settings(max_examples=30, deadline=None)
@given(
    name=st.sampled_from(["exp", "abs_linear", "sqrt", "quadratic"]),
    log10_scale=st.floats(-0.7, 0.7),
    R=st.floats(1e9, 1e11),
)
def test_fit_recovery_property(name, log10_scale, R):
    m = pl.IMPEDANCE_MODELS[name]
    base = {"quadratic": 1e14}.get(name, 3e7)
    c_true = base * 10**log10_scale * (10**log10_scale if name == "quadratic" else 1.0)
    currents = np.array([0.0, 50e-9, 100e-9, 200e-9, 300e-9])
    x = m(currents, R, c_true)
    fit = pl.fit_impedance_model(name, currents, x, R)
    assert fit.params["c"] == pytest.approx(c_true, rel=1e-5)


# ---------------------------------------------------------------------------
# Table 2
# ---------------------------------------------------------------------------
def test_paper_fit_points():
    i, x = pl.paper_fit_points()
    np.testing.assert_allclose(i, [0.0, 100e-9, 300e-9])
    np.testing.assert_allclose(x, [21e9, 6e9, 2e9])


def test_table_2_reproduces_paper():
    df = pl.table_2()
    assert isinstance(df, pd.DataFrame)
    for col in ["model", "equation", "parameters", "SSE [GOhm^2]", "best"]:
        assert col in df.columns
    assert len(df) == 5
    best = df.loc[df["best"]]
    assert len(best) == 1
    assert best["equation"].item() == "(10)"
    c = best["c"].item()
    assert pl.PAPER_C_EQ12 / 1.5 < c < pl.PAPER_C_EQ12 * 1.5
    sse = dict(zip(df["equation"], df["SSE [GOhm^2]"]))
    # Same ordering as the paper: (10) < (9) < (11) < (7) = (8)
    assert sse["(10)"] < sse["(9)"] < sse["(11)"] < sse["(7)"]
    # (7) and (8) differ only by the base of the exponential -> identical SSE
    assert sse["(7)"] == pytest.approx(sse["(8)"], rel=1e-8)
    # Paper prints two significant digits; allow for that rounding
    for eq, paper in pl.PAPER_TABLE_2_SSE_GOHM2.items():
        assert sse[f"({eq})"] == pytest.approx(paper, rel=0.05)


def test_table_2_from_explicit_data_mirrored_points():
    # Using +-I as separate points doubles every symmetric model's SSE;
    # model (10) must stay the best and its c must not change.
    i = [0.0, 100e-9, -100e-9, 300e-9, -300e-9]
    x = [21e9, 6e9, 6e9, 2e9, 2e9]
    sym = pl.table_2(i, x, 21e9)
    assert sym.loc[sym["best"], "equation"].item() == "(10)"
    base = pl.table_2()
    c_sym = sym.set_index("equation").loc["(10)", "c"]
    c_base = base.set_index("equation").loc["(10)", "c"]
    assert c_sym == pytest.approx(c_base, rel=1e-6)


def test_table_2_needs_both_arrays():
    with pytest.raises(ValueError):
        pl.table_2([0.0, 1e-7], None)


# ---------------------------------------------------------------------------
# Ramp identification
# ---------------------------------------------------------------------------
def _synthetic_ramp(X, *, I=100e-9, C=C_SYN, a=A_SYN, t_half=60.0, fs=20.0):
    """Exact response of C || X to a +I then -I current ramp (piecewise exponentials).

    Samples sit at (k + 1/2)/fs, so the current reversal at t_half falls midway
    between two samples, where trapezoidal integration of the step is exact.
    Returns time, displacement a*Q, total current, voltage.
    """
    tau = X * C
    t = (np.arange(int(round(2 * t_half * fs))) + 0.5) / fs
    V_inf_up, V_inf_dn = I * X, -I * X
    V_up = V_inf_up * (1 - np.exp(-t / tau))
    V_turn = V_inf_up * (1 - np.exp(-t_half / tau))
    V_dn = V_inf_dn + (V_turn - V_inf_dn) * np.exp(-(t - t_half) / tau)
    up = t < t_half
    V = np.where(up, V_up, V_dn)
    i = np.where(up, I, -I)
    return t, a * C * V, i, V


@pytest.mark.parametrize("X", [2e9, 6e9, 21e9])
def test_impedance_from_ramp_recovers_X_displacement(X):
    t, d, i, V = _synthetic_ramp(X)
    est = pl.impedance_from_ramp(t, d, i, V)
    assert est.impedance == pytest.approx(X, rel=0.01)
    assert est.gain == pytest.approx(A_SYN, rel=0.01)
    assert est.method == "displacement"


def test_impedance_from_ramp_recovers_X_and_C_from_voltage():
    t, _, i, V = _synthetic_ramp(6e9)
    est = pl.impedance_from_ramp(t, None, i, V, method="voltage")
    assert est.impedance == pytest.approx(6e9, rel=0.01)
    assert est.capacitance == pytest.approx(C_SYN, rel=0.01)


def test_impedance_from_ramp_with_measurement_noise():
    rng = np.random.default_rng(1)
    t, d, i, V = _synthetic_ramp(2e9, I=300e-9)
    d_noisy = d + 0.1e-6 * rng.standard_normal(d.size)  # 0.1 um noise
    i_noisy = i * (1 + 0.002 * rng.standard_normal(i.size))
    est = pl.impedance_from_ramp(t, d_noisy, i_noisy, V)
    assert est.impedance == pytest.approx(2e9, rel=0.05)


def test_impedance_from_ramp_lossless_gives_huge_X():
    t = np.linspace(0, 60, 601)
    i = np.full_like(t, 100e-9)
    V = i * t / C_SYN
    est = pl.impedance_from_ramp(t, A_SYN * C_SYN * V, i, V)
    assert est.impedance > 1e14


def test_impedance_from_ramp_input_validation():
    t, d, i, V = _synthetic_ramp(6e9)
    with pytest.raises(ValueError):
        pl.impedance_from_ramp(t, None, i, V)
    with pytest.raises(ValueError):
        pl.impedance_from_ramp(t[::-1], d, i, V)
    with pytest.raises(ValueError):
        pl.impedance_from_ramp(t, d[:-1], i, V)
    with pytest.raises(ValueError):
        pl.impedance_from_ramp(t, d, i, V, method="bogus")


@settings(max_examples=25, deadline=None)
@given(
    log10_X=st.floats(9.0, 10.5),
    I=st.floats(20e-9, 500e-9),
    C=st.floats(0.05e-6, 0.5e-6),
)
def test_impedance_from_ramp_property(log10_X, I, C):
    X = 10**log10_X
    # Ramp long enough that the leaked charge is a visible fraction (>= ~5 %).
    t_half = max(60.0, 0.1 * X * C)
    t, d, i, V = _synthetic_ramp(X, I=I, C=C, t_half=t_half, fs=2000 / t_half)
    est = pl.impedance_from_ramp(t, d, i, V)
    assert est.impedance == pytest.approx(X, rel=0.02)


# ---------------------------------------------------------------------------
# Control principle and compensation
# ---------------------------------------------------------------------------
def test_displacement_and_velocity_inverse():
    t = np.linspace(0, 10, 101)
    i = np.full_like(t, 100e-9)
    d = pl.displacement_from_current(t, i, A_SYN)
    assert d[-1] == pytest.approx(A_SYN * 100e-9 * 10)
    assert pl.current_for_velocity(5e-6, A_SYN) == pytest.approx(100e-9)


def test_compensated_current_zero_voltage_is_identity():
    i_c = np.array([-300e-9, 0.0, 100e-9])
    np.testing.assert_array_equal(pl.compensated_current(i_c, 0.0, R_PAPER, 3.4e7), i_c)


def test_compensated_current_at_rest_adds_static_leakage():
    i_t = pl.compensated_current(0.0, 105.0, R_PAPER, 3.4e7)
    assert i_t == pytest.approx(105.0 / R_PAPER)  # 5 nA, the static hold current
    assert i_t == pytest.approx(5e-9)


def test_compensated_current_numeric_eq15():
    # i_c = 300 nA, V = 105 V: sqrt(10.2^2 + 1) = 10.2489 -> i_l = 51.24 nA
    i_t = pl.compensated_current(300e-9, 105.0, R_PAPER, 3.4e7)
    assert i_t == pytest.approx(300e-9 + 5e-9 * math.sqrt(10.2**2 + 1), rel=CLOSED_FORM)
    assert i_t == pytest.approx(351.24e-9, rel=1e-4)
    # Same as i_c + V / X(i_c) with model (10)
    x = pl.get_impedance_model(10)(300e-9, R_PAPER, 3.4e7)
    assert i_t == pytest.approx(300e-9 + 105.0 / x)


@given(
    i_c=st.floats(-1e-6, 1e-6),
    V=st.floats(-200.0, 200.0),
    R=st.floats(1e8, 1e11),
    c=st.floats(0.0, 1e8),
)
def test_compensation_properties(i_c, V, R, c):
    i_l = pl.leakage_current(i_c, V, R, c)
    # Eq. (15) is i_c + i_l; where they cancel, the sum is good to ε of |i_c| + |i_l| only
    assert pl.compensated_current(i_c, V, R, c) == pytest.approx(
        i_c + i_l, rel=CLOSED_FORM, abs=CLOSED_FORM * (abs(i_c) + abs(i_l)) + 1e-300
    )
    # loss current flows with V and is at least the static leakage V/R
    assert abs(i_l) >= abs(V) / R * (1 - 1e-9)
    if V != 0 and i_l != 0:
        assert math.copysign(1, i_l) == math.copysign(1, V)
    # only the magnitude of the charging current matters for the loss
    assert pl.leakage_current(-i_c, V, R, c) == pytest.approx(pl.leakage_current(i_c, V, R, c))


def test_eq14_feedforward_keeps_charge_on_target():
    """Plant C || X(i) with X from model (10); Eq. (14) should deliver the intended charge."""
    R, c, C = R_PAPER, 3.4e7, C_SYN
    dt = 1e-3
    t = np.arange(0, 80, dt)
    i_c = np.where(t < 40, 300e-9, -300e-9)
    x_true = pl.get_impedance_model(10)(i_c, R, c)

    def simulate(i_t):
        Q = np.zeros_like(t)
        for k in range(t.size - 1):
            Q[k + 1] = Q[k] + dt * (i_t[k] - Q[k] / C / x_true[k])
        return Q

    target = np.concatenate([[0.0], np.cumsum(i_c[:-1] * dt)])
    q_comp = simulate(pl.compensated_current_from_charge(t, i_c, C, R, c))
    q_raw = simulate(i_c)
    peak = np.max(np.abs(target))
    assert np.max(np.abs(q_comp - target)) / peak < 2e-3
    assert np.max(np.abs(q_raw - target)) / peak > 0.05  # without compensation: large loss


# ---------------------------------------------------------------------------
# PID current loop
# ---------------------------------------------------------------------------
def test_pid_step_terms():
    pid = pl.CurrentPID(kp=2.0, ki=10.0, kd=0.5, dt=0.1)
    u, s = pid.step(pl.PIDState(), setpoint=1.0, measurement=0.0)
    assert u == pytest.approx(2.0 + 10.0 * 0.1)  # no derivative kick on the first sample
    u2, s2 = pid.step(s, setpoint=1.0, measurement=0.5)
    # e = 0.5, integral = 0.1 + 0.05, de/dt = -5
    assert u2 == pytest.approx(2.0 * 0.5 + 10.0 * 0.15 + 0.5 * (-5.0))
    assert s2.integral == pytest.approx(0.15)


def test_pid_is_pure_and_clamped():
    pid = pl.CurrentPID(kp=100.0, ki=100.0, kd=0.0, dt=0.1, u_min=-1.0, u_max=1.0)
    s0 = pl.PIDState()
    u, s1 = pid.step(s0, 10.0, 0.0)
    assert u == 1.0
    assert s0 == pl.PIDState()  # not mutated
    assert s1.integral == 0.0  # anti-windup: saturated in the error direction
    with pytest.raises(ValueError):
        pl.CurrentPID(1, 1, 0, dt=0.0)


def test_pid_tracks_current_through_lagging_meter():
    """Amplifier (gain G) into C || R, current meter with a first-order lag.

    The load is capacitive (i = C G du/dt), so integral action acts as a
    proportional current gain K = C G ki and the steady error is r / (1 + K).
    """
    C, R, G = C_SYN, R_PAPER, 10.0
    dt, tau_m = 1e-3, 0.1
    K = 50.0
    pid = pl.CurrentPID(kp=0.0, ki=K / (C * G), kd=0.0, dt=dt)
    r = 100e-9
    state, u_prev, meas = pl.PIDState(), 0.0, 0.0
    for _ in range(int(2.0 / dt)):
        u, state = pid.step(state, r, meas)
        V = G * u
        i_true = C * G * (u - u_prev) / dt + V / R
        meas += dt / tau_m * (i_true - meas)
        u_prev = u
    # Proportional-type tracking: r*K/(1+K) plus the small leakage V/R
    assert meas == pytest.approx(r * K / (1 + K), rel=0.005)
    assert abs(meas - r) < 0.03 * r


# ---------------------------------------------------------------------------
# Static hold from a record, ramp helpers
# ---------------------------------------------------------------------------
def test_hold_from_record_removes_the_residual_charging():
    t = np.linspace(0, 20, 2001)
    # 5.5 nA flows, 0.5 nA of it still charges the actuator (the position creeps up)
    x = 100e-6 + A_SYN * 0.5e-9 * t
    est = pl.hold_from_record(t, np.full_like(t, 105.0), np.full_like(t, 5.5e-9), x, A_SYN)
    # a straight-line fit of exact data (κ = cond of [t, 1]), then 5.5 − 0.5 nA (κ = 1.1); the
    # slope is a creep of 1e-4 of the position it rides on, so it keeps |x|/|Δx| fewer digits
    kappa = np.linalg.cond(np.vander(t, 2)) * 1.1 * np.max(x) / np.ptp(x)
    assert est.R == pytest.approx(21e9, rel=float(rtol(kappa)))
    assert est.R_ohm == pytest.approx(105.0 / 5.5e-9, rel=float(rtol(kappa)))
    assert est.velocity == pytest.approx(A_SYN * 0.5e-9, rel=float(rtol(kappa)))


def test_impedance_from_ramp_segments_absorb_a_lagging_meter():
    """A meter with a 0.5 s lag mis-places tau*dI of charge at each reversal; per-stretch offsets
    remove it."""
    t, d, i, V = _synthetic_ramp(2e9, I=300e-9)
    dt = t[1] - t[0]
    decay = np.exp(-dt / 0.5)
    lagged = np.empty_like(i)
    lagged[0] = i[0]
    for k in range(1, i.size):
        lagged[k] = decay * lagged[k - 1] + (1 - decay) * i[k]
    biased = pl.impedance_from_ramp(t, d, lagged, V)
    fixed = pl.impedance_from_ramp(t, d, lagged, V, segments=pl.constant_stretches(i))
    assert abs(biased.impedance / 2e9 - 1) > 0.02
    assert fixed.impedance == pytest.approx(2e9, rel=0.005)
    with pytest.raises(ValueError):
        pl.impedance_from_ramp(t, d, lagged, V, segments=np.zeros(3))


def test_constant_stretches_and_charging_current():
    np.testing.assert_array_equal(pl.constant_stretches([1, 1, -1, -1, -1, 2]), [0, 0, 1, 1, 1, 2])
    np.testing.assert_allclose(pl.charging_current([300e-9], [100.0], 2e9), [250e-9])


def test_ramp_velocity_and_its_spread():
    t = np.arange(0, 60, 0.01)
    steady = 5e-6 * t
    np.testing.assert_allclose(
        pl.ramp_velocity(t, steady, 2.0), 5e-6, rtol=float(rtol(np.linalg.cond(np.vander(t, 2))))
    )
    command = np.full_like(t, 300e-9)
    assert pl.velocity_spread(t, steady, command, 2.0) < 1e-6
    slowing = 5e-6 * t - 0.02e-6 * t**2  # 5 -> 2.6 um/s
    assert pl.velocity_spread(t, slowing, command, 2.0) > 10.0


# ---------------------------------------------------------------------------
# Positioning performance (Section 7)
# ---------------------------------------------------------------------------
def _triangle(t, period):
    return 4 * np.abs(((t / period + 0.25) % 1) - 0.5) - 1  # starts at 0, rising


def test_turning_points_follow_the_ramps_not_the_noise():
    t = np.linspace(0, 4, 4001)
    y = _triangle(t, 1.0) + 0.01 * np.random.default_rng(0).standard_normal(t.size)
    tp = pl.turning_points(y, 0.2)
    assert tp[0] == 0 and tp[-1] == t.size - 1
    np.testing.assert_allclose(
        t[tp[1:-1]], [0.25, 0.75, 1.25, 1.75, 2.25, 2.75, 3.25, 3.75], atol=0.03
    )
    assert len(pl.turning_points(np.r_[0, 0.1, 0, 0.1, 1.0], 0.5)) == 2  # wiggles below the swing


def test_branch_hysteresis_of_a_known_loop():
    # fine sampling: branch_gap's bin means compare the branches half a sample step apart
    t = np.linspace(0, 3, 60001)
    req = 300e-6 * _triangle(t, 1.0)
    rising = np.diff(req, prepend=-1.0) > 0  # a turning sample ends the branch that reached it
    meas = req + np.where(rising, -4.5e-6, 4.5e-6)  # branches 9 um apart
    expected = 100 * 9e-6 / np.ptp(meas)
    assert pl.branch_hysteresis_percent(req, meas, 30e-6) == pytest.approx(expected, rel=0.01)
    with pytest.raises(ValueError):
        pl.branch_hysteresis_percent(np.linspace(0, 1, 50), np.linspace(0, 1, 50), 0.1)


def test_drift_percent_of_an_exponential_creep():
    t = np.arange(0, 160, 0.01)
    x = np.where(t < 40, 200e-6 * t / 40, 200e-6 * (1 + 0.1 * (1 - np.exp(-(t - 40) / 30))))
    expected = 100 * 0.1 * (1 - np.exp(-119.5 / 30))  # averages centred 0.5 s inside the window
    assert pl.drift_percent(t, x, 40.0, 120.0) == pytest.approx(expected, rel=0.01)


def test_repeatability_finds_every_cycle_midpoint_and_peak_to_peak():
    t = np.arange(0, 1000, 0.1)
    req = 300e-6 * _triangle(t, 100.0)
    meas = req * (1 + 0.005 * t / 1000) + 6e-6 * t / 1000  # ptp grows 0.5 %, midpoint drifts 6 um
    cycles = pl.repeatability(t, req, meas, 30e-6)
    assert list(cycles["cycle"]) == list(range(1, 11))
    drift = cycles["midpoint [m]"].iloc[-1] - cycles["midpoint [m]"].iloc[0]
    assert drift == pytest.approx(6e-6 * 900 / 1000, rel=0.02)
    growth = cycles["peak-to-peak [m]"].iloc[-1] / cycles["peak-to-peak [m]"].iloc[0] - 1
    assert growth == pytest.approx(0.005 * 0.9, rel=0.05)


def test_linear_gain_and_max_error():
    u = np.linspace(-100, 100, 201)
    assert pl.linear_gain(u, 2e-6 * u) == pytest.approx(2e-6)
    req = 1e-6 * u
    assert pl.max_error(req, req + np.r_[np.zeros(200), 7e-6]) == pytest.approx(7e-6)
