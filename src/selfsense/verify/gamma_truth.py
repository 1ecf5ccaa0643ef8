"""Γ and Γ_T refitted on the twin's truth: what sets a fitted curve's distance from the thesis's
(a verification step, like the error budgets: it reads a simulated capture's ``/truth`` group).

A Γ fitted on the twin's captures (Eq 5.4, Table 5.2; Γ_T, Eq 7.13, Tables 7.2–7.3) can differ from
the one the thesis prints for two reasons: the twin's C–x(–T) relation is not the bench's (the
twin's clamped capacitance falls linearly with x, Eq 4.4 with Table 4.2's ΔCx, plus the domain
state's share and κ_T (T − 23 °C); docs/twin.md), and the measured inputs — C_e from the ripple,
x from the laser, T from the middle IR thermometer — carry their errors into the fit. Refitting
with the measured inputs replaced by the twin's noiseless values over the same ripple windows,
in every combination, separates the two: the fit on the truth alone is the twin's own Γ,
and each substitution shows what that input's measurement moves. The measured variant is the
pipeline's own fit, so its numbers are those of ``curve_vs_thesis`` and Table 7.2.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from selfsense.chapters.ch5 import gamma_data
from selfsense.chapters.ch7 import gamma_t_data, while_driven
from selfsense.io.capture import open_capture, read_series
from selfsense.methods.gamma import (
    GammaPolynomial,
    coefficient_table,
    curve_difference,
    fit_gamma,
    load_gamma,
)
from selfsense.methods.ripple import plan_from_capture
from selfsense.verify.truth import Truth

#: the fitted inputs and the truth state each is replaced by
TRUE_STATE = {"C_e": "C_e", "x": "x", "T": "T"}
MEASURED = "measured"
ALL_TRUE = "all true"
DISTANCE = "max |Γ − Γ_thesis| [µm]"
RESIDUAL = "residual standard error [µm]"
SLOPE_T = "g [µm/K]"
SLOPE_T_T = "t of g"
INTERACTION = "g_CT [µm/(µF·K)]"
INTERACTION_T = "t of g_CT"


def window_truth(
    truth: Truth, time: np.ndarray, fs: float, block_len: int, names: Sequence[str]
) -> dict[str, np.ndarray]:
    """The truth states ``names`` averaged over the ripple windows a series was taken over: a
    window of ``block_len`` samples centred on each ``time`` [s]
    (:func:`selfsense.methods.ripple.impedance_series`)."""
    last = np.rint(np.asarray(time) * fs + (block_len - 1) / 2).astype(np.int64)
    means = truth.means(last, block_len)
    return {name: means[name] for name in names}


def variants(
    measured: Mapping[str, np.ndarray], true: Mapping[str, np.ndarray]
) -> dict[str, dict[str, np.ndarray]]:
    """The fit's inputs with every subset of them replaced by the truth: as measured, "true C_e",
    "true C_e + T", …, all true. Every subset, not one input at a time: the inputs' errors need not
    add up in a fit (a slow laser drift and the thermometer's lag, both following the heating,
    move the same coefficients)."""
    names = list(measured)
    out = {}
    for size in range(len(names) + 1):
        for subset in itertools.combinations(names, size):
            label = (
                MEASURED
                if not subset
                else ALL_TRUE
                if size == len(names)
                else "true " + " + ".join(subset)
            )
            out[label] = {n: (true if n in subset else measured)[n] for n in names}
    return out


def curve_rows(
    data: Mapping[str, Mapping[str, np.ndarray]],
    orders: Mapping[str, int],
    printed: GammaPolynomial,
    x_max_um: float,
    temperatures: Sequence[float] = (0.0,),
    interaction_order: int | None = None,
) -> pd.DataFrame:
    """One row per fit of ``orders`` ({name: order}), in columns "<quantity>, <variant>" for each
    variant of :func:`variants`: max |Γ − Γ_thesis| over the printed curve's C range
    (:func:`selfsense.methods.gamma.curve_difference`), the residual standard error (the scatter
    Tables 5.2 and 7.2–7.3 report through R², MS and F) and, with a temperature, g and its t
    statistic. With ``interaction_order`` (Γ_T), a row more: the fit with a C·T term (Table 7.2's
    last column), its coefficient and t statistic (the t, not Table 7.2's p, which underflows to 0
    for every |t| above ≈ 38)."""
    rows = []
    for name, order in orders.items():
        row: dict[str, object] = {"fit": name, "order": order}
        for variant, d in data.items():
            fit = fit_gamma(d["C_e"], d["x"], order, temperature=d.get("T"))
            row[f"{DISTANCE}, {variant}"] = curve_difference(
                GammaPolynomial.from_fit(fit), printed, x_max_um, temperatures
            )[DISTANCE]
            row |= _statistics(fit, variant, {"g": (SLOPE_T, SLOPE_T_T)} if "T" in d else {})
        rows.append(row)
    if interaction_order is not None:
        row = {"fit": "thesis order + C·T", "order": interaction_order}
        for variant, d in data.items():
            fit = fit_gamma(
                d["C_e"], d["x"], interaction_order, temperature=d["T"], interaction=True
            )
            row |= _statistics(fit, variant, {"g_CT": (INTERACTION, INTERACTION_T)})
        rows.append(row)
    return pd.DataFrame(rows)


def _statistics(fit, variant: str, coefficients: Mapping[str, tuple[str, str]]) -> dict[str, float]:
    """A fit's residual standard error and, for each of ``coefficients`` ({name: (column of its
    value, column of its t)}), its value and t statistic, in columns for ``variant``."""
    out = {f"{RESIDUAL}, {variant}": float(np.sqrt(fit.results.mse_resid))}
    if coefficients:
        table = coefficient_table(fit)
        for name, (value, t) in coefficients.items():
            out |= {
                f"{value}, {variant}": float(table.loc[name, "Coefficients"]),
                f"{t}, {variant}": float(table.loc[name, "t Stat"]),
            }
    return out


def gamma_variants(
    series: Mapping[str, np.ndarray],
    truth: Truth,
    fs: float,
    block_len: int,
    n_periods: int,
    warmup: float,
) -> dict[str, dict[str, np.ndarray]]:
    """:func:`variants` of Γ's data (Table 5.2): the windows
    :func:`selfsense.chapters.ch5.gamma_data` keeps of the 0.1 Hz run's ripple ``series``, the
    twin's x zeroed at the first as the laser's is."""
    kept = {
        k: np.asarray(v)[::n_periods] for k, v in series.items()
    }  # gamma_data(kept, 1) = gamma_data(series, np)
    true = window_truth(truth, kept["time"], fs, block_len, ("C_e", "x"))
    as_series = kept | {
        "C_e": np.where(np.isfinite(kept["C_e"]), true["C_e"], np.nan),
        "x_laser": np.where(np.isfinite(kept["x_laser"]), true["x"], np.nan),
    }
    (C, x), (C_true, x_true) = gamma_data(kept, 1, warmup), gamma_data(as_series, 1, warmup)
    return variants({"C_e": C, "x": x}, {"C_e": C_true, "x": x_true})


def gamma_t_variants(
    samples: Mapping[str, np.ndarray],
    T_time: np.ndarray,
    T_mid: np.ndarray,
    truth: Truth,
    fs: float,
    block_len: int,
) -> dict[str, dict[str, np.ndarray]]:
    """:func:`variants` of Γ_T's data (Eq 7.13, Tables 7.2–7.3): the heating run's C_e windows
    :func:`selfsense.chapters.ch7.gamma_t_data` uses, the twin's x zeroed at the run's first sample
    as the laser's is (:func:`selfsense.chapters.ch7.extract`), its T the stack's own."""
    true = window_truth(truth, samples["time"], fs, block_len, ("C_e", "x", "T"))
    ok = np.isfinite(samples["C_e"]) & np.isfinite(samples["x_laser"])
    C, x, T = gamma_t_data(samples, T_time, T_mid)
    x0 = truth.at(np.zeros(1))["x"][0]
    return variants(
        {"C_e": C, "x": x, "T": T},
        {"C_e": true["C_e"][ok], "x": true["x"][ok] - x0, "T": true["T"][ok]},
    )


def capture_variants(
    capture,
    series: Mapping[str, np.ndarray],
    n_periods: int,
    thermometer: Mapping[str, np.ndarray] | None = None,
    span: tuple[float, float] | None = None,
) -> dict[str, dict[str, np.ndarray]]:
    """:func:`gamma_variants` of a simulated capture's ripple ``series`` or, given the middle
    thermometer's ``thermometer`` ({"time", "T_mid"}), :func:`gamma_t_variants` of its Γ_T
    samples inside the drive's ``span`` [s], those rule gamma_t_fit fits
    (:func:`selfsense.chapters.ch7.while_driven`; None: all of them)."""
    with open_capture(capture) as cap:
        truth = Truth.from_capture(cap, names=("C_e", "x", "T"))
        fs, block_len, warmup = (
            cap.fs,
            plan_from_capture(cap, n_periods).block_len,
            float(cap.attrs.get("warmup_s", 0.0)),
        )
    if thermometer is None:
        return gamma_variants(series, truth, fs, block_len, n_periods, warmup)
    driven = series if span is None else while_driven(series, span)
    return gamma_t_variants(driven, thermometer["time"], thermometer["T_mid"], truth, fs, block_len)


def truth_refits(
    capture,
    series,
    fits: Mapping[str, str],
    printed: GammaPolynomial,
    x_max_um: float,
    n_periods: int,
    temperatures: Sequence[float] = (0.0,),
    power=None,
    span: tuple[float, float] | None = None,
) -> pd.DataFrame:
    """Rule gamma_truth's table: :func:`curve_rows` of every fit the pipeline made of Γ (Eq 5.4,
    Table 5.2) or, given the thermometers' ``power`` series, of Γ_T (Eq 7.13, Tables 7.2–7.3, with
    the C·T row at the order of the fit named "thesis order"), refitted on :func:`capture_variants`
    of the simulated ``capture`` and its ripple or Γ_T sample ``series``, against the ``printed``
    curve over its stroke ``x_max_um`` [µm] at ``temperatures`` [°C] (Γ_T's, on the samples
    inside its drive's ``span``).

    ``fits``: {name: path of a fit's record (:func:`selfsense.methods.gamma.load_gamma`)}, each
    refitted at its order; every path (the capture, the series, the fits, ``power``) is read
    here."""
    thermometer = read_series(power, ["time", "T_mid"]) if power else None
    data = capture_variants(capture, read_series(series), n_periods, thermometer, span)
    orders = {name: load_gamma(path).order for name, path in fits.items()}
    interaction = orders["thesis order"] if thermometer is not None else None
    return curve_rows(data, orders, printed, x_max_um, temperatures, interaction)
