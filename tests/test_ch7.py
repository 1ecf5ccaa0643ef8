"""Chapter 7 assembly on exact synthetic data, and the thermal stage on the twin."""

import numpy as np
import pytest

from selfsense.chapters import ch7
from selfsense.ripple import SamplingPlan
from selfsense.thermal import ThermalModel, ThermalProperties, predict_temperature

PROPS = ThermalProperties(7800, 350, 740e-9, 640e-6)


def heating_run(P=0.7, tau=105.0, gamma=52.0, T_amb=23.0, seconds=600):
    t = np.arange(0, seconds, 0.1)
    power = np.where(t < 400, P, 0.0)
    T = predict_temperature(t, power, ThermalModel(tau, gamma), T0=T_amb, T_amb=T_amb)
    return {"time": t, "P_PS": power, "T_mid": T + np.random.default_rng(1).normal(0, 0.05, t.size)}


def test_identify_recovers_tau_and_gamma_and_reports_unidentifiable_runs():
    per_run, fits = ch7.identify({"long": heating_run(), "short": heating_run(seconds=2)}, PROPS, T_amb=None)
    row = per_run.set_index("run").loc["long"]
    assert row["tau [s]"] == pytest.approx(105.0, rel=0.02)
    assert row["gamma [K/W]"] == pytest.approx(52.0, rel=0.02)
    assert per_run.set_index("run").loc["short", "note"].startswith("not identifiable")
    assert list(fits) == ["long"]


def test_voltage_trend_is_quadratic_for_a_quadratic_loss():
    t = np.arange(0, 1600, 0.1)
    volts = [25, 50, 75, 100]
    P = np.concatenate([np.full(4000, 1e-4 * v * v) for v in volts])
    table = ch7.voltage_trend({"time": t, "P_PS": P}, [{"duration": 400, "hi": v} for v in volts],
                              ThermalModel(100.0, 50.0))
    assert table["fit R²"].iloc[0] == pytest.approx(1.0)
    assert table["fit slope [K/V²]"].iloc[0] == pytest.approx(50.0 * 1e-4)


def test_extract_is_chunk_invariant_and_measures_hysteresis_power(stack_params, stack_daq):
    from selfsense.twin.bench import Bench, experiment_seed

    fs = stack_daq.fs
    bench = Bench(stack_params, stack_daq, experiment_seed(2, "heat"))
    t = np.arange(int(1.0 * fs)) / fs
    measured, truth = bench.step(t, 50 - 50 * np.cos(2 * np.pi * 100 * t))
    plan = SamplingPlan(1e5, 12, 4, 4)
    k_over_alpha = stack_params.stack.k / stack_params.stack.alpha

    def run(sizes):
        starts = np.cumsum([0] + sizes[:-1])
        chunks = ((s, {k: v[s:s + n] for k, v in measured.items()}) for s, n in zip(starts, sizes))
        parts = list(ch7.extract(chunks, fs, plan, k_over_alpha, 0.1, 200))
        return np.concatenate([p[0]["P_PS"] for p in parts])

    whole = run([len(t)])
    np.testing.assert_allclose(run([10_000, 7, len(t) - 10_007]), whole, rtol=1e-12)
    true_power = np.mean((truth["U_H"] * np.gradient(truth["q"]) * fs)[int(fs) // 2:])
    assert np.mean(whole[5:]) == pytest.approx(true_power, rel=0.2)  # the loss seen through the instruments
