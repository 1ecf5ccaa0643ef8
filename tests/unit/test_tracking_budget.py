"""Chapter 6's tracking budget (selfsense.verify.tracking_budget): each source is the term of the
voltage balance it names and the sources add up to the error. On the smoke DAG the totals are
Tables 6.1–6.2's tracking errors: tests/workflow/test_verify_tables.py."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.verify.tracking_budget import (
    CLOSED_SOURCES,
    CONTROLLER_SOURCES,
    OPEN_SOURCES,
    controller_split,
    loop_sensitivity,
    split,
)

from ..tolerances import CLOSED_FORM

ALPHA_OVER_K = 9.36 / 25.1e6  # Table 4.2–4.3's α and k [m/V]


@settings(max_examples=50, deadline=None)
@given(
    st.floats(0, 100),
    st.floats(-5, 5),
    st.floats(-1, 1),
    st.floats(-1e-7, 1e-7),
    st.floats(-1e-7, 1e-7),
)
def test_each_open_loop_source_is_its_term_of_the_voltage_balance(U, U_H, U_c, lag, laser):
    """U = U_P + U_H + U_c (Eq 1.6), x = (α/k)·U_P − lag, x_laser = x + laser: the budget gives each
    term back, and they add up to x_R − x_laser."""
    U_P = U - U_H - U_c
    x = ALPHA_OVER_K * U_P - lag
    x_ref = ALPHA_OVER_K * U + 2e-8  # a feedforward that misses x_R by 20 nm
    run = {"x_ref": np.array([x_ref]), "x_laser": np.array([x + laser])}
    true = {
        "x": np.array([x]),
        "U_P": np.array([U_P]),
        "U_H": np.array([U_H]),
        "U_drive": np.array([U]),
    }
    total, parts = split(run, true, ALPHA_OVER_K, closed=False)
    scale = ALPHA_OVER_K * 100 * CLOSED_FORM
    expected = {
        "feedforward": 2e-8,
        "hysteresis": ALPHA_OVER_K * U_H,
        "creep": ALPHA_OVER_K * U_c,
        "stack dynamics": lag,
        "laser": -laser,
    }
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


OMEGA_C, FS, NS = (
    2 * np.pi * 250,
    48_000.0,
    12,
)  # Chapter 6's crossover, the bench's DAQ and ripple plan


def test_the_loop_sensitivity_is_python_controls_closed_loop_of_the_delayed_integrator():
    """S = 1/(1 + L), L(z) = h[(ns + 1)/2·z⁻¹ + (ns − 1)/2·z⁻²]/(1 − z⁻¹) at the means' rate,
    h = ω_C/fs: the lfilter coefficients against python-control's feedback of that L, to
    rounding."""
    import control as ct
    from scipy.signal import freqz

    h, dt = OMEGA_C / FS, NS / FS
    loop = ct.tf([h * (NS + 1) / 2, h * (NS - 1) / 2], [1, -1, 0], dt)
    S = ct.feedback(ct.tf([1], [1], dt), loop)
    w = 2 * np.pi * np.array([1.0, 10, 50, 125, 250, 1000]) * dt
    _, response = freqz(*loop_sensitivity(OMEGA_C, FS, NS), worN=w)
    assert response == pytest.approx(np.array([complex(S(np.exp(1j * v))) for v in w]), rel=1e-12)
    # well below crossover the Type-I loop leaves ω/ω_C of the reference, its design (Eq 6.3)
    assert abs(response[0]) == pytest.approx(2 * np.pi / OMEGA_C, rel=1e-3)


def _delayed_integral_loop(x_ref, U_H, alpha_over_k):
    """The real-time loop per sample as HPOIntegralController steps it (each sample of a block
    integrates the error of the same sample of the block before), around a stack with hysteresis
    only, x = (α/k)(u − U_H), and a perfect observer."""
    K_I, u, e = OMEGA_C / alpha_over_k, np.zeros(len(x_ref)), np.zeros(len(x_ref))
    start = 0.0
    for b in range(0, len(x_ref), NS):
        steps = K_I / FS * e[b - NS : b] if b else np.zeros(NS)
        u[b : b + NS] = start + np.cumsum(steps)
        start = u[b + NS - 1]
        e[b : b + NS] = x_ref[b : b + NS] - alpha_over_k * (u[b : b + NS] - U_H[b : b + NS])
    return u


@pytest.mark.parametrize("frequency", [10.0, 50.0, 125.0])  # P2a–d's range
def test_the_controller_split_finds_the_loops_lag_and_the_hysteresis_it_rejects(frequency):
    """On the loop simulated per sample, the split's means-rate model leaves a residual ("loop
    model") from the error's change within a block: a ramp of slope s per sample moves a block's
    mean command by h·s·m against the model, m = mean over the block of (i + 1)(ns − 1 − i)/2, so
    |r| ≤ ‖S‖∞·h·m·max|s|, with s = Δε̄/ns between consecutive means (the first-order term; the
    slopes of consecutive blocks partly cancel, so the residual is smaller still). The sources the
    stack does not have are exactly zero, the parts add up to ε_CCL, and the loop lag and the
    hysteresis part are what the same loop does without hysteresis and what the hysteresis adds."""
    from scipy.signal import freqz

    t = np.arange(int(0.2 * FS)) / FS
    x_ref = 15e-6 * (1 - np.cos(2 * np.pi * frequency * t))
    U_H = 1.5e-6 / ALPHA_OVER_K * np.sin(2 * np.pi * frequency * t + 1.0)
    u = _delayed_integral_loop(x_ref, U_H, ALPHA_OVER_K)
    means = {
        name: v.reshape(-1, NS).mean(axis=1)
        for name, v in {"x_ref": x_ref, "u": u, "U_H": U_H, "x": ALPHA_OVER_K * (u - U_H)}.items()
    }
    run = {"x_ref": means["x_ref"], "x_hat": means["x"], "u_cmd": means["u"]}
    true = {
        "x": means["x"],
        "U_P": means["u"] - means["U_H"],
        "U_H": means["U_H"],
        "U_drive": means["u"],
    }
    sensitivity = loop_sensitivity(OMEGA_C, FS, NS)
    total, parts = controller_split(
        run, true, ALPHA_OVER_K, sensitivity, np.ones(len(total := run["x_ref"]), bool)
    )
    assert list(parts) == list(CONTROLLER_SOURCES)
    assert np.abs(sum(parts.values()) - total).max() <= CLOSED_FORM * 30e-6
    for name in ("creep", "stack dynamics", "observer", "drive"):
        assert np.abs(parts[name]).max() <= CLOSED_FORM * 30e-6, name
    m = np.mean([(i + 1) * (NS - 1 - i) / 2 for i in range(NS)])
    peak = np.abs(freqz(*sensitivity, worN=4096)[1]).max()
    steady = slice(len(total) // 4, None)  # after the first blocks' step from rest

    def bound(error):
        return peak * OMEGA_C / FS * m / NS * np.abs(np.diff(error)[steady]).max()

    assert np.abs(parts["loop model"][steady]).max() <= bound(total)
    # against the counterfactual: the same loop around a stack without hysteresis errs by the loop
    # lag alone, and the hysteresis part is what the hysteresis adds (each to its own model bound)
    u_linear = _delayed_integral_loop(x_ref, np.zeros_like(U_H), ALPHA_OVER_K)
    lag = means["x_ref"] - ALPHA_OVER_K * u_linear.reshape(-1, NS).mean(axis=1)
    for name, expected in (("loop lag", lag), ("hysteresis", total - lag)):
        assert np.abs(parts[name] - expected)[steady].max() <= bound(expected), name
