"""Chapter 7's coupled temperature error split into its sources with the twin's truth.

A verification step, like :mod:`selfsense.verify.error_budget` and
:mod:`selfsense.verify.tracking_budget`: it needs a simulated capture's ``/truth`` group, so it
runs on the twin's datasets only. Rule `coupled` (:func:`selfsense.chapters.ch7.coupled_estimation`)
predicts the stack's temperature with the identified first-order model γ/(τs + 1) (Eq 7.4),
stepped exactly (zero-order hold) over 0.1 s intervals from T_amb and driven by the loss power
(U − (k/α)x)·I averaged over each (Eq 7.10, 7.12): x the laser's position for T_SH(PS), the
observer's estimate for T_SH(HPO).
:func:`selfsense.chapters.ch7.against_measured` takes each estimate's max |T_SH − T_mid| against
the middle IR thermometer over every sample of the traces. With T_model(P_true) the same model,
stepped the same way, driven by the twin's true heat over the same intervals, and T the stack's
true temperature, that error splits sample by sample on the traces' 10 Hz grid:

    T_SH − T_mid = [T_SH − T_model(P_true)] + [T_model(P_true) − T] + [T − T_mid]
                    power estimate            thermal model             thermometer

* ``power estimate``: the model is linear and both runs start at T_amb, so this is Eq 7.4 driven by
  P̂ − P_true: what the estimator's loss power misses of the twin's heat (k/α, the position it
  multiplies, the measured U and I with the ripple and the probe's offset and resolution);
* ``thermal model``: the identified τ, γ and T_amb against the twin's own ρcv dT/dt =
  P − k_T A (T − T_amb) (Eq 7.2, stepped per sample), and the 10 Hz hold of the power against the
  twin's per-sample heat;
* ``thermometer``: the IR thermometer's noise, its share of the rise and the ADC's step.

The true heat
-------------
The twin heats with its own hysteresis and creep loss (docs/twin.md), per sample
(U_drive − U_P)·(q[n] − q[n−1])·fs: U_drive − U_P = U_H + ΣU_c by the voltage balance (Eq 1.6),
the charge before the first sample zero as in the kernel's initial state. Its means over the
estimator's intervals are taken by the estimator's own
:class:`~selfsense.methods.thermal.PowerAverager`. The truth is stored every 12th sample (4 kHz);
the states are rebuilt at every sample by the 4-point cubic of
:meth:`selfsense.verify.truth.Truth.at` and summed as the kernel sums them. Against the kernel's
own 48 kHz sum on 0–100 V raised sines (the mixed run's drives), the interval means are off by
+0.004 % at 20 Hz, +0.002 % at 50 Hz and −0.08 % at 100 Hz (worst interval 0.13 %), +0.07 % at
200 Hz: what the cubic misses are the Maxwell operator's kinks, where an element saturates and at
the reversals. A straight line between stored samples would miss −0.13, −0.4 and −1.1 % (each
chord cuts the loop short), the kernel's right-endpoint sum taken at 4 kHz +1.3, +3.3 and +6.2 %
(dU_H/dq ≥ 0 makes every step's ΔU_H·Δq count). On the mixed run's 100 Hz stretch, a rise of
about 30 K, −0.08 % is −0.03 K of T_model(P_true), carried by ``power estimate`` and
``thermal model`` with opposite signs (their sum does not use it); over the thesis campaign's
whole mixed run, the twin's own τ and γ driven by these means give its true T within 0.03 K
(rms 0.011 K).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from selfsense.chapters.ch7 import COUPLING_INTERVAL
from selfsense.io.capture import open_capture
from selfsense.methods.thermal import PowerAverager, ThermalModel, predict_temperature
from selfsense.verify.truth import Truth

#: the sources of the error, in the order of the module docstring
SOURCES = ("power estimate", "thermal model", "thermometer")

#: the estimates of rule `coupled`'s traces, by the name a budget row gives each
ESTIMATORS = {"PS": "T_SH_PS", "HPO": "T_SH_HPO"}

#: the /truth states the heat is made of, and the temperature
HEAT_STATES = ("q", "U_P", "U_drive")
TRUTH_STATES = (*HEAT_STATES, "T")


def true_heat(truth: Truth, fs: float, interval: float, n: int, block: int = 1 << 18) -> np.ndarray:
    """The twin's mean loss power [W] over each of the first ``n`` intervals of ``interval`` s, the
    zero-order-hold value Eq 7.4 takes (module docstring, "The true heat"); ``block`` samples at a
    time, so the memory does not grow with the capture.

    Past the last stored value (a capture's last ``decimation`` − 1 samples) :meth:`Truth.at` holds
    the nearest values, so an interval that ends there is not the twin's heat: when the traces cover
    the whole capture that is their last, whose power acts only after their last time stamp."""
    averager = PowerAverager(fs, interval)
    stop = n * averager.n_per_interval
    if not 0 < stop <= truth.n_samples:
        raise ValueError(
            f"{truth.source}: {n} intervals of {interval} s need {stop} samples, "
            f"the capture has {truth.n_samples}"
        )
    q_prev, means = 0.0, []
    for start in range(0, stop, block):
        v = truth.at(np.arange(start, min(start + block, stop)))
        dq = np.diff(v["q"], prepend=q_prev)
        q_prev = v["q"][-1]
        means.append(averager.update((v["U_drive"] - v["U_P"]) * dq * fs))
    return np.concatenate(means)


def split(
    T_SH: np.ndarray, T_mid: np.ndarray, T_model: np.ndarray, T_true: np.ndarray
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """T_SH − T_mid and its sources (module docstring), in kelvin."""
    return T_SH - T_mid, {
        "power estimate": T_SH - T_model,
        "thermal model": T_model - T_true,
        "thermometer": T_true - T_mid,
    }


def budget_row(
    t: np.ndarray, total: np.ndarray, parts: Mapping[str, np.ndarray]
) -> dict[str, float]:
    """An error's max as :func:`~selfsense.chapters.ch7.against_measured` takes it (every sample),
    each source's signed value at that instant (they add up to the error there), its max |.| and
    rms, and how far the sources' sum is from the error anywhere."""
    k = int(np.argmax(np.abs(total)))
    row = {
        "total max error [K]": float(abs(total[k])),
        "total at max [K]": float(total[k]),
        "time of max [s]": float(t[k]),
        "total rms [K]": float(np.sqrt(np.mean(total**2))),
    }
    for name, part in parts.items():
        row |= {
            f"{name} at max [K]": float(part[k]),
            f"{name} max [K]": float(np.max(np.abs(part))),
            f"{name} rms [K]": float(np.sqrt(np.mean(part**2))),
        }
    return row | {
        "max |sum of sources − total| [K]": float(np.max(np.abs(sum(parts.values()) - total))),
        "samples": int(total.size),
    }


def temperature_budget(
    traces: Mapping[str, np.ndarray],
    P_true: np.ndarray,
    T_true: np.ndarray,
    model: ThermalModel,
    T_amb: float,
    stats: Mapping[str, float] | None = None,
) -> pd.DataFrame:
    """One row per estimator of :data:`ESTIMATORS`: the budget of its error against ``traces``'
    T_mid (:func:`budget_row`), from the true mean power over each interval that starts at
    ``traces["time"]`` and the true temperature at those times.

    Given rule `coupled`'s ``stats``, each row also holds the max error they state, which must be
    the budget's: the traces are the arrays it was taken from.
    """
    t = np.asarray(traces["time"], dtype=float)
    T_model = predict_temperature(
        t, P_true, model, T0=T_amb, T_amb=T_amb
    )  # as coupled_estimation starts it
    rows = []
    for name, key in ESTIMATORS.items():
        row = {"estimator": name} | budget_row(
            t, *split(traces[key], traces["T_mid"], T_model, T_true)
        )
        if stats is not None:
            stated = float(stats[f"max |{key} − T| [K]"])
            if not np.isclose(stated, row["total max error [K]"], rtol=1e-12, atol=0.0):
                raise ValueError(
                    f"the traces' max |{key} − T_mid| is {row['total max error [K]']:.6g} K, the "
                    f"stats' {stated:.6g} K: traces and stats are not of one run"
                )
            row["stats max error [K]"] = stated
        rows.append(row)
    return pd.DataFrame(rows)


def capture_temperature_budget(
    path,
    traces: Mapping[str, np.ndarray],
    model: ThermalModel,
    T_amb: float,
    interval: float = COUPLING_INTERVAL,
    stats: Mapping[str, float] | None = None,
) -> pd.DataFrame:
    """:func:`temperature_budget` of rule `coupled`'s ``traces`` (time, T_SH_PS, T_SH_HPO, T_mid at
    the starts of its ``interval``-long steps) over the simulated capture ``path`` they come from,
    with the identified ``model`` and ``T_amb`` the estimator ran with."""
    t = np.asarray(traces["time"], dtype=float)
    if t.size < 2 or not np.allclose(
        t, np.arange(t.size) * interval, rtol=0.0, atol=1e-9 * interval
    ):
        raise ValueError(
            f"{path}: the traces are not on the estimator's grid of {interval} s steps from 0"
        )
    with open_capture(path) as cap:
        attrs, states = cap.read_truth()
        fs, n_samples = cap.fs, cap.length()
    states = {k: states[k] for k in TRUTH_STATES if k in states}  # the rest of /truth can go
    heat = Truth.from_group(attrs, states, n_samples, str(path), names=HEAT_STATES)
    temperature = Truth.from_group(attrs, states, n_samples, str(path), names=("T",))
    P_true = true_heat(heat, fs, interval, t.size)
    T_true = temperature.at(np.rint(t * fs))["T"]
    return temperature_budget(traces, P_true, T_true, model, T_amb, stats)
