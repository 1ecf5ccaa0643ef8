"""Chapter 7: self-heating — loss power, the thermal model (Table 7.1), Γ_T (Tables 7.2–7.3) and
the coupled observer/thermal estimation (Fig 7.9–7.12)."""

from __future__ import annotations

from typing import Iterable, Mapping

import numpy as np
import pandas as pd

from ..gamma import GammaPolynomial, anova_table, coefficient_table, fit_gamma, gamma_t_table
from ..observer import HPOGains
from ..ripple import RippleExtractor, SamplingPlan, WindowMeans
from ..selfsensing import SelfSensingChain
from ..thermal import (PowerAverager, SelfHeatingEstimator, ThermalModel, ThermalProperties, identify_series,
                       linear_fit, power_loss, predict_temperature)

THESIS_TABLE_7_1 = {"tau [s]": 100.0, "k_T [W/(m² K)]": 28.0, "gamma [K/W]": 57.0, "k/alpha [V/m]": 2.85e6,
                    "T_ref [°C]": 23.0}
THESIS_TABLE_7_2 = {"n=4": (0.998189, 0.998188, 0.474422), "n=5": (0.998194, 0.998193, 0.473808),
                    "n=6": (0.998194, 0.998193, 0.47377), "n=5 + C·T": (0.998193, 0.998193, 0.473825)}


def extract(chunks, fs: float, plan: SamplingPlan, k_over_alpha: float, interval: float, every: int):
    """Stream a capture into (a) mean loss power per interval from the laser position (Eq 7.4)
    and (b) C_e with the window-mean position, every ``every``-th ripple window (for Γ_T).

    Yields ({"time", "P_PS"}, {"time", "C_e", "x_laser"}) per chunk.
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
        keep = (blocks.sample_index // plan.ns) % every == 0
        yield ({"time": t, "P_PS": P},
               {"time": (blocks.sample_index[keep] - (plan.block_len - 1) / 2) / fs, "C_e": blocks.C_e[keep],
                "x_laser": xm[keep]})


def identify(series: Mapping[str, Mapping[str, np.ndarray]], props: ThermalProperties, T_amb: float | None):
    """τ and γ per heating run by least squares of the predicted against the measured T (Eq 7.4)."""
    rows, fits = [], {}
    for name, s in series.items():
        try:
            fit = identify_series(s["time"], s["T_mid"], s["P_PS"], T_amb=T_amb, T0="ambient", props=props)
        except ValueError as err:  # a run too short to see τ (e.g. the smoke campaign): say so
            rows.append({"run": name, "note": f"not identifiable: {err}"})
            continue
        span = float(s["time"][-1] - s["time"][0])
        if span < 3 * fit.tau or fit.r_squared < 0.9:
            rows.append({"run": name, "note": f"not identifiable: {span:.3g} s of data for τ = {fit.tau:.3g} s, "
                                              f"R² = {fit.r_squared:.3f}"})
            continue
        fits[name] = fit
        rows.append({"run": name, "tau [s]": fit.tau, "gamma [K/W]": fit.gamma,
                     "k_T from tau [W/(m² K)]": fit.k_T_from_tau, "k_T from gamma [W/(m² K)]": fit.k_T_from_gamma,
                     "R²": fit.r_squared, "max |T − fit| [K]": fit.residual_max,
                     "heating power [W]": _heating_power(s["P_PS"]),
                     "max rise [K]": float(np.max(s["T_mid"]) - fit.T_amb),
                     "T_amb [°C]": fit.T_amb, "note": ""})
    return pd.DataFrame(rows), fits


def _heating_power(P: np.ndarray) -> float:
    """Mean loss power while the drive heats (the cooling stretch at 0 V carries none)."""
    return float(np.mean(P[P > 0.5 * np.max(P)]))


def table_7_1(per_run: pd.DataFrame, k_over_alpha: float, T_ref: float) -> pd.DataFrame:
    ours = {"tau [s]": per_run["tau [s]"].mean(), "gamma [K/W]": per_run["gamma [K/W]"].mean(),
            "k_T [W/(m² K)]": 0.5 * (per_run["k_T from tau [W/(m² K)]"].mean() + per_run["k_T from gamma [W/(m² K)]"].mean()),
            "k/alpha [V/m]": k_over_alpha, "T_ref [°C]": T_ref}
    spread = {"tau [s]": per_run["tau [s]"].std(ddof=1), "gamma [K/W]": per_run["gamma [K/W]"].std(ddof=1),
              "k_T [W/(m² K)]": abs(per_run["k_T from tau [W/(m² K)]"].mean() - per_run["k_T from gamma [W/(m² K)]"].mean()) / 2}
    return pd.DataFrame([{"parameter": k, "reproduced": v, "spread": spread.get(k, np.nan),
                          "thesis": THESIS_TABLE_7_1[k]} for k, v in ours.items()])


def steady_rise_trends(per_run: pd.DataFrame, freq_runs: Mapping[str, float]) -> pd.DataFrame:
    """Fig 7.2: the steady rise (γ·P) against drive frequency at 100 V, with a linear fit."""
    sel = per_run[per_run["run"].isin(freq_runs)]
    f = np.array([freq_runs[r] for r in sel["run"]])
    rise = (sel["gamma [K/W]"] * sel["heating power [W]"]).to_numpy()
    fit = linear_fit(f, rise)
    return pd.DataFrame({"frequency [Hz]": f, "steady rise [K]": rise, "fit slope [K/Hz]": fit.slope,
                         "fit intercept [K]": fit.intercept, "fit R²": fit.r_squared})


def voltage_trend(series: Mapping[str, np.ndarray], segments, model: ThermalModel) -> pd.DataFrame:
    """Fig 7.3: the steady rise γ·P per voltage step at 150 Hz against V², with a linear fit."""
    rows, start = [], 0.0
    for seg in segments:
        sel = (series["time"] >= start + 0.5 * seg["duration"]) & (series["time"] < start + seg["duration"])
        rows.append({"voltage [V]": seg["hi"], "steady rise [K]": model.gamma * float(np.mean(series["P_PS"][sel]))})
        start += seg["duration"]
    table = pd.DataFrame(rows)
    fit = linear_fit(table["voltage [V]"] ** 2, table["steady rise [K]"])
    return table.assign(**{"fit slope [K/V²]": fit.slope, "fit R²": fit.r_squared})


def prediction_errors(series: Mapping[str, Mapping[str, np.ndarray]], model: ThermalModel, T_amb: float) -> pd.DataFrame:
    """Figs 7.5–7.6: T predicted from the loss power against the measured T, max error."""
    rows = []
    for name, s in series.items():
        T = predict_temperature(s["time"], s["P_PS"], model, T0=T_amb, T_amb=T_amb)
        err = T - s["T_mid"]
        rows.append({"run": name, "max |T_SH(PS) − T| [K]": float(np.max(np.abs(err))),
                     "max rise [K]": float(np.max(s["T_mid"]) - T_amb),
                     "error [% of max rise]": 100 * float(np.max(np.abs(err))) / max(float(np.max(s["T_mid"]) - T_amb), 1e-9)})
    return pd.DataFrame(rows)


def gamma_t(samples: Mapping[str, np.ndarray], T_mid_time, T_mid, orders=(4, 5, 6), order: int = 5):
    """Tables 7.2 and 7.3 from C_e, position and the interpolated temperature (Eq 7.13)."""
    T = np.interp(samples["time"], T_mid_time, T_mid)
    ok = np.isfinite(samples["C_e"]) & np.isfinite(samples["x_laser"])
    C, x, T = samples["C_e"][ok], samples["x_laser"][ok], T[ok]
    t72 = gamma_t_table(C, x, T, orders=tuple(orders), interaction_order=order)
    fit = fit_gamma(C, x, order, temperature=T)
    return t72, anova_table(fit).reset_index(names="source"), coefficient_table(fit).reset_index(names="coefficient"), fit


def coupled_estimation(chunks, fs: float, plan: SamplingPlan, gamma: GammaPolynomial, gains: HPOGains,
                       model: ThermalModel, k_over_alpha: float, T_amb: float, warmup: float,
                       interval: float = 0.1):
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
    return out, {"max observer error [µm]": err_max * 1e6, "stroke [µm]": stroke * 1e6,
                 "max observer error [% of stroke]": 100 * err_max / stroke}
