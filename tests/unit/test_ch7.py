"""Chapter 7 assembly on exact synthetic data, and the thermal stage on the twin."""

import numpy as np
import pytest

from selfsense.chapters import ch7
from selfsense.io.capture import open_capture
from selfsense.methods.gamma import GammaPolynomial
from selfsense.methods.ripple import SamplingPlan
from selfsense.methods.thermal import ThermalModel, ThermalProperties, predict_temperature

from ..helpers import synthetic
from ..tolerances import sums

PROPS = ThermalProperties(7800, 350, 740e-9, 640e-6)


def heating_run(P=0.7, tau=105.0, gamma=52.0, T_amb=23.0, seconds=600):
    t = np.arange(0, seconds, 0.1)
    power = np.where(t < 400, P, 0.0)
    T = predict_temperature(t, power, ThermalModel(tau, gamma), T0=T_amb, T_amb=T_amb)
    return {"time": t, "P_PS": power, "T_mid": T + np.random.default_rng(1).normal(0, 0.05, t.size)}


def test_identify_recovers_tau_and_gamma_and_reports_unidentifiable_runs():
    per_run, fits = ch7.identify(
        {"long": heating_run(), "short": heating_run(seconds=2)}, PROPS, T_amb=None
    )
    row = per_run.set_index("run").loc["long"]
    assert row["tau [s]"] == pytest.approx(105.0, rel=0.02)
    assert row["gamma [K/W]"] == pytest.approx(52.0, rel=0.02)
    assert per_run.set_index("run").loc["short", "note"].startswith("not identifiable")
    assert list(fits) == ["long"]


def test_the_thermal_model_from_the_heating_runs_alone_predicts_a_run_it_did_not_see():
    runs = {
        f"r{f}": heating_run(P=P) | {"U_max": 100.0, "x_max": 3.5e-5}
        for f, P in ((50, 0.5), (100, 0.7))
    }
    tables, record, built = ch7.thermal_identification(runs, {"r50": 50, "r100": 100}, PROPS, 3e6)
    assert record["tau"] == pytest.approx(105.0, rel=0.02)
    assert record["gamma"] == pytest.approx(52.0, rel=0.02)
    assert set(built) == set(ch7.THERMAL_FIGURES)
    t = np.arange(0, 1600, 0.1)
    P = np.concatenate([np.full(4000, 1e-4 * v * v) for v in (25, 50, 75, 100)])
    volt = {"time": t, "P_PS": P}
    # powers it was not identified at, one figure each
    unseen = {"check": heating_run(P=0.9, seconds=900), "mixed": heating_run(P=0.3)}
    checks, figs = ch7.thermal_checks(
        volt, [{"duration": 400, "hi": v} for v in (25, 50, 75, 100)], unseen, record
    )
    # the thermometer's noise alone: its largest of 9000 draws of σ 0.05 K is about 4σ, where a γ
    # 1 % off would add 0.46 K over the check's 46 K rise
    assert (checks["prediction"]["max |T_SH(PS) − T| [K]"] < 6 * 0.05).all()
    assert checks["volt_trend"]["fit R²"].iloc[0] == pytest.approx(1.0)
    assert set(figs) == set(ch7.CHECK_FIGURES)


def test_checks_without_a_thermal_model_say_why_in_each_table_and_figure():
    short = {"r50": heating_run(seconds=2)}
    tables, record, _ = ch7.thermal_identification(short, {"r50": 50}, PROPS, 3e6)
    assert not record["identified"]
    checks, figs = ch7.thermal_checks({}, [], {"check": heating_run()}, record)
    for table in (tables["table_7_1"], checks["volt_trend"], checks["prediction"]):
        assert table["note"].iloc[0] == f"not computed: {record['reason']}"
    assert set(figs) == set(ch7.CHECK_FIGURES)


def test_voltage_trend_is_quadratic_for_a_quadratic_loss():
    t = np.arange(0, 1600, 0.1)
    volts = [25, 50, 75, 100]
    P = np.concatenate([np.full(4000, 1e-4 * v * v) for v in volts])
    table = ch7.voltage_trend(
        {"time": t, "P_PS": P},
        [{"duration": 400, "hi": v} for v in volts],
        ThermalModel(100.0, 50.0),
    )
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
        chunks = (
            (s, {k: v[s : s + n] for k, v in measured.items()}) for s, n in zip(starts, sizes)
        )
        parts = list(ch7.extract(chunks, fs, plan, k_over_alpha, 0.1, 200))
        return np.concatenate([p[0]["P_PS"] for p in parts])

    whole = run([len(t)])
    # means of 4800 samples per 0.1 s, summed in other chunks; U − (k/α)x cancels |U|/|U_H| of the
    # digits
    kappa = np.max(np.abs(measured["U"])) / np.max(np.abs(truth["U_H"]))
    np.testing.assert_allclose(run([10_000, 7, len(t) - 10_007]), whole, rtol=sums(4800) * kappa)
    true_power = np.mean((truth["U_H"] * np.gradient(truth["q"]) * fs)[int(fs) // 2 :])
    assert np.mean(whole[5:]) == pytest.approx(
        true_power, rel=0.2
    )  # the loss seen through the instruments


@pytest.mark.parametrize("period", [20, 40, 80, 133.3, 200, 400, 1000, 4000, 40_000])
def test_gamma_t_samples_see_every_phase_of_any_drive(period):
    """One window kept per group of 200, at every phase of a drive of any period (in windows): the
    widest gap between the kept phases stays within a few times the even spread's 1/n (the
    three-distance theorem bounds {k·φ}'s gaps by ≈ 2.6/n; 4/n leaves room for the stride's own
    residues), where a fixed stride kept two phases of a 50 Hz drive (80 windows) and one of
    100 Hz."""
    every, groups = 200, 5000
    window = np.arange(groups * every)
    kept = window[ch7.kept_windows(window, every)]
    assert np.array_equal(kept // every, np.arange(groups))  # one per group: the stride's count
    phases = np.sort(np.mod(kept, period) / period)
    gaps = np.diff(np.concatenate([phases, phases[:1] + 1]))
    assert gaps.max() <= 4.0 / min(groups, period)
    if period in (40, 80):
        assert np.unique(np.mod(window[window % every == 0], period)).size == {80: 2, 40: 1}[period]


def test_gamma_t_is_fitted_on_the_drive_alone_and_its_count_is_the_drives_length():
    """Γ_T's samples inside the drive's span only (not the warm-up hold, not the cooling): over a
    drive of whole groups of windows their count is the span's windows over ``every``, the
    closed form by which Table 7.3's total df 7 999 fixes the 50 Hz run's 400 s drive
    (400 s · 4000 periods/s / 200 = 8 000)."""
    every, rate = 200, 4000.0  # ripple periods a second
    window = np.arange(int(603 * rate))  # a 3 s warm-up, the 400 s drive, 200 s of cooling
    kept = window[ch7.kept_windows(window, every)]
    samples = {"time": (kept + 0.5) / rate, "C_e": np.ones(kept.size), "x_laser": kept * 1.0}
    driven = ch7.while_driven(samples, (3.0, 403.0))
    assert driven["time"].size == 400 * rate / every == 8000
    assert driven["time"].min() >= 3.0 and driven["time"].max() < 403.0
    inside = (samples["time"] >= 3.0) & (samples["time"] < 403.0)
    assert np.array_equal(driven["x_laser"], samples["x_laser"][inside])  # every series alike


def test_gamma_t_windows_are_the_same_in_any_chunks():
    every = 200
    whole = ch7.kept_windows(np.arange(100_000), every)
    parts = np.concatenate(
        [
            ch7.kept_windows(np.arange(a, b), every)
            for a, b in ((0, 7), (7, 33_333), (33_333, 100_000))
        ]
    )
    assert np.array_equal(parts, whole)


LINEAR_GAMMA = GammaPolynomial(
    (32.0 * 3.13, -32.0)
)  # x [µm] = 32 (3.13 − C [µF]): 0 at rest, 32 µm at 2.13 µF


def sine_run(frequency, shift=0.0, loop=0.0, T=(23.0, 23.0), seconds=3.0, warmup=0.5, rate=4000.0):
    """A ripple series whose C_e–x follows LINEAR_GAMMA, the laser reading `shift` more after the
    warm-up and `loop` more (less) on the rising (falling) branch; T_mid ramps from T[0] to T[1]."""
    t = np.arange(int(seconds * rate)) / rate
    U = np.where(t >= warmup, 50 - 50 * np.cos(2 * np.pi * frequency * (t - warmup)), 0.0)
    C = 3.13e-6 - 1e-8 * U
    rising = np.gradient(U) >= 0
    x = (
        LINEAR_GAMMA.predict(C) + 5e-6 + (t >= warmup) * (shift + np.where(rising, loop, -loop))
    )  # laser zero: 5 µm
    t_slow = np.arange(0, seconds, 0.1)
    return {
        "time": t,
        "C_e": C,
        "x_laser": x,
        "U": U,
        "frequency": frequency,
        "warmup": warmup,
        "T_time": t_slow,
        "T_mid": np.interp(t_slow, [warmup, seconds], T),
    }


def test_frequency_effect_is_zero_on_gamma_and_gives_a_shift_or_a_loop_back():
    runs = {
        "ref": sine_run(0.5),
        "on": sine_run(10.0),
        "shifted": sine_run(50.0, shift=0.4e-6, T=(25.0, 25.0)),
        "loop": sine_run(100.0, loop=0.3e-6, T=(23.0, 24.0)),
    }
    table, curves = ch7.frequency_effect(
        runs, LINEAR_GAMMA, g=0.2, reference="ref", bins=10, min_windows=5
    )
    t = table.set_index("run")
    assert list(table["frequency [Hz]"]) == [0.5, 10, 50, 100]
    for run in ("ref", "on"):
        assert t.loc[run, "max |x − Γ(C_e)| [µm]"] < 1e-6
    for col in ("mean x − Γ(C_e) [µm]", "max |x − Γ(C_e)| [µm]", "rms x − Γ(C_e) [µm]"):
        assert t.loc["shifted", col] == pytest.approx(0.4, rel=1e-6)
    assert t.loc["shifted", "max [% of stroke]"] == pytest.approx(
        100 * 0.4 / t.loc["shifted", "stroke [µm]"]
    )
    # the two branches straddle Γ: their mean hides the loop, the per-branch curves do not
    assert abs(t.loc["loop", "mean x − Γ(C_e) [µm]"]) < 0.05
    assert t.loc["loop", "max |x − Γ(C_e)| [µm]"] == pytest.approx(0.3, rel=1e-6)
    assert t.loc["shifted", "offset from temperature g·(T − T_Γ) [µm]"] == pytest.approx(0.2 * 2.0)
    assert t.loc["loop", "T rise [K]"] == pytest.approx(1.0, abs=0.05)
    assert t.loc["ref", "note"] == "Γ fitted on this run" and t.loc["on", "note"] == ""
    assert set(curves) == {"0.5 Hz", "10 Hz", "50 Hz", "100 Hz"}


def test_figure_7_9_shows_the_identified_values_or_says_why_not():
    from selfsense.methods.observer import HPOGains
    from selfsense.methods.ripple import plan_from_fs

    def texts(fig):
        return " ".join(t.get_text() for ax in fig.axes for t in ax.texts)

    args = (
        GammaPolynomial((1.0, 2.0, 0.0, 0.0, 0.0, 3.0), g=0.203),
        HPOGains(16.6, 2 * np.pi, 1.0),
    )
    plan = plan_from_fs(48000.0, 1e5, 12, 4)
    fig, shown = ch7.figure_7_9(
        *args, {"identified": True, "tau": 106.9, "gamma": 50.4, "T_amb": 23.1}, 2.64e6, plan
    )
    assert (
        "τ = 106.9 s, γ = 50.4 K/W" in texts(fig)
        and "g = 0.203 µm/K" in texts(fig)
        and "2.64 V/µm" in texts(fig)
    )
    assert "order 5" in texts(fig) and shown["Gamma_T order"] == 5
    assert shown["L_I"] == pytest.approx((2 * np.pi) ** 2 * 16.6) and shown["tau [s]"] == 106.9
    fig, shown = ch7.figure_7_9(
        *args, {"identified": False, "reason": "runs too short"}, 2.64e6, plan
    )
    assert (
        "not identified" in texts(fig)
        and "runs too short" in texts(fig)
        and shown["tau [s]"] is None
    )


def _heating_run(rng, T_end, n=6000, kappa=7.9e-9, dC_x=-0.03, C0=3.13e-6, noise=2e-9):
    """C_e, x, T of a 50 Hz-like run while the stack warms: C depends on x and on T (the twin's
    C_P), so x = (C − C0 − κ(T − 23))/ΔCx exactly, g = κ/|ΔCx| [m/K]."""
    x = 16.5e-6 * (1 - np.cos(np.linspace(0, 400 * np.pi, n)))
    T = 23 + (T_end - 23) * (1 - np.exp(-np.linspace(0, 4, n)))
    C = C0 + dC_x * x + kappa * (T - 23) + rng.normal(0, noise, n)
    return C, x, T


def test_gamma_t_order_is_validated_on_a_hotter_run_and_gives_g_back():
    rng = np.random.default_rng(7)
    fit_run, hotter = _heating_run(rng, 41.0), _heating_run(rng, 60.0)
    table, order = ch7.gamma_t_order(fit_run, hotter)
    assert order == 1 and table.loc[table["chosen"], "order"].item() == 1
    g_true = 1e6 * 7.9e-9 / 0.03  # µm/K
    # C_e noise of 2 nF (≈ 0.07 %) over 18 K of warming: g is determined to ≈ 0.1 %; 2 % is the
    # scorecard's twin-input rule
    assert table.loc[table["chosen"], "g [µm/K]"].item() == pytest.approx(g_true, rel=0.02)
    assert (
        table["rms error on the validation run [µm]"]
        >= table.loc[table["chosen"], "rms error on the validation run [µm]"].item()
    ).all()


@pytest.mark.parametrize("rate", [5.0, 10.0, 20.0, 12.5])
def test_thermometers_beside_the_power_are_read_at_its_times_whatever_their_rate(tmp_path, rate):
    """The loss power comes every 0.1 s; the thermometers come at their own rate. Each interval's
    temperature is the thermometers' at its time (a 10 K/s ramp, exact between samples), never
    their k-th sample: at 20 Hz that read the ramp at half its time and τ came out doubled."""
    capture = synthetic(tmp_path / "ramp.nc", n=96_000, thermometers=rate)
    power, _, _ = ch7.extract_capture(capture, 2.85e6, n_periods=4)
    with open_capture(capture) as cap:
        step, last = cap.resolution("T_mid"), (cap.n_slow - 1) / cap.slow_rate
    assert power["time"][-1] <= last < power["time"][-1] + 0.1
    for name in ch7.THERMOMETERS:
        np.testing.assert_allclose(power[name], 23.0 + 10.0 * power["time"], rtol=0, atol=step)


def test_the_coupled_traces_meet_the_thermometer_at_their_own_times():
    """Traces every 0.1 s against a thermometer series every 0.2 s (another power interval in
    config.yaml): each trace sample meets the ramp at its own time, over the span both cover."""
    t = np.arange(0, 30, 0.1)
    traces = {"time": t, "T_SH_HPO": 23.0 + t, "T_SH_PS": 24.0 + t}
    measured = {"time": np.arange(0, 20, 0.2), "T_mid": 23.0 + np.arange(0, 20, 0.2)}
    out, stats = ch7.against_measured(traces, {}, measured)
    assert out["time"][-1] == pytest.approx(19.8)
    np.testing.assert_allclose(out["T_mid"], 23.0 + out["time"], rtol=1e-12)
    assert stats["max |T_SH_HPO − T| [K]"] == pytest.approx(0.0, abs=1e-12)
    assert stats["max |T_SH_PS − T| [K]"] == pytest.approx(1.0)
