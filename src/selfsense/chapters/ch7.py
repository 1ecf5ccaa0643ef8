"""Chapter 7: self-heating — loss power, the thermal model (Table 7.1), Γ_T (Tables 7.2–7.3), the
frequency effect on C_e–x (Fig 7.8) and the coupled observer/thermal estimation (Fig 7.9–7.12)."""

from __future__ import annotations

import textwrap
from collections.abc import Mapping

import numpy as np
import pandas as pd

from selfsense.chapters import figure_names
from selfsense.io.capture import open_capture, read_series
from selfsense.methods.gamma import (
    GammaPolynomial,
    anova_table,
    coefficient_table,
    fit_gamma,
    gamma_t_table,
)
from selfsense.methods.metrics import branch_means, direction
from selfsense.methods.observer import HPOGains
from selfsense.methods.ripple import (
    RippleExtractor,
    SamplingPlan,
    WindowMeans,
    plan_from_capture,
)
from selfsense.methods.selfsensing import SelfSensingChain
from selfsense.methods.thermal import (
    PowerAverager,
    SelfHeatingEstimator,
    ThermalModel,
    ThermalProperties,
    identify_series,
    linear_fit,
    power_loss,
    predict_temperature,
)

THESIS_TABLE_7_1 = {
    "tau [s]": 100.0,
    "k_T [W/(m² K)]": 28.0,
    "gamma [K/W]": 57.0,
    "k/alpha [V/m]": 2.85e6,
    "T_ref [°C]": 23.0,
}
#: How often the coupled estimation hands T_SH(HPO) to Γ_T and x̂ to the loss power [s]: the IR
#: thermometers' rate, and fast enough for a temperature that changes over τ ≈ 100 s.
COUPLING_INTERVAL = 0.1
#: the thesis's coupled estimation over the mixed run (Fig 7.12)
THESIS_COUPLED_MIXED = {
    "max observer error [µm]": 1.38,
    "max observer error [% of stroke]": 4.18,
    "max |T_SH_HPO − T| [K]": 1.45,
    "max |T_SH_PS − T| [K]": 1.45,
}
THERMAL_FIGURES, CHECK_FIGURES = figure_names.CH7_THERMAL, figure_names.CH7_CHECKS
GAMMA_T_FIGURE, FREQUENCY_FIGURE, DIAGRAM_FIGURE = (
    figure_names.CH7_GAMMA_T,
    figure_names.CH7_FREQUENCY,
    figure_names.CH7_DIAGRAM,
)
COUPLED_FIGURES = figure_names.CH7_COUPLED
#: the figure of the mixed run, the one the thesis reports the coupled estimation's errors for
MIXED_FIGURE = "fig_7_12"
THESIS_TABLE_7_2 = {
    "n=4": (0.998189, 0.998188, 0.474422),
    "n=5": (0.998194, 0.998193, 0.473808),
    "n=6": (0.998194, 0.998193, 0.47377),
    "n=5 + C·T": (0.998193, 0.998193, 0.473825),
}


#: {k·φ} (φ the golden ratio's fractional part) is the most evenly spread sequence in [0, 1): the
#: offsets :func:`kept_windows` takes within each group of windows
GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0


def kept_windows(window: np.ndarray, every: int) -> np.ndarray:
    """Which ripple windows (their indices from the capture's start) Γ_T's samples keep: one in each
    group of ``every``, the k-th group's at offset ⌊{k·φ}·every⌋.

    A fixed stride samples a periodic drive stroboscopically: 200 windows of 12 samples at 48 kHz
    are 2.5 periods of a 50 Hz drive and 5 of a 100 Hz one, so every 200th window sees two phases
    of the stroke, or one, and Γ_T would be fitted through two clusters of (C_e, x). The offsets
    {k·φ} fill every phase for any drive period, and the selection depends on the window's index
    alone, so a capture read in any chunks keeps the same windows."""
    window = np.asarray(window, dtype=np.int64)
    offset = np.floor(np.mod((window // every) * GOLDEN, 1.0) * every).astype(np.int64)
    return window % every == offset


def extract(
    chunks, fs: float, plan: SamplingPlan, k_over_alpha: float, interval: float, every: int
):
    """Stream a capture into (a) mean loss power per interval from the laser position (Eq 7.4)
    and (b) C_e with the window-mean position, one ripple window in ``every`` (for Γ_T,
    :func:`kept_windows`).

    Yields ({"time", "P_PS"}, {"time", "C_e", "x_laser"}, (max U [V], max x [m])) per chunk; the
    maxima over the run give k/α by Eq 7.11.
    """
    power = PowerAverager(fs, interval)
    extractor, means = RippleExtractor(plan), WindowMeans(plan, 1)
    x0, emitted = None, 0
    for _, d in chunks:
        if x0 is None:
            x0 = float(d["x_laser"][0])
        x = d["x_laser"] - x0
        P = power.update(power_loss(d["U"], x, d["I"], k_over_alpha))
        t = (emitted + np.arange(len(P))) * interval
        emitted += len(P)
        blocks = extractor.process(d["Ur"], d["Ir"])
        _, (xm,) = means.process(x)
        keep = kept_windows(blocks.sample_index // plan.ns, every)
        yield (
            {"time": t, "P_PS": P},
            {
                "time": (blocks.sample_index[keep] - (plan.block_len - 1) / 2) / fs,
                "C_e": blocks.C_e[keep],
                "x_laser": xm[keep],
            },
            (float(np.max(d["U"], initial=-np.inf)), float(np.max(x, initial=-np.inf))),
        )


#: the fast channels :func:`extract_capture` streams, and the IR thermometers it reads beside them
EXTRACTED = ("U", "I", "x_laser", "Ur", "Ir")
THERMOMETERS = ("T_top", "T_mid", "T_bot")
#: the units of :func:`extract_capture`'s series
SERIES_UNITS = {"time": "s", "P_PS": "W", "C_e": "F", "x_laser": "m"} | {
    t: "degC" for t in THERMOMETERS
}


def extract_capture(
    capture, k_over_alpha: float, n_periods: int, interval: float = 0.1, every: int = 200
):
    """Rule thermal_extract's series of one Chapter 7 capture, streamed (:func:`extract`):

    - the loss power P_PS per ``interval`` [s] (Eq 7.4) beside the capture's IR thermometers read
      at the intervals' times on their own time axis (linear between their samples, whatever
      their rate), over the span both cover ({"time", "P_PS", "T_top"?, "T_mid", "T_bot"?});
    - the run's peaks {"U_max" [V], "x_max" [m]} (Eq 7.11's k/α from them);
    - Γ_T's samples, one ripple window of ``n_periods`` in ``every`` ({"time", "C_e",
      "x_laser"}).
    """
    with open_capture(capture, require=EXTRACTED + ("T_mid",)) as cap:
        plan = plan_from_capture(cap, n_periods)
        parts = list(
            extract(cap.iter_chunks(EXTRACTED), cap.fs, plan, k_over_alpha, interval, every)
        )
        slow = [c for c in THERMOMETERS if c in cap.channels]
        temps = cap.read(slow, dim="time_slow")
        T_time = np.arange(cap.n_slow) / cap.slow_rate
    P = {k: np.concatenate([p[0][k] for p in parts]) for k in ("time", "P_PS")}
    n = int(np.searchsorted(P["time"], T_time[-1], side="right")) if T_time.size else 0
    power = {k: v[:n] for k, v in P.items()}
    power |= {c: np.interp(power["time"], T_time, temps[c]) for c in slow}
    peaks = {"U_max": max(p[2][0] for p in parts), "x_max": max(p[2][1] for p in parts)}
    samples = {k: np.concatenate([p[1][k] for p in parts]) for k in ("time", "C_e", "x_laser")}
    return power, peaks, samples


def identify(
    series: Mapping[str, Mapping[str, np.ndarray]], props: ThermalProperties, T_amb: float | None
):
    """τ and γ per heating run by least squares of the predicted against the measured T (Eq 7.4)."""
    rows, fits = [], {}
    for name, s in series.items():
        try:
            fit = identify_series(
                s["time"], s["T_mid"], s["P_PS"], T_amb=T_amb, T0="ambient", props=props
            )
        except ValueError as err:  # a run too short to see τ (e.g. the smoke campaign): say so
            rows.append({"run": name, "note": f"not identifiable: {err}"})
            continue
        span = float(s["time"][-1] - s["time"][0])
        if span < 3 * fit.tau or fit.r_squared < 0.9:
            rows.append(
                {
                    "run": name,
                    "note": f"not identifiable: {span:.3g} s of data for τ = {fit.tau:.3g} s, "
                    f"R² = {fit.r_squared:.3f}",
                }
            )
            continue
        fits[name] = fit
        rows.append(
            {
                "run": name,
                "tau [s]": fit.tau,
                "gamma [K/W]": fit.gamma,
                "k_T from tau [W/(m² K)]": fit.k_T_from_tau,
                "k_T from gamma [W/(m² K)]": fit.k_T_from_gamma,
                "R²": fit.r_squared,
                "max |T − fit| [K]": fit.residual_max,
                "heating power [W]": heating_power(s["P_PS"]),
                "max rise [K]": float(np.max(s["T_mid"]) - fit.T_amb),
                "T_amb [°C]": fit.T_amb,
                "U_max [V]": s.get("U_max", np.nan),
                "x_max [m]": s.get("x_max", np.nan),
                "note": "",
            }
        )
    return pd.DataFrame(rows), fits


def heating_power(P: np.ndarray) -> float:
    """Mean loss power while the drive heats (the cooling stretch at 0 V carries none)."""
    return float(np.mean(P[P > 0.5 * np.max(P)]))


def thermal_identification(
    runs: Mapping[str, Mapping[str, np.ndarray]],
    freq_of: Mapping[str, float],
    props: ThermalProperties,
    k_over_alpha: float,
):
    """τ, γ, k_T from the heating runs (Table 7.1) and the steady rise against frequency (Figs
    7.1, 7.2), from those runs alone.

    ``runs``: {run: loss-power series} at 100 V and the frequencies ``freq_of`` [Hz]. When no run
    is long enough to identify τ (e.g. the smoke campaign) the later tables and figures say why.
    Returns ({table: DataFrame} incl. "per_run", the thermal model record, {figure: Figure}); the
    record is what :func:`thermal_checks` predicts with.
    """
    from selfsense.chapters import (
        figures,  # here: the streaming jobs that import this module need no matplotlib
    )

    per_run, _ = identify(runs, props, T_amb=None)
    identified = per_run.dropna(subset=["tau [s]"]) if "tau [s]" in per_run else per_run.iloc[0:0]
    heating = figures.loop(
        [s["time"] for s in runs.values()],
        [s["T_mid"] for s in runs.values()],
        "time [s]",
        "T [°C]",
        "Self-heating at 100 V, 20–200 Hz",
        labels=list(runs),
    )
    if identified.empty:
        reason = "no heating run long enough to identify τ and γ (see per_run.csv)"
        record = {"identified": False, "reason": reason}
        tables, missing = _not_computed(("table_7_1", "freq_trend"), THERMAL_FIGURES[1:], reason)
        return {"per_run": per_run} | tables, record, {THERMAL_FIGURES[0]: heating} | missing
    trend = steady_rise_trends(identified, freq_of)
    tables = {
        "per_run": per_run,
        "table_7_1": table_7_1(identified, k_over_alpha, THESIS_TABLE_7_1["T_ref [°C]"]),
        "freq_trend": trend,
    }
    frequency_rise = figures.loop(
        [trend["frequency [Hz]"]] * 2,
        [
            trend["steady rise [K]"],
            trend["fit slope [K/Hz]"] * trend["frequency [Hz]"] + trend["fit intercept [K]"],
        ],
        "frequency [Hz]",
        "steady rise [K]",
        f"Steady rise against frequency (linear fit R² = {trend['fit R²'].iloc[0]:.4f})",
        labels=["identified γ·P", "linear fit"],
    )
    record = {
        "identified": True,
        "tau": float(identified["tau [s]"].mean()),
        "gamma": float(identified["gamma [K/W]"].mean()),
        "T_amb": float(identified["T_amb [°C]"].mean()),
    }
    return tables, record, dict(zip(THERMAL_FIGURES, (heating, frequency_rise)))


def thermal_checks(
    volt: Mapping[str, np.ndarray],
    volt_segments,
    checks: Mapping[str, Mapping[str, np.ndarray]],
    record: Mapping[str, object],
):
    """The identified thermal model against the runs it was not identified on: the steady rise
    against V² at 150 Hz (Fig 7.3) and the predicted temperature of the check runs (Figs 7.5,
    7.6).

    ``volt``: the 150 Hz voltage steps' loss-power series, their ``volt_segments``; ``checks``:
    {run: loss-power series} predicted; ``record``: :func:`thermal_identification`'s thermal
    model record (its reason is repeated when it identified none). Returns ({"volt_trend",
    "prediction": DataFrame}, {figure: Figure}).
    """
    from selfsense.chapters import figures

    if not record["identified"]:
        return _not_computed(("volt_trend", "prediction"), CHECK_FIGURES, record["reason"])
    model, T_amb = ThermalModel(record["tau"], record["gamma"]), record["T_amb"]
    vtrend = voltage_trend(volt, volt_segments, model)
    voltage_rise = figures.loop(
        [vtrend["voltage [V]"] ** 2],
        [vtrend["steady rise [K]"]],
        "V² [V²]",
        "steady rise [K]",
        f"Steady rise against V² at 150 Hz (R² = {vtrend['fit R²'].iloc[0]:.4f})",
    )
    predicted = []
    for name, s in checks.items():
        T_pred = predict_temperature(s["time"], s["P_PS"], model, T0=T_amb, T_amb=T_amb)
        predicted.append(
            figures.time_traces(
                s["time"],
                [
                    (s["T_mid"], "T measured [°C]"),
                    (T_pred, "T_SH(PS) [°C]"),
                    (T_pred - s["T_mid"], "error [K]"),
                ],
                f"{name}: measured against predicted temperature",
            )
        )
    tables = {"volt_trend": vtrend, "prediction": prediction_errors(checks, model, T_amb)}
    return tables, dict(zip(CHECK_FIGURES, (voltage_rise, *predicted)))


def _not_computed(tables, names, reason: str):
    """A one-row note for each of ``tables`` and a placeholder for each figure of ``names``."""
    from selfsense.chapters import figures

    note = {key: pd.DataFrame([{"note": f"not computed: {reason}"}]) for key in tables}
    return note, {name: figures.placeholder(_title(name), reason) for name in names}


def _title(name: str) -> str:
    """A placeholder's title from its file name: fig_7_10 → Figure 7.10."""
    return "Figure " + name.removeprefix("fig_").replace("_", ".")


def table_7_1(per_run: pd.DataFrame, k_over_alpha: float, T_ref: float) -> pd.DataFrame:
    """Table 7.1: τ, γ, k_T (means over the identified runs), k/α by Eq 7.11 (U_max/x_max, median
    over the runs) beside Chapter 4's k/α, which the loss power P = (U − k/α·x)·I uses."""
    ours = {
        "tau [s]": per_run["tau [s]"].mean(),
        "gamma [K/W]": per_run["gamma [K/W]"].mean(),
        "k_T [W/(m² K)]": 0.5
        * (per_run["k_T from tau [W/(m² K)]"].mean() + per_run["k_T from gamma [W/(m² K)]"].mean()),
        "k/alpha [V/m]": float(np.median(per_run["U_max [V]"] / per_run["x_max [m]"])),
        "k/alpha, Chapter 4 [V/m]": k_over_alpha,
        "T_ref [°C]": T_ref,
    }
    spread = {
        "tau [s]": per_run["tau [s]"].std(ddof=1),
        "gamma [K/W]": per_run["gamma [K/W]"].std(ddof=1),
        "k_T [W/(m² K)]": abs(
            per_run["k_T from tau [W/(m² K)]"].mean() - per_run["k_T from gamma [W/(m² K)]"].mean()
        )
        / 2,
    }
    return pd.DataFrame(
        [
            {
                "parameter": k,
                "reproduced": v,
                "spread": spread.get(k, np.nan),
                "thesis": THESIS_TABLE_7_1.get(k, np.nan),
            }
            for k, v in ours.items()
        ]
    )


def steady_rise_trends(per_run: pd.DataFrame, freq_runs: Mapping[str, float]) -> pd.DataFrame:
    """Fig 7.2: the steady rise (γ·P) against drive frequency at 100 V, with a linear fit, and
    the steady temperature it reaches from the run's ambient."""
    sel = per_run[per_run["run"].isin(freq_runs)]
    f = np.array([freq_runs[r] for r in sel["run"]])
    rise = (sel["gamma [K/W]"] * sel["heating power [W]"]).to_numpy()
    fit = linear_fit(f, rise)
    return pd.DataFrame(
        {
            "frequency [Hz]": f,
            "steady rise [K]": rise,
            "steady temperature [°C]": sel["T_amb [°C]"].to_numpy() + rise,
            "fit slope [K/Hz]": fit.slope,
            "fit intercept [K]": fit.intercept,
            "fit R²": fit.r_squared,
        }
    )


def voltage_trend(series: Mapping[str, np.ndarray], segments, model: ThermalModel) -> pd.DataFrame:
    """Fig 7.3: the steady rise γ·P per voltage step at 150 Hz against V², with a linear fit."""
    rows, start = [], 0.0
    for seg in segments:
        sel = (series["time"] >= start + 0.5 * seg["duration"]) & (
            series["time"] < start + seg["duration"]
        )
        rows.append(
            {
                "voltage [V]": seg["hi"],
                "steady rise [K]": model.gamma * float(np.mean(series["P_PS"][sel])),
            }
        )
        start += seg["duration"]
    table = pd.DataFrame(rows)
    fit = linear_fit(table["voltage [V]"] ** 2, table["steady rise [K]"])
    return table.assign(**{"fit slope [K/V²]": fit.slope, "fit R²": fit.r_squared})


def prediction_errors(
    series: Mapping[str, Mapping[str, np.ndarray]], model: ThermalModel, T_amb: float
) -> pd.DataFrame:
    """Figs 7.5–7.6: T predicted from the loss power against the measured T, max error."""
    rows = []
    for name, s in series.items():
        T = predict_temperature(s["time"], s["P_PS"], model, T0=T_amb, T_amb=T_amb)
        err = T - s["T_mid"]
        rows.append(
            {
                "run": name,
                "max |T_SH(PS) − T| [K]": float(np.max(np.abs(err))),
                "max rise [K]": float(np.max(s["T_mid"]) - T_amb),
                "error [% of max rise]": 100
                * float(np.max(np.abs(err)))
                / max(float(np.max(s["T_mid"]) - T_amb), 1e-9),
            }
        )
    return pd.DataFrame(rows)


def while_driven(samples: Mapping[str, np.ndarray], span: tuple[float, float]) -> dict:
    """The samples whose window centre lies in the drive's ``span`` = (start, end) [s].

    Γ_T is fitted on a heating run while it heats, not on its warm-up hold or its cooling at 0 V:
    Table 7.3's total df 7 999 are 8 000 windows, the 50 Hz run's 400 s drive at one window in
    200 of the 4 kHz ripple periods.
    """
    start, end = span
    keep = (samples["time"] >= start) & (samples["time"] < end)
    return {k: v[keep] for k, v in samples.items()}


def gamma_t_data(samples: Mapping[str, np.ndarray], T_mid_time, T_mid) -> tuple[np.ndarray, ...]:
    """C_e [F], x [m] and the middle thermometer interpolated to each window [°C] (Eq 7.13's
    data)."""
    T = np.interp(samples["time"], T_mid_time, T_mid)
    ok = np.isfinite(samples["C_e"]) & np.isfinite(samples["x_laser"])
    return samples["C_e"][ok], samples["x_laser"][ok], T[ok]


def gamma_t_order(data, validation, candidates=(1, 2, 3, 4, 5, 6)) -> tuple[pd.DataFrame, int]:
    """The order of Γ_T (Eq 7.13) by validation: fitted on ``data`` (the 50 Hz run), each order
    predicts ``validation`` (a hotter run not used for fitting), and the smallest rms error wins.

    Adjusted R² cannot choose here: C_e itself depends on temperature, so the polynomial in C
    takes up part of what g should carry and higher orders "explain" more of the fitting run
    while g drifts and the fit extrapolates badly to other temperatures."""
    rows = []
    for j in candidates:
        fit = fit_gamma(data[0], data[1], j, temperature=data[2])
        error_um = (fit.predict(validation[0], validation[2]) - validation[1]) * 1e6
        rows.append(
            {
                "order": j,
                "adjusted R² (fit run)": fit.r2_adj,
                "g [µm/K]": float(fit.coefficients["g"]),
                "rms error on the validation run [µm]": float(np.sqrt(np.mean(error_um**2))),
                "max error on the validation run [µm]": float(np.max(np.abs(error_um))),
            }
        )
    table = pd.DataFrame(rows)
    order = int(table.loc[table["rms error on the validation run [µm]"].idxmin(), "order"])
    return table.assign(chosen=table["order"] == order), order


def gamma_t(data, validation, orders=(4, 5, 6), order: int = 5, candidates=(1, 2, 3, 4, 5, 6)):
    """Tables 7.2 and 7.3 (at the thesis's order n = 5) from C_e, position and temperature
    (Eq 7.13), the order validated on another run, and both fits: (tables, {name: GammaFit})."""
    selection, chosen = gamma_t_order(data, validation, candidates)
    C, x, T = data
    t72 = gamma_t_table(C, x, T, orders=tuple(orders), interaction_order=order)
    fit = fit_gamma(C, x, order, temperature=T)
    tables = {
        "table_7_2": t72,
        "anova": anova_table(fit).reset_index(names="source"),
        "coefficients": coefficient_table(fit).reset_index(names="coefficient"),
        "order": selection,
    }
    return tables, {"gamma_t": fit_gamma(C, x, chosen, temperature=T), "gamma_t_n5": fit}


def gamma_t_fits(
    samples: Mapping[str, np.ndarray],
    thermometers: Mapping[str, np.ndarray],
    validation_samples: Mapping[str, np.ndarray],
    validation_thermometers: Mapping[str, np.ndarray],
    spans: tuple[tuple[float, float], tuple[float, float]],
    orders=(4, 5, 6),
    order: int = 5,
    candidates=(1, 2, 3, 4, 5, 6),
):
    """Rule gamma_t_fit's results: :func:`gamma_t` on the 50 Hz heating run's C_e/x ``samples``
    (rule thermal_extract's) with its middle thermometer (``thermometers``: its power series,
    "time" and "T_mid"; Eq 7.13's data, :func:`gamma_t_data`), the order validated on the hotter
    100 Hz run's, each inside its drive's span of ``spans`` (:func:`while_driven`). Returns
    ({table: DataFrame}: Tables 7.2, 7.3 at ``order``, the order's validation; {"gamma_t",
    "gamma_t_n5": the fit's :class:`GammaPolynomial` record})."""
    fit_span, validation_span = spans
    tables, fits = gamma_t(
        gamma_t_data(while_driven(samples, fit_span), thermometers["time"], thermometers["T_mid"]),
        gamma_t_data(
            while_driven(validation_samples, validation_span),
            validation_thermometers["time"],
            validation_thermometers["T_mid"],
        ),
        orders,
        order,
        candidates,
    )
    return tables, {name: GammaPolynomial.from_fit(fit).record() for name, fit in fits.items()}


def figure_7_7(samples: Mapping[str, np.ndarray]):
    """Fig 7.7: C_e against position on the 50 Hz run while the stack heats (:func:`gamma_t`'s
    samples)."""
    from selfsense.chapters import (
        figures,  # here: the streaming jobs that import this module need no matplotlib
    )

    return figures.loop(
        [samples["x_laser"] * 1e6],
        [samples["C_e"] * 1e6],
        "x [µm]",
        "C_e [µF]",
        "Capacitance against position while the stack heats (50 Hz)",
    )


def coupled_estimation(
    chunks,
    fs: float,
    plan: SamplingPlan,
    gamma: GammaPolynomial,
    gains: HPOGains,
    model: ThermalModel,
    k_over_alpha: float,
    T_amb: float,
    warmup: float,
    interval: float = COUPLING_INTERVAL,
):
    """Fig 7.9: the temperature-compensated observer and the thermal model, coupled.

    Every ``interval`` the thermal model, driven by the loss power computed with the observer's
    own position, gives T_SH(HPO), which Γ_T uses for the next interval; T_SH(PS) runs alongside
    on the laser position. Returns 10 Hz traces (t, T_SH(HPO), T_SH(PS)) and per-sample-max
    observer error statistics after ``warmup``.
    """
    chain = SelfSensingChain(plan, gamma, gains, fs)
    hpo = SelfHeatingEstimator(fs, model, k_over_alpha, interval, T0=T_amb, T_amb=T_amb)
    ps = SelfHeatingEstimator(fs, model, k_over_alpha, interval, T0=T_amb, T_amb=T_amb)
    step = int(round(interval * fs))
    traces = {"time": [], "T_SH_HPO": [], "T_SH_PS": []}
    err_max, x_lo, x_hi, x0 = 0.0, np.inf, -np.inf, None
    for start, d in chunks:
        if x0 is None:
            x0 = float(d["x_laser"][0])
        for a in range(0, len(d["U"]), step):
            sl = slice(a, a + step)
            chain.temperature = hpo.temperature
            x_hat = chain.process(d["Ur"][sl], d["Ir"][sl], d["I"][sl])["x_hat"]
            x = d["x_laser"][sl] - x0
            h, p = hpo.update(d["U"][sl], x_hat, d["I"][sl]), ps.update(d["U"][sl], x, d["I"][sl])
            traces["time"].append(h.t)
            traces["T_SH_HPO"].append(h.T)
            traces["T_SH_PS"].append(p.T)
            t = (start + a + np.arange(len(x))) / fs
            after = t >= warmup
            if after.any():
                err_max = max(err_max, float(np.max(np.abs(x_hat[after] - x[after]))))
                x_lo, x_hi = min(x_lo, float(x[after].min())), max(x_hi, float(x[after].max()))
    out = {k: np.concatenate(v) for k, v in traces.items()}
    stroke = x_hi - x_lo
    return out, {
        "max observer error [µm]": err_max * 1e6,
        "stroke [µm]": stroke * 1e6,
        "max observer error [% of stroke]": 100 * err_max / stroke,
    }


def against_measured(
    traces: Mapping[str, np.ndarray],
    result: Mapping[str, float],
    measured: Mapping[str, np.ndarray],
):
    """:func:`coupled_estimation`'s traces beside the measured middle temperature read at their
    times (linear between its samples: the two need not share an interval), over the span both
    cover, and the result with each estimate's max error against it."""
    n = int(np.searchsorted(traces["time"], measured["time"][-1], side="right"))
    out = {k: v[:n] for k, v in traces.items()}
    out["T_mid"] = np.interp(out["time"], measured["time"], measured["T_mid"])
    errors = {
        f"max |{key} − T| [K]": float(np.max(np.abs(out[key] - out["T_mid"])))
        for key in ("T_SH_HPO", "T_SH_PS")
    }
    return out, dict(result) | errors


#: the capture's channels :func:`coupled_run` streams, and the units of its traces
COUPLED_CHANNELS = ("U", "I", "x_laser", "Ur", "Ir")
COUPLED_UNITS = {"time": "s", "T_SH_HPO": "degC", "T_SH_PS": "degC", "T_mid": "degC"}


def coupled_run(
    capture,
    measured: Mapping[str, np.ndarray],
    gamma: GammaPolynomial,
    gains: HPOGains,
    thermal: Mapping[str, float],
    k_over_alpha: float,
    n_periods: int,
):
    """Fig 7.9 over one heating run: :func:`coupled_estimation` of the ``capture`` (its ripple
    windows of ``n_periods``, the observer error counted from its warm-up on) with Γ_T (Eq 7.13)
    ``gamma``, the observer ``gains`` and the thermal model rule thermal_identify identified
    (``thermal``: its record's "tau" [s], "gamma" [K/W] and "T_amb" [°C], Table 7.1), then
    :func:`against_measured` the middle thermometer's ``measured`` series ({"time", "T_mid"}).
    Returns (traces, result)."""
    with open_capture(capture, require=COUPLED_CHANNELS) as cap:
        traces, result = coupled_estimation(
            cap.iter_chunks(COUPLED_CHANNELS),
            cap.fs,
            plan_from_capture(cap, n_periods),
            gamma,
            gains,
            ThermalModel(thermal["tau"], thermal["gamma"]),
            k_over_alpha,
            thermal["T_amb"],
            float(cap.attribute("warmup_s")),
        )
    return against_measured(traces, result, measured)


def coupled_table(stats: Mapping[str, Mapping], mixed_run: str) -> pd.DataFrame:
    """The coupled estimation's errors per run ({run: stats record}), the thesis's beside the mixed
    run (the one Fig 7.12 shows, which the thesis reports them for)."""
    thesis = {f"thesis {k}": v for k, v in THESIS_COUPLED_MIXED.items()}
    return pd.DataFrame(
        [
            {"run": run}
            | {k: v for k, v in s.items() if k != "provenance"}
            | (thesis if run == mixed_run else {})
            for run, s in stats.items()
        ]
    )


def figure_coupled(name: str, run: str, traces: Mapping[str, np.ndarray], stats: Mapping):
    """Figs 7.10–7.12 (``name`` of :data:`COUPLED_FIGURES`): measured T, T_SH(PS) and T_SH(HPO) over
    one run, or why they are missing."""
    from selfsense.chapters import figures

    if not len(traces["time"]):
        return figures.placeholder(_title(name), stats["note"])
    return figures.time_traces(
        traces["time"],
        [
            (traces["T_mid"], "T measured [°C]"),
            (traces["T_SH_PS"], "T_SH(PS) [°C]"),
            (traces["T_SH_HPO"], "T_SH(HPO) [°C]"),
            (traces["T_SH_HPO"] - traces["T_mid"], "T_SH(HPO) − T [K]"),
        ],
        f"{run}: temperature from the laser and from the observer",
    )


def thermal_recovery(
    table_7_1: pd.DataFrame, truth: Mapping[str, float], g_um_per_K: float
) -> pd.DataFrame:
    """τ, γ, k_T of Table 7.1 and g of the validated Γ_T against the twin's truth (the capture's
    /truth attributes; the twin's g is its C_P temperature slope over its position slope,
    κ_T/|ΔCx|)."""
    identified = (
        table_7_1.set_index("parameter")["reproduced"]
        if "parameter" in table_7_1
        else pd.Series(dtype=float)
    )
    pairs = [
        (name, float(truth[attr]), float(identified.get(key, float("nan"))))
        for name, attr, key in (
            ("tau [s]", "thermal_tau", "tau [s]"),
            ("gamma [K/W]", "thermal_gamma", "gamma [K/W]"),
            ("k_T [W/(m² K)]", "thermal_k_T", "k_T [W/(m² K)]"),
        )
    ]
    pairs.append(
        (
            "g [µm/K]",
            1e6 * float(truth["stack_kappa_T"]) / abs(float(truth["stack_dC_x"])),
            g_um_per_K,
        )
    )
    return pd.DataFrame(
        [
            {"parameter": name, "truth": t, "identified": i, "error [%]": 100 * (i / t - 1)}
            for name, t, i in pairs
        ]
    )


def frequency_run(series, capture, frequency: float) -> dict[str, np.ndarray | float]:
    """One run for :func:`frequency_effect`: its ripple series with the drive frequency [Hz], the
    warm-up and the middle thermometer."""
    with open_capture(capture, require=("T_mid",)) as cap:
        T = cap.read(["T_mid"], dim="time_slow")["T_mid"]
        rate = cap.slow_rate
        warmup = float(cap.attribute("warmup_s"))
    return read_series(series) | {
        "frequency": frequency,
        "warmup": warmup,
        "T_time": np.arange(T.size) / rate,
        "T_mid": T,
    }


def frequency_effect(
    runs: Mapping[str, Mapping],
    gamma: GammaPolynomial,
    g: float,
    reference: str,
    bins: int = 20,
    min_windows: int = 10,
):
    """Fig 7.8: how far each drive frequency's C_e–x curve lies from Γ, and how warm the stack was.

    ``runs``: {run: ripple series (time, C_e, x_laser, U) plus "frequency" [Hz], "warmup" [s]
    and the middle thermometer "T_time", "T_mid"}. Position is zeroed at the series' first
    window, as Γ's data were (:func:`..ch5.gamma_data`), and the warm-up hold is left out.
    The distance x − Γ(C_e) is averaged per position bin and per branch, so the table measures
    the curve (offset, bending, loop opening) rather than the ripple estimator's window noise; a
    bin with fewer than ``min_windows`` windows is left out (at 300 Hz the 4 kHz windows fall
    on a few drive phases, leaving some bins one or two windows, whose mean is that noise).
    ``g`` (Γ_T's temperature coefficient [µm/K]) turns each run's mean temperature, relative to
    the ``reference`` run's (the one Γ was fitted on), into the offset self-heating alone would
    give: what is left beyond it is the frequency's effect.
    Returns the table and the curves for :func:`figure_7_8`.
    """
    rows, curves = [], {}
    for name, r in sorted(runs.items(), key=lambda item: item[1]["frequency"]):
        driven = r["time"] >= r["warmup"]
        x, C = (r["x_laser"] - r["x_laser"][0])[driven], r["C_e"][driven]
        ok = np.isfinite(x) & np.isfinite(C)
        x, C, U = x[ok], C[ok], r["U"][driven][ok]
        centres, rising, falling = branch_means(
            x, x - gamma.predict(C), direction(U), bins, min_windows
        )
        curve = np.concatenate([rising, falling])
        stroke = float(np.ptp(x))
        on = r["T_time"] >= r["warmup"]
        t, T = r["T_time"][on], r["T_mid"][on]
        rows.append(
            {
                "frequency [Hz]": r["frequency"],
                "run": name,
                "windows": int(x.size),
                "stroke [µm]": 1e6 * stroke,
                "mean x − Γ(C_e) [µm]": 1e6 * float(np.nanmean(curve)),
                "max |x − Γ(C_e)| [µm]": 1e6 * float(np.nanmax(np.abs(curve))),
                "rms x − Γ(C_e) [µm]": 1e6 * float(np.sqrt(np.nanmean(curve**2))),
                "max [% of stroke]": 100 * float(np.nanmax(np.abs(curve))) / stroke,
                "rms [% of stroke]": 100 * float(np.sqrt(np.nanmean(curve**2))) / stroke,
                "T mean [°C]": float(np.mean(T)),
                "T rise [K]": _rise(t, T),
                "note": "Γ fitted on this run" if name == reference else "",
            }
        )
        curves[f"{r['frequency']:g} Hz"] = {
            "x": x,
            "C_e": C,
            "centres": centres,
            "rising": rising,
            "falling": falling,
        }
    table = pd.DataFrame(rows)
    T_ref = table.loc[table["run"] == reference, "T mean [°C]"].iloc[0]
    table.insert(
        table.columns.get_loc("note"),
        "offset from temperature g·(T − T_Γ) [µm]",
        g * (table["T mean [°C]"] - T_ref),
    )
    return table, curves


def _rise(t: np.ndarray, T: np.ndarray) -> float:
    """Warming over a run from a straight line through its temperatures: a run lasts seconds
    against τ ≈ 100 s, and the line sees through thermometer noise that max − min would report."""
    return float(np.polyfit(t, T, 1)[0] * np.ptp(t)) if t.size > 1 else float("nan")


def figure_7_8(curves: Mapping[str, Mapping[str, np.ndarray]], gamma: GammaPolynomial):
    """Fig 7.8 from :func:`frequency_effect`'s curves, with Γ drawn over the measured C_e range."""
    from selfsense.chapters import (
        figures,  # here: the streaming jobs that import this module need no matplotlib
    )

    C = np.concatenate([c["C_e"] for c in curves.values()])
    grid = np.linspace(np.min(C), np.max(C), 200)
    return figures.frequency_effect(curves, (grid, gamma.predict(grid)))


def figure_7_9(
    gamma_t: GammaPolynomial,
    gains: HPOGains,
    thermal: Mapping,
    k_over_alpha: float,
    plan: SamplingPlan,
    interval: float = COUPLING_INTERVAL,
):
    """Fig 7.9 as the pipeline runs it (:func:`coupled_estimation`), annotated with its identified
    values.

    (a) the self-heating model fed by the observer: P = (U − (k/α)x̂)·I averaged per interval,
    ΔT = γP/(τs+1) discretised exactly (ZOH), T_SH(HPO) = T_amb + ΔT; (b) the observer whose Γ_T
    reads that temperature, held for the next interval (the loop closes through this one-interval
    delay). ``thermal`` is the thermal stage's model record; when it holds no identified model
    the diagram says why. Returns the figure and the values it shows.
    """
    from selfsense.chapters import figures

    if thermal["identified"]:
        heat = f"τ = {thermal['tau']:.1f} s, γ = {thermal['gamma']:.1f} K/W"
        ambient = f"T_amb = {thermal['T_amb']:.1f} °C"
    else:
        heat = "τ, γ not identified:\n" + "\n".join(textwrap.wrap(thermal["reason"], 28))
        ambient = "T_amb: not identified"
    shown = {
        "tau [s]": thermal.get("tau"),
        "gamma [K/W]": thermal.get("gamma"),
        "T_amb [°C]": thermal.get("T_amb"),
        "k/alpha [V/m]": k_over_alpha,
        "Gamma_T order": gamma_t.order,
        "g [µm/K]": gamma_t.g,
        "a0 [C/m]": gains.a0,
        "omega_S [rad/s]": gains.omega_s,
        "zeta_S": gains.zeta_s,
        "L_P": gains.LP,
        "L_I": gains.LI,
        "np": plan.n_periods,
        "C_e rate [Hz]": plan.fr_folded,
        "interval [s]": interval,
    }
    heating = {
        "x": {"xy": (5, 12), "text": "x̂ from (b)", "kind": "port", "size": (9, 4)},
        "U": {"xy": (5, 30), "text": "U\n(drive voltage)", "kind": "port", "size": (9, 6)},
        "I": {
            "xy": (44, 8),
            "text": "I (drive current,\nas measured)",
            "kind": "port",
            "size": (14, 6),
        },
        "gain": {
            "xy": (20, 12),
            "text": f"k/α\n{k_over_alpha * 1e-6:.3g} V/µm\n(Case 2 k, α; Ch 4)",
            "kind": "box",
            "size": (14, 9),
        },
        "sum": {"xy": (30, 30), "kind": "sum"},
        "mul": {"xy": (44, 30), "kind": "mul"},
        "mean": {
            "xy": (59, 30),
            "text": f"mean over\n{interval:g} s",
            "kind": "box",
            "size": (11, 8),
        },
        "model": {
            "xy": (78, 30),
            "text": f"γ / (τs + 1)\n{heat}\nexact ZOH at {interval:g} s",
            "kind": "box",
            "size": (20, 13 if thermal["identified"] else 16),
        },
        "amb": {"xy": (92, 12), "text": ambient, "kind": "port", "size": (16, 4)},
        "tsum": {"xy": (92, 30), "kind": "sum"},
        "T": {"xy": (100, 40), "text": "T_SH(HPO)\nto Γ_T (b)", "kind": "port", "size": (9, 6)},
    }
    heating_wires = [
        ("x", "gain", r"$\hat{x}$", (), None),
        ("gain", "sum", r"$U_\mathrm{P}$", ((30, 12),), "−"),
        ("U", "sum", "$U$", (), "+"),
        ("sum", "mul", r"$U_\mathrm{H}$", (), None),
        ("I", "mul", "$I$", (), None),
        ("mul", "mean", r"$P_\mathrm{loss}$", (), None),
        ("mean", "model", r"$\bar{P}$", (), None),
        ("model", "tsum", r"$\Delta T$", (), "+"),
        ("amb", "tsum", "", (), "+"),
        ("tsum", "T", "", ((100, 30),), None),
    ]
    observer = {
        "ripple": {"xy": (5, 30), "text": "U_r, I_r\n(ripple)", "kind": "port", "size": (8, 6)},
        "ce": {
            "xy": (20, 30),
            "text": f"C_e (Eq 3.12)\nnp = {plan.n_periods} folded periods,\n"
            f"one per {1e3 / plan.fr_folded:g} ms",
            "kind": "box",
            "size": (17, 9),
        },
        "T": {
            "xy": (42, 43),
            "text": f"T_SH(HPO) from (a), held {interval:g} s",
            "kind": "port",
            "size": (26, 3),
        },
        "gamma": {
            "xy": (42, 30),
            "text": f"Γ_T(C_e, T) (Eq 7.13)\norder {gamma_t.order}, g = {gamma_t.g:.3g} µm/K\n"
            "held to the next window",
            "kind": "box",
            "size": (19, 9),
        },
        "s1": {"xy": (60, 30), "kind": "sum"},
        "L": {
            "xy": (76, 30),
            "text": f"L(s) = L_P + L_I / s\nL_P = {gains.LP:.4g} A/m\nL_I = {gains.LI:.4g} A/(m s)",
            "kind": "box",
            "size": (18, 9),
        },
        "I": {"xy": (56, 8), "text": "I (drive current)", "kind": "port", "size": (12, 3)},
        "s2": {"xy": (76, 8), "kind": "sum"},
        "int": {
            "xy": (89, 8),
            "text": f"1 / (a0 s)\na0 = {gains.a0:.3g} C/m",
            "kind": "box",
            "size": (12, 7),
        },
        "node": {"xy": (98, 8), "kind": "node"},
        "out": {"xy": (98, 20), "text": "x̂ to (a)", "kind": "port", "size": (8, 3)},
    }
    observer_wires = [
        ("ripple", "ce", "", (), None),
        ("ce", "gamma", r"$C_\mathrm{e}$", (), None),
        ("T", "gamma", "$T$", (), None),
        ("gamma", "s1", r"$x_\mathrm{CP}$", (), "−"),
        ("s1", "L", "", (), None),
        ("L", "s2", r"$\hat{I}_0$", (), "−"),
        ("I", "s2", "$I$", (), "+"),
        ("s2", "int", "", (), None),
        ("int", "node", "", (), None),
        ("node", "s1", r"$\hat{x}$", ((102, 8), (102, 38), (60, 38)), "+"),
        ("node", "out", "", (), None),
    ]
    fig = figures.block_diagram(
        [
            (
                "(a) Self-heat generation model with HPO input (Eq 7.10–7.12)",
                heating,
                heating_wires,
            ),
            (
                "(b) Temperature-compensated HPO (Eq 5.5–5.9, 7.13), "
                f"Tustin at {plan.fs / 1e3:g} kHz; "
                f"T and x̂ exchanged every {interval:g} s",
                observer,
                observer_wires,
            ),
        ]
    )
    return fig, shown
