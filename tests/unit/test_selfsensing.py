"""The self-sensing chain on the twin, and Chapter 5's table logic."""

import numpy as np
import pandas as pd
import pytest

from selfsense.chapters.ch5 import (
    charge_estimate_figure,
    choose_order,
    creep_errors,
    creep_phases,
    run_observer,
    table_5_3,
)
from selfsense.methods.gamma import GammaPolynomial, fit_gamma
from selfsense.methods.observer import HPOGains
from selfsense.methods.ripple import SamplingPlan, extract_impedance
from selfsense.methods.selfsensing import SelfSensingChain
from selfsense.twin.bench import Bench, experiment_seed

PLAN = SamplingPlan(1e5, 12, 4, 4)
FS = PLAN.fs


@pytest.fixture(scope="module")
def bench_run(stack_params, stack_daq):
    """4 s warm-up at 0 V, then 1 Hz at 100 V for 2 s, on the twin (1 mA probe offset)."""
    bench = Bench(stack_params, stack_daq, experiment_seed(5, "chain"))
    t = np.arange(int(6.0 * FS)) / FS
    U = np.where(t < 4.0, 0.0, 50 - 50 * np.cos(2 * np.pi * (t - 4.0)))
    measured, truth = bench.step(t, U)
    blocks = extract_impedance(measured["Ur"], measured["Ir"], PLAN)
    x_at = np.interp(blocks.sample_index - 23.5, np.arange(len(t)), measured["x_laser"])
    gamma = GammaPolynomial.from_fit(fit_gamma(blocks.C_e[::4], x_at[::4], 3))
    return t, measured, gamma


def run_chain(measured, gamma, sizes, a0=16.4):
    chain = SelfSensingChain(PLAN, gamma, HPOGains(a0), FS)
    out, start = [], 0
    for size in sizes:
        sl = slice(start, start + size)
        out.append(chain.process(measured["Ur"][sl], measured["Ir"][sl], measured["I"][sl]))
        start += size
    return {k: np.concatenate([o[k] for o in out]) for k in out[0]}, chain


def test_chain_tracks_the_laser_after_warm_up(bench_run):
    t, measured, gamma = bench_run
    out, _ = run_chain(measured, gamma, [len(t)])
    after = t >= 4.0
    err = np.abs(out["x_hat"][after] - measured["x_laser"][after])
    assert err.max() < 1.5e-6  # µm-level over a 33 µm stroke
    assert out["i0_hat"][after].mean() == pytest.approx(1e-3, rel=0.3)  # learned the probe offset


def test_chain_is_chunk_invariant(bench_run):
    t, measured, gamma = bench_run
    whole, _ = run_chain(measured, gamma, [len(t)])
    parts, _ = run_chain(measured, gamma, [1000, 7, 50_000] + [len(t) - 51_007])
    np.testing.assert_array_equal(whole["x_hat"], parts["x_hat"])


def test_the_creep_tables_phases_count_every_sample_not_the_figures_traces(bench_run):
    """Each phase's max is over all its samples (the traces keep one in 48): the two phases split
    the error after the warm-up, so the larger of their maxima is the run's, and each is at least
    the traces' max over the same times."""
    t, measured, gamma = bench_run
    chunks = [
        (s, {k: measured[k][s : s + 40_000] for k in ("Ur", "Ir", "I", "x_laser")})
        for s in range(0, len(t), 40_000)
    ]
    stats, traces = run_observer(
        iter(chunks), PLAN, gamma, HPOGains(16.4), FS, 4.0, phases=creep_phases(4.0, 0.5)
    )
    phases = stats["max error by phase [µm]"]
    assert max(phases.values()) == stats["max error [µm]"]
    err = np.abs(traces["x_hat"] - traces["x_laser"]) * 1e6
    for label, begin, end in creep_phases(4.0, 0.5):
        assert phases[label] >= err[(traces["time"] >= begin) & (traces["time"] < end)].max()
    table = creep_errors(stats, traces, 4.0).set_index("phase")
    assert table.loc["steady state", "max error [% of stroke]"] == pytest.approx(
        100 * phases["steady state"] / stats["stroke [µm]"]
    )


def test_nan_burst_is_masked_and_counted(bench_run):
    t, measured, gamma = bench_run
    hurt = dict(measured)
    hurt["Ur"] = measured["Ur"].copy()
    hurt["Ur"][200_000:200_050] = np.nan
    out, chain = run_chain(hurt, gamma, [len(t)])
    assert np.all(np.isfinite(out["x_hat"]))
    assert 4 <= chain.masked_windows <= 9  # every window touching the 50 NaN samples


def test_order_choice_stops_where_adjusted_r2_stops_rising():
    table = pd.DataFrame(
        {
            "model": ["j=3", "j=4", "j=5", "j=6", "ln"],
            "adjusted R²": [0.99881, 0.99886, 0.99889, 0.998890001, 0.997],
        }
    )
    assert choose_order(table) == 5


def test_table_5_3_applies_eq_5_9_and_flags_the_slip():
    t = table_5_3(17.0, 2 * np.pi, 1.0).set_index("parameter")
    assert t.loc["L_P", "reproduced"] == pytest.approx(213.628, rel=1e-4)
    assert t.loc["L_I", "reproduced"] == pytest.approx(671.13, rel=1e-4)
    assert t.loc["L_I", "thesis Table 5.3"] == 641


def test_fig_5_4_charge_estimate_drifts_with_the_offset_and_its_compensation_is_exact():
    # q = a0·x + q0 + I0·t exactly: the raw q/a0 drifts by I0·T/a0, the compensated estimate is x
    a0, I0, q0 = 17.0, 2e-6, 3e-6
    t = np.arange(0, 1, 1e-4)
    x = 15e-6 * (1 - np.cos(2 * np.pi * 10 * t))
    fig = charge_estimate_figure({"time": t, "x_laser": x, "q": a0 * x + q0 + I0 * t}, a0)
    laser, raw, compensated = (line.get_ydata() for line in fig.axes[0].lines)
    error = fig.axes[1].lines[0].get_ydata()
    assert np.max(np.abs(error)) < 1e-6  # µm
    np.testing.assert_allclose(compensated, laser, atol=1e-6)
    assert raw[-1] - laser[-1] == pytest.approx(I0 * t[-1] / a0 * 1e6, rel=1e-6)
