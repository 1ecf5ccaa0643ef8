"""Chapter 7's temperature budget (selfsense.verify.temperature_budget): each source is its closed
form on a synthetic run, the sources add up to the error, the true heat is the twin's per-sample
sum, and the budget is of the coupled stats' number."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.chapters.ch7 import against_measured
from selfsense.io.capture import CaptureWriter, channel_spec
from selfsense.methods.thermal import ThermalModel
from selfsense.verify.temperature_budget import (
    ESTIMATORS,
    HEAT_STATES,
    SOURCES,
    TRUTH_STATES,
    budget_row,
    capture_temperature_budget,
    split,
    temperature_budget,
    true_heat,
)
from selfsense.verify.truth import Truth

from ..tolerances import CLOSED_FORM, rtol, sums

FS, DECIMATION, INTERVAL = 2400.0, 12, 0.1  # 240 samples, 20 stored truth values per interval
N = int(FS * INTERVAL)
INTERVALS = 60
N_SAMPLES = INTERVALS * N

# a twin whose stack heats with a constant 0.5 W (U_H = 10 V on a charge rising at 50 mA) from 23 °C
# with τ = 2.5 s, γ = 55 K/W; an identified model with τ = 2 s, γ = 50 K/W and T_amb 0.1 K high; a
# thermometer that reads 0.2 K low; estimators whose power is 3 % and 8 % high
P0, U_H, T_AMB = 0.5, 10.0, 23.0
TWIN, MODEL, MODEL_T_AMB = ThermalModel(2.5, 55.0), ThermalModel(2.0, 50.0), 23.1
THERMOMETER = -0.2
POWER_ERROR = {"PS": 0.03, "HPO": 0.08}


def synthetic_truth():
    """States at the stored samples (q from the sample before the first, as the kernel's zero
    state)."""
    t = np.arange(0, N_SAMPLES, DECIMATION) / FS
    q = P0 / U_H * (t + 1 / FS)
    U_P = 50.0 + 30.0 * np.sin(2 * np.pi * 7.0 * t)  # anything: the heat takes U_drive − U_P
    T = T_AMB + TWIN.step_response(t, P0)
    return {"q": q, "U_P": U_P, "U_drive": U_P + U_H, "T": T}


def synthetic_traces():
    t = np.arange(INTERVALS) * INTERVAL
    rise = MODEL.step_response(t, P0)  # the ZOH is exact for a constant power
    traces = {"time": t, "T_mid": T_AMB + TWIN.step_response(t, P0) + THERMOMETER}
    for name, key in ESTIMATORS.items():
        traces[key] = MODEL_T_AMB + (1 + POWER_ERROR[name]) * rise
    return traces


def test_each_source_is_its_closed_form_and_they_add_up():
    states, traces = synthetic_truth(), synthetic_traces()
    P_true = true_heat(
        Truth(states, DECIMATION, N_SAMPLES, names=HEAT_STATES), FS, INTERVAL, INTERVALS
    )
    # the last interval ends past the last stored value (true_heat); its power acts on no trace
    # sample
    np.testing.assert_allclose(P_true[:-1], P0, rtol=sums(N), atol=0)
    t = traces["time"]
    T_true = Truth(states, DECIMATION, N_SAMPLES, names=("T",)).at(np.rint(t * FS))["T"]
    budget = temperature_budget(traces, P_true, T_true, MODEL, MODEL_T_AMB).set_index("estimator")
    assert list(budget.index) == list(ESTIMATORS)
    tol = (
        sums(INTERVALS) * 100.0
    )  # kelvin: sums of the steps, relative to temperatures below 100 °C
    model_part = MODEL_T_AMB + MODEL.step_response(t, P0) - (T_AMB + TWIN.step_response(t, P0))
    for name, row in budget.iterrows():
        power_part = POWER_ERROR[name] * MODEL.step_response(t, P0)
        total = power_part + model_part - THERMOMETER
        k = int(np.argmax(np.abs(total)))
        assert row["time of max [s]"] == t[k]
        assert row["total max error [K]"] == pytest.approx(abs(total[k]), abs=tol)
        assert row["power estimate at max [K]"] == pytest.approx(power_part[k], abs=tol)
        assert row["thermal model at max [K]"] == pytest.approx(model_part[k], abs=tol)
        assert row["thermometer at max [K]"] == pytest.approx(-THERMOMETER, abs=tol)
        assert row["power estimate max [K]"] == pytest.approx(np.max(np.abs(power_part)), abs=tol)
        assert row["thermal model max [K]"] == pytest.approx(np.max(np.abs(model_part)), abs=tol)
        assert row["thermometer rms [K]"] == pytest.approx(-THERMOMETER, abs=tol)
        assert row["total at max [K]"] == pytest.approx(
            sum(row[f"{s} at max [K]"] for s in SOURCES), abs=tol
        )
        assert row["max |sum of sources − total| [K]"] <= tol


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 300))
def test_the_sources_add_up_to_the_error_and_its_max_is_the_coupled_stats(seed, n):
    """Any traces, model temperatures and truth: the parts add up sample by sample, and the total's
    max is the one against_measured (rule coupled) states for each estimator."""
    r = np.random.default_rng(seed)
    T = {k: 23.0 + 40.0 * r.random(n) for k in ("T_SH_PS", "T_SH_HPO", "T_mid", "model", "true")}
    for key in ESTIMATORS.values():
        total, parts = split(T[key], T["T_mid"], T["model"], T["true"])
        assert list(parts) == list(SOURCES)
        np.testing.assert_allclose(
            sum(parts.values()), total, rtol=0, atol=64.0 * CLOSED_FORM
        )  # below 64 °C
    traces = {"time": np.arange(n) * INTERVAL} | {k: T[k] for k in ("T_SH_PS", "T_SH_HPO")}
    _, stats = against_measured(traces, {}, {"time": traces["time"], "T_mid": T["T_mid"]})
    for key in ESTIMATORS.values():
        row = budget_row(traces["time"], *split(T[key], T["T_mid"], T["model"], T["true"]))
        assert row["total max error [K]"] == stats[f"max |{key} − T| [K]"]
        assert row["samples"] == n


def test_the_true_heat_is_the_kernels_per_sample_sum_of_states_cubic_between_stored_samples():
    """U_drive − U_P and q cubic in time: the 4-point cubic rebuilds every sample exactly, so each
    interval's mean is Σ (U_drive − U_P)[n]·(q[n] − q[n−1])·fs / N, whatever the block it is read
    in."""
    n = np.arange(-1, N_SAMPLES)
    s = n / N_SAMPLES
    q = 1e-4 * (1 + 2 * s - 3 * s**2 + 4 * s**3)
    u = 5.0 - 8 * s + 6 * s**2 - 9 * s**3
    stored = slice(1, None, DECIMATION)  # sample 0 on
    truth = Truth(
        {"q": q[stored], "U_P": 1 - u[stored], "U_drive": np.ones_like(u[stored])},
        DECIMATION,
        N_SAMPLES,
        names=HEAT_STATES,
    )
    exact = (u[1:] * np.diff(q) * FS).reshape(INTERVALS, N).mean(axis=1)
    inner = slice(
        1, -1
    )  # the first and last stored values' neighbours are the nearest, not the cubic's
    got = true_heat(truth, FS, INTERVAL, INTERVALS)
    kappa = np.max(np.abs(q)) / np.min(
        np.abs(np.diff(q))
    )  # a step of q is a difference of two values
    np.testing.assert_allclose(got[inner], exact[inner], rtol=rtol(kappa, roundings=N), atol=0)
    assert np.array_equal(true_heat(truth, FS, INTERVAL, INTERVALS, block=7), got)
    with pytest.raises(ValueError, match="need 14640 samples, the capture has 14400"):
        true_heat(truth, FS, INTERVAL, INTERVALS + 1)


def write_capture(path, states):
    with CaptureWriter(
        path,
        {"fs": FS},
        [channel_spec("U", -200.0, 200.0)],
        N_SAMPLES,
        truth=TRUTH_STATES,
        truth_decimation=DECIMATION,
    ) as w:
        w.write({"U": np.zeros(N_SAMPLES)})
        w.write({k: states[k] for k in TRUTH_STATES}, dim="time_truth")
    return path


def test_a_captures_budget_reads_its_truth_and_checks_the_coupled_stats(tmp_path):
    """From a capture file: the same rows as from its /truth's stored (float32) values, with the
    stats' max beside the budget's; stats of another run, or traces off the estimator's grid, stop
    it."""
    states, traces = synthetic_truth(), synthetic_traces()
    path = write_capture(tmp_path / "run.nc", states)
    stored = {k: v.astype(np.float32) for k, v in states.items()}
    P_true = true_heat(
        Truth(stored, DECIMATION, N_SAMPLES, names=HEAT_STATES), FS, INTERVAL, INTERVALS
    )
    T_true = stored["T"][np.arange(INTERVALS) * (N // DECIMATION)].astype(float)
    expected = temperature_budget(traces, P_true, T_true, MODEL, MODEL_T_AMB)
    stats = {
        f"max |{key} − T| [K]": v
        for key, v in zip(ESTIMATORS.values(), expected["total max error [K]"])
    }
    got = capture_temperature_budget(path, traces, MODEL, MODEL_T_AMB, INTERVAL, stats=stats)
    assert got.drop(columns="stats max error [K]").equals(expected)
    assert list(got["stats max error [K]"]) == list(expected["total max error [K]"])
    with pytest.raises(ValueError, match="traces and stats are not of one run"):
        capture_temperature_budget(
            path,
            traces,
            MODEL,
            MODEL_T_AMB,
            INTERVAL,
            stats={k: v + 0.01 for k, v in stats.items()},
        )
    with pytest.raises(ValueError, match="not on the estimator's grid"):
        capture_temperature_budget(
            path, traces | {"time": traces["time"] + 0.05}, MODEL, MODEL_T_AMB, INTERVAL
        )
