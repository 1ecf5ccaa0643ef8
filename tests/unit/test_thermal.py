"""Tests for selfsense.methods.thermal (thesis Chapter 7, self-heating)."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from selfsense.methods.thermal import (
    K_T_TABLE_7_1,
    P885_PROPERTIES,
    TABLE_7_1,
    PowerAverager,
    SelfHeatingEstimator,
    ThermalModel,
    ThermalProperties,
    average_power,
    identify_series,
    identify_step,
    k_over_alpha_from_stroke,
    k_T_from_gamma,
    k_T_from_tau,
    linear_fit,
    power_loss,
    predict_temperature,
    steady_state_rise,
    zoh_coefficients,
)

from ..tolerances import CLOSED_FORM, rtol, sums

RHO, C, V, A = 7800.0, 350.0, 740e-9, 640e-6
MODEL_28 = ThermalModel.from_k_T(28.0, P885_PROPERTIES)


# ---------------------------------------------------------------- parameters


def test_tau_gamma_from_properties_with_k_T_28():
    m = ThermalModel.from_k_T(K_T_TABLE_7_1, ThermalProperties(RHO, C, V, A))
    # Eq 7.5 / 7.6 evaluated independently here
    assert m.tau == pytest.approx(RHO * V * C / (28.0 * A), rel=CLOSED_FORM)
    assert m.gamma == pytest.approx(1.0 / (28.0 * A), rel=CLOSED_FORM)
    # thesis rounds these to 100 s and 57 K/W; the physical values are:
    assert m.tau == pytest.approx(112.7, abs=0.05)
    assert m.gamma == pytest.approx(55.80, abs=0.01)
    assert m.implied_heat_capacity == pytest.approx(RHO * C * V, rel=CLOSED_FORM)


def test_k_T_estimates_roundtrip_and_table_7_1_inconsistency():
    est = MODEL_28.k_T_estimates(P885_PROPERTIES)
    assert est.from_tau == pytest.approx(28.0, rel=CLOSED_FORM)
    assert est.from_gamma == pytest.approx(28.0, rel=CLOSED_FORM)
    assert est.relative_mismatch == pytest.approx(0.0, abs=CLOSED_FORM)
    # Table 7.1 (tau = 100 s, gamma = 57 K/W) over-determines k_T inconsistently
    t71 = TABLE_7_1.k_T_estimates(P885_PROPERTIES)
    assert t71.from_tau == pytest.approx(RHO * V * C / (100.0 * A), rel=CLOSED_FORM)  # ~31.6
    assert t71.from_gamma == pytest.approx(1.0 / (57.0 * A), rel=CLOSED_FORM)  # ~27.4
    assert t71.from_tau > 31 and t71.from_gamma < 28
    assert k_T_from_tau(100.0, P885_PROPERTIES) == t71.from_tau
    assert k_T_from_gamma(57.0, P885_PROPERTIES) == t71.from_gamma


def test_k_over_alpha_from_stroke():
    assert k_over_alpha_from_stroke(100.0, 32e-6) == pytest.approx(3.125e6)


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_invalid_parameters_rejected(bad):
    with pytest.raises(ValueError):
        ThermalModel(tau=bad, gamma=1.0)
    with pytest.raises(ValueError):
        ThermalModel(tau=1.0, gamma=bad)
    with pytest.raises(ValueError):
        ThermalProperties(RHO, C, V, bad)


# ---------------------------------------------------------------- prediction


@pytest.mark.parametrize("dt", [0.1, 1.0, 5.0, 30.0])
def test_zoh_coefficients_match_scipy_and_control(dt):
    a, b = zoh_coefficients(MODEL_28, dt)
    num, den, _ = signal.cont2discrete(([MODEL_28.gamma], [MODEL_28.tau, 1.0]), dt, method="zoh")
    # b = γ(1 − e^(−dt/τ)) cancels digits for dt ≪ τ: κ ≈ τ/dt (≈ 1100 at dt = 0.1 s)
    kappa_b = MODEL_28.tau / dt + 1
    assert -den[1] == pytest.approx(a, rel=CLOSED_FORM)
    assert np.ravel(num)[-1] == pytest.approx(b, rel=rtol(kappa_b))
    sysd = control.sample_system(
        control.tf([MODEL_28.gamma], [MODEL_28.tau, 1.0]), dt, method="zoh"
    )
    assert -sysd.den[0][0][1] / sysd.den[0][0][0] == pytest.approx(a, rel=CLOSED_FORM)
    assert sysd.num[0][0][-1] / sysd.den[0][0][0] == pytest.approx(b, rel=rtol(kappa_b))


@pytest.mark.parametrize("dt", [0.1, 5.0, 40.0])
def test_step_matches_analytic_solution_even_on_coarse_grid(dt):
    P, T_amb = 0.8, 23.0
    t = np.arange(0.0, 1000.0, dt)
    T = predict_temperature(t, np.full_like(t, P), MODEL_28, T_amb=T_amb)
    expected = T_amb + MODEL_28.gamma * P * (1.0 - np.exp(-t / MODEL_28.tau))
    # the recursion's roundings (each ≤ ε of ≈ 70 °C) decay as a = e^(−dt/τ): they add up to
    # ε/(1 − a)
    atol = float(rtol(1 / (1 - np.exp(-dt / MODEL_28.tau)))) * 70.0
    np.testing.assert_allclose(T, expected, rtol=0, atol=atol)
    np.testing.assert_allclose(MODEL_28.step_response(t, P), expected - T_amb, atol=atol)
    # an Euler step would be visibly wrong at dt = 40 s; make sure we are not it
    if dt >= 40.0:
        euler = T_amb + MODEL_28.gamma * P * (1 - (1 - dt / MODEL_28.tau) ** np.arange(t.size))
        assert np.max(np.abs(euler - expected)) > 1.0


def test_cooling_from_initial_temperature_and_steady_state():
    t = np.arange(0.0, 600.0, 0.5)
    T = predict_temperature(t, 0.0, MODEL_28, T0=60.0, T_amb=23.0)
    np.testing.assert_allclose(
        T,
        23.0 + 37.0 * np.exp(-t / MODEL_28.tau),
        atol=float(rtol(1 / (1 - np.exp(-0.5 / MODEL_28.tau)))) * 60.0,
    )
    assert MODEL_28.steady_state_rise(1.2) == pytest.approx(1.2 * MODEL_28.gamma)
    t = np.arange(0.0, 5000.0, 1.0)
    assert predict_temperature(t, 1.2, MODEL_28)[-1] - 23.0 == pytest.approx(
        MODEL_28.steady_state_rise(1.2), rel=float(rtol(1 / (1 - np.exp(-1.0 / MODEL_28.tau))))
    )  # 5000 steps of a recursion whose roundings decay as e^(−dt/τ): ε/(1 − a) of the rise


def test_predict_rejects_nonuniform_grid():
    with pytest.raises(ValueError):
        predict_temperature(np.array([0.0, 1.0, 3.0]), 1.0, MODEL_28)


# ---------------------------------------------------------------- power loss


def _sine(f=100.0, fs=48_000.0, cycles=10, U0=50.0, Ua=50.0):
    t = np.arange(int(round(cycles * fs / f))) / fs
    w = 2 * np.pi * f
    return t, U0 + Ua * np.sin(w * t), Ua * w * np.cos(w * t)  # t, U, dU/dt


def test_capacitor_with_linear_position_has_no_loss():
    k_over_alpha, Cp = 2.85e6, 3.1e-6
    _, U, dU = _sine()
    I = Cp * dU
    x = U / k_over_alpha  # x = (alpha/k) U: no hysteresis voltage
    p = power_loss(U, x, I, k_over_alpha)
    assert np.max(np.abs(p)) < CLOSED_FORM * np.max(np.abs(U)) * np.max(
        np.abs(I)
    )  # U − U: roundings only
    # a mis-scaled position leaves a purely capacitive U_H: instantaneous
    # power is non-zero but averages to zero over whole cycles (reactive)
    p2 = power_loss(U, 0.8 * x, I, k_over_alpha)
    assert np.max(np.abs(p2)) > 1.0
    assert abs(p2.mean()) < 1e-6 * np.max(np.abs(p2))


def test_resistive_hysteresis_voltage_dissipates_R_Irms2():
    k_over_alpha, Cp, R = 2.85e6, 3.1e-6, 20.0
    _, U_P, dU = _sine()
    I = Cp * dU
    U = U_P + R * I  # hysteresis voltage in phase with current
    p = power_loss(U, U_P / k_over_alpha, I, k_over_alpha)
    # p = (U − U_P)·I: U − U_P cancels |U|/|R·I| of its digits, then n-term means
    kappa = np.max(np.abs(U)) / np.max(np.abs(R * I))
    assert p.mean() == pytest.approx(R * np.mean(I**2), rel=sums(U.size) * kappa)
    assert p.mean() > 0


@settings(max_examples=200, deadline=None)
@given(
    n=st.integers(0, 3000),
    n_per=st.integers(1, 97),
    cuts=st.lists(st.integers(0, 3000), max_size=12),
    seed=st.integers(0, 2**31 - 1),
)
def test_power_averager_is_chunk_invariant(n, n_per, cuts, seed):
    fs = 1000.0
    p = np.random.default_rng(seed).normal(size=n) * 10.0 + 3.0
    ref = PowerAverager(fs, n_per / fs)
    whole = ref.update(p)
    m = n // n_per
    np.testing.assert_allclose(
        whole, p[: m * n_per].reshape(m, n_per).mean(axis=1), rtol=sums(n_per)
    )

    avg = PowerAverager(fs, n_per / fs)
    edges = [0, *sorted(c for c in cuts if c <= n), n]
    pieces = [avg.update(p[a:b]) for a, b in zip(edges[:-1], edges[1:])]
    assert avg.pending < n_per  # memory stays bounded by one block
    np.testing.assert_array_equal(np.concatenate(pieces), whole)
    tail = avg.flush()
    if n % n_per:
        np.testing.assert_allclose(tail, [p[m * n_per :].mean()], rtol=sums(n_per))
    else:
        assert tail.size == 0
    assert avg.n_emitted == m + (1 if n % n_per else 0)


def test_power_averager_rejects_fractional_block():
    with pytest.raises(ValueError):
        PowerAverager(48_000.0, 0.10001)
    assert PowerAverager(48_000.0, 0.1).n_per_interval == 4800


def test_average_power_times():
    t, P = average_power(np.arange(10.0), fs=10.0, interval=0.3, t0=5.0)
    np.testing.assert_allclose(t, [5.0, 5.3, 5.6])
    np.testing.assert_allclose(P, [1.0, 4.0, 7.0])


# ------------------------------------------------- end-to-end (Eq 7.12) stream


def test_self_heating_stream_equals_batch_and_is_chunk_invariant():
    fs, f, k_over_alpha, Cp, R = 4800.0, 150.0, 2.85e6, 3.1e-6, 15.0
    t = np.arange(int(fs * 20.0)) / fs
    w = 2 * np.pi * f
    U_P = 50 + 50 * np.sin(w * t)
    I = Cp * 50 * w * np.cos(w * t)
    U = U_P + R * I
    x = U_P / k_over_alpha
    model = ThermalModel(tau=5.0, gamma=50.0)  # fast model so heating is visible

    out = SelfHeatingEstimator(fs, model, k_over_alpha, interval=0.1).run(U, x, I, chunk_size=777)
    tt, P = average_power(power_loss(U, x, I, k_over_alpha), fs, 0.1)
    np.testing.assert_allclose(out.t, tt)
    # chunked vs whole: means of 480 samples whose loss term cancels |U|/|R·I| of its digits; the
    # temperature recursion then carries ε/(1 − a) of its size
    kappa = np.max(np.abs(U)) / np.max(np.abs(R * I))
    np.testing.assert_allclose(out.P, P, rtol=sums(480) * kappa)
    t_tol = float(rtol(1 / (1 - np.exp(-0.1 / model.tau)))) * np.max(np.abs(out.T))
    np.testing.assert_allclose(out.T, predict_temperature(tt, P, model), rtol=0, atol=t_tol)
    assert out.T[-1] > 23.0 + 0.9 * model.gamma * R * np.mean(I**2) * (1 - np.exp(-19.9 / 5.0))

    big = SelfHeatingEstimator(fs, model, k_over_alpha, interval=0.1).run(U, x, I, chunk_size=10**7)
    np.testing.assert_allclose(big.T, out.T, rtol=0, atol=t_tol)

    est = SelfHeatingEstimator(fs, model, k_over_alpha, interval=0.1)
    est.update(U, x, I)
    # the state after the last complete interval is the next ZOH step
    a, b = zoh_coefficients(model, 0.1)
    assert est.temperature == pytest.approx(
        23.0 + a * (out.T[-1] - 23.0) + b * out.P[-1], abs=t_tol
    )


# ------------------------------------------------------------ identification


@pytest.mark.parametrize("P", [0.2, 0.5, 1.0, 1.2])
@pytest.mark.parametrize("fit_ambient", [False, True])
def test_identify_step_recovers_tau_gamma_from_noisy_step(P, fit_ambient):
    rng = np.random.default_rng(int(P * 1000) + fit_ambient)
    t = np.arange(0.0, 800.0, 0.1)
    T_amb = 23.4
    T = T_amb + MODEL_28.step_response(t, P) + rng.normal(scale=0.1, size=t.size)
    fit = identify_step(t, T, P, T_amb=None if fit_ambient else T_amb)
    assert fit.tau == pytest.approx(MODEL_28.tau, rel=0.01)
    assert fit.gamma == pytest.approx(MODEL_28.gamma, rel=0.01)
    assert fit.T_amb == pytest.approx(T_amb, abs=0.05)
    assert fit.k_T_from_tau == pytest.approx(28.0, rel=0.01)
    assert fit.k_T_from_gamma == pytest.approx(28.0, rel=0.01)
    assert fit.r_squared > 0.99
    assert 0.2 < fit.residual_max < 0.6  # ~4-5 sigma of 0.1 K noise
    assert fit.rmse == pytest.approx(0.1, rel=0.1)
    assert abs(fit.tau - MODEL_28.tau) < 5 * fit.tau_stderr + 1e-9


def test_identify_step_with_pre_step_samples_and_warm_start():
    t = np.arange(0.0, 900.0, 0.5)
    ts, T_amb, T0 = 50.0, 22.0, 30.0
    rel = np.maximum(t - ts, 0.0)
    e = np.exp(-rel / MODEL_28.tau)
    T = np.where(t < ts, T0, T_amb + (T0 - T_amb) * e + MODEL_28.gamma * 0.6 * (1 - e))
    fit = identify_step(t, T, 0.6, t_step=ts, T_amb=T_amb, T0="free")
    assert fit.tau == pytest.approx(MODEL_28.tau, rel=1e-6)
    assert fit.gamma == pytest.approx(MODEL_28.gamma, rel=1e-6)
    assert fit.T0 == pytest.approx(T0, abs=1e-6)


def test_identify_step_refuses_unidentifiable_problem():
    t = np.arange(0.0, 600.0, 1.0)
    T = 23.0 + MODEL_28.step_response(t, 1.0)
    with pytest.raises(ValueError, match="identifiable"):
        identify_step(t, T, 1.0, T_amb=None, T0="free")


def test_identify_series_recovers_tau_gamma_from_staircase():
    rng = np.random.default_rng(7)
    dt = 0.5
    t = np.arange(0.0, 3000.0, dt)
    # several power levels, heating and cooling (like the mixed runs, Fig 7.12)
    levels = [(0, 0.2), (500, 0.6), (1000, 1.2), (1700, 0.4), (2300, 0.0)]
    P = np.zeros_like(t)
    for start, level in levels:
        P[t >= start] = level
    T_amb, T0 = 24.0, 27.0
    T_true = predict_temperature(t, P, MODEL_28, T0=T0, T_amb=T_amb)
    T = T_true + rng.normal(scale=0.15, size=t.size)
    fit = identify_series(t, T, P, T_amb=None, T0="free")
    assert fit.tau == pytest.approx(MODEL_28.tau, rel=0.01)
    assert fit.gamma == pytest.approx(MODEL_28.gamma, rel=0.01)
    assert fit.T_amb == pytest.approx(T_amb, abs=0.1)
    assert fit.T0 == pytest.approx(T0, abs=0.2)
    assert fit.r_squared > 0.999
    np.testing.assert_allclose(fit.fitted, predict_temperature(t, P, fit.model, fit.T0, fit.T_amb))
    # noise-free data: essentially exact
    exact = identify_series(t, T_true, P, T0="free")
    assert exact.tau == pytest.approx(MODEL_28.tau, rel=1e-6)
    assert exact.gamma == pytest.approx(MODEL_28.gamma, rel=1e-6)
    assert exact.residual_max < 1e-6


def test_steady_state_rise_extrapolates_unfinished_record():
    # 400 s runs (thesis Sec 7.2) are only ~3.5 tau: last sample is short
    t = np.arange(0.0, 400.0, 0.2)
    rise = MODEL_28.steady_state_rise(1.0)
    T = 23.0 + MODEL_28.step_response(t, 1.0)
    assert (rise - (T[-1] - 23.0)) / rise > 0.02
    assert steady_state_rise(t, T) == pytest.approx(rise, rel=1e-6)
    assert steady_state_rise(t, T, T_amb=23.0) == pytest.approx(rise, rel=1e-6)


# ------------------------------------------------------------ linear trends


def test_linear_fit_exact_data():
    f = np.array([20.0, 50.0, 100.0, 150.0])
    fit = linear_fit(f, 0.35 * f - 4.0)
    assert fit.slope == pytest.approx(0.35, rel=CLOSED_FORM)
    assert fit.intercept == pytest.approx(-4.0, rel=CLOSED_FORM)
    assert fit.r_squared == pytest.approx(1.0, abs=CLOSED_FORM)
    assert fit.n == 4
    np.testing.assert_allclose(fit(f), 0.35 * f - 4.0)
    V = np.array([25.0, 50.0, 75.0, 100.0])
    fv = linear_fit(V**2, 6e-3 * V**2)
    assert fv.slope == pytest.approx(6e-3, rel=CLOSED_FORM)
    # an intercept of 0 is judged against the data's size (≤ 60): least squares leaves cond·ε of it
    assert fv.intercept == pytest.approx(
        0.0, abs=float(rtol(np.linalg.cond(np.vander(V**2, 2)))) * 60.0
    )


def test_linear_fit_noisy_r2_below_one():
    rng = np.random.default_rng(1)
    x = np.linspace(0, 10, 50)
    y = 2 * x + 3 * rng.normal(size=x.size)
    fit = linear_fit(x, y)
    resid = y - fit(x)
    assert fit.r_squared == pytest.approx(
        1 - resid @ resid / np.sum((y - y.mean()) ** 2), rel=CLOSED_FORM
    )
    assert 0.5 < fit.r_squared < 0.95
    assert fit.slope == pytest.approx(2.0, abs=5 * fit.slope_stderr)
