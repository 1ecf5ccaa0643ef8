"""Chapter 4: identification over all sets — Tables 4.1–4.3 and Figures 4.2–4.8."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from selfsense.chapters import figure_names, figures
from selfsense.methods.electromech import (
    ChargeFit,
    Geometry,
    ModelParameters,
    SetIdentification,
    as_row,
    identify_set,
    kinematics,
    material_properties,
    sensitivity,
    slope_is_consistent,
)

#: Table 4.2 rows: (key, label, unit, scale from SI to the unit)
PARAMETERS = (
    ("C_P0", "capacitance at 0 V, C_P0", "µF", 1e6),
    ("C_P100", "capacitance at full stroke, C_P100", "µF", 1e6),
    ("dC_x", "capacitance slope, ΔCx", "F/m", 1.0),
    ("k", "stiffness, k", "N/µm", 1e-6),
    ("alpha", "force–voltage factor, α", "N/V", 1.0),
    ("b", "damping, b", "N s/m", 1.0),
    ("m", "moving mass, m (input)", "kg", 1.0),
    ("C_T", "free capacitance, C_T", "µF", 1e6),
    ("eps_T", "relative free permittivity, ε_T", "-", 1.0),
    ("d33", "strain coefficient, d33", "pm/V", 1e12),
    ("k33", "coupling coefficient, k33", "-", 1.0),
    ("U_P_max", "piezo voltage at full stroke, U_Pmax", "V", 1.0),
)

#: published values (thesis Tables 4.2, 4.3; Table 2.1 for the manufacturer), in table units
THESIS_CASE1 = {"C_P0": 3.13, "C_P100": 3.13, "dC_x": 0.0, "k": 11.20}
THESIS_CASE2 = {
    "C_P0": 3.13,
    "C_P100": 2.16,
    "dC_x": -0.03,
    "k": 25.1,
    "alpha": 9.36,
    "d33": 700.0,
    "k33": 0.72,
    "U_P_max": 86.0,
}
MANUFACTURER = {"C_P0": 3.1, "k": 25.0}
SENSITIVITY_CHANGES = {
    "no change": (1.0, 1.0),
    "+20 % C_P0": (1.2, 1.0),
    "+20 % ΔCx": (1.0, 1.2),
    "+20 % both": (1.2, 1.2),
}
THESIS_TABLE_4_3 = {
    "k": (25.1, 20.7, 24.0, 20.9),
    "alpha": (9.36, 7.72, 10.77, 9.36),
    "d33": (700, 697, 841, 840),
    "k33": (0.72, 0.66, 0.77, 0.73),
    "U_P_max": (86, 86, 72, 72),
}


#: the column of rule static_stiffness's table that holds k (Eq 4.16) [N/µm]
STATIC_K = "k [N/µm]"


def load_static_stiffness(path) -> float:
    """k [N/m] from rule static_stiffness's table (Eq 4.16): the k Case 1 is identified with."""
    return float(pd.read_csv(path)[STATIC_K].iloc[0]) * 1e6


def set_frame(series: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """One set's series with the position zeroed at its start, as the thesis recorded it."""
    return dict(series) | {"x_laser": series["x_laser"] - series["x_laser"][0]}


def identify_sets(
    sets: Mapping[str, Mapping[str, np.ndarray]], k_static: float, m: float, geometry: Geometry
) -> tuple[pd.DataFrame, dict[str, SetIdentification]]:
    """Both cases for every set: one row per (set, case) in SI units, and the fits."""
    rows, fits = [], {}
    for name, raw in sets.items():
        s = set_frame(raw)
        fit = identify_set(s["time"], s["C_e"], s["x_laser"], s["q"], s["I"], k_static, m)
        fits[name] = fit
        for p in (fit.case1, fit.case2):
            mp = material_properties(p, geometry, fit.x_max)
            rows.append(
                {"set": name, "frequency [Hz]": _frequency(name)}
                | as_row(p, mp)
                | {
                    "C_P100": float(p.capacitance(fit.x_max)),
                    "alpha_from_current": fit.alpha_from_current if p.case == 2 else np.nan,
                    "k_from_current": fit.k_from_current if p.case == 2 else np.nan,
                    "x_max": fit.x_max,
                    "Eq 4.15 has a real root": (
                        slope_is_consistent(fit.charge_linear.a1, p.C_P0, k_static)
                        if p.case == 1
                        else np.nan
                    ),
                }
                | {
                    f"charge_{k}": v
                    for k, v in vars(
                        fit.charge_linear if p.case == 1 else fit.charge_quadratic
                    ).items()
                }
            )
    return pd.DataFrame(rows), fits


def fits_from_table(per_set: pd.DataFrame) -> dict[str, SetIdentification]:
    """Rebuild the fits from the per-set table, so figures need not identify again."""
    model_keys = ("case", "C_P0", "dC_x", "k", "alpha", "b", "m")
    charge_keys = ("a1", "a2", "q0", "I0", "rms_residual")
    fits = {}
    for name, rows in per_set.groupby("set", sort=False):
        by_case = {int(r["case"]): r for _, r in rows.iterrows()}
        params = {c: ModelParameters(*(r[k] for k in model_keys)) for c, r in by_case.items()}
        charges = {
            c: ChargeFit(*(r[f"charge_{k}"] for k in charge_keys)) for c, r in by_case.items()
        }
        two = by_case[2]
        fits[name] = SetIdentification(
            params[1],
            params[2],
            charges[1],
            charges[2],
            two["alpha_from_current"],
            two["k_from_current"],
            two["x_max"],
        )
    return fits


def _frequency(name: str) -> float:
    token = next(t for t in name.split("_") if t.endswith("hz"))
    return float(token[:-2].replace("p", "."))


def table_4_2(per_set: pd.DataFrame) -> pd.DataFrame:
    """Mean and standard deviation over the sets, beside the manufacturer's and the thesis's
    values."""
    rows = []
    for key, label, unit, scale in PARAMETERS:
        row = {"parameter": label, "unit": unit}
        for case in (1, 2):
            values = per_set.loc[per_set["case"] == case, key] * scale
            row[f"case {case} mean"] = values.mean()
            row[f"case {case} std"] = values.std(ddof=1) if len(values) > 1 else np.nan
        row["manufacturer"] = MANUFACTURER.get(key, np.nan)
        row["thesis case 1"] = THESIS_CASE1.get(key, np.nan)
        row["thesis case 2"] = THESIS_CASE2.get(key, np.nan)
        rows.append(row)
    return pd.DataFrame(rows)


def table_4_3(fits: Mapping[str, SetIdentification], geometry: Geometry) -> pd.DataFrame:
    """Sensitivity of k, α, d33, k33, U_Pmax to +20 % in C_P0, ΔCx and both (set means), from the
    quadratic q(x) fit (Eq 4.18); beside "no change", k and α from current over velocity (Eq 4.19),
    the thesis's alternative."""
    per_set = [
        sensitivity(
            f.charge_quadratic, f.case2.C_P0, f.case2.dC_x, geometry, f.x_max, SENSITIVITY_CHANGES
        )
        for f in fits.values()
    ]
    scale = {"k": 1e-6, "alpha": 1.0, "d33": 1e12, "k33": 1.0, "U_P_max": 1.0}
    unit = {"k": "N/µm", "alpha": "N/V", "d33": "pm/V", "k33": "-", "U_P_max": "V"}
    rows = []
    for key in scale:
        row = {"parameter": key, "unit": unit[key]}
        for i, label in enumerate(SENSITIVITY_CHANGES):
            row[label] = float(np.mean([s[label][key] for s in per_set])) * scale[key]
            row[f"thesis {label}"] = THESIS_TABLE_4_3[key][i]
        current = {
            "k": [f.k_from_current for f in fits.values()],
            "alpha": [f.alpha_from_current for f in fits.values()],
        }
        row["no change, Eq 4.19"] = (
            float(np.mean(current[key])) * scale[key] if key in current else np.nan
        )
        rows.append(row)
    return pd.DataFrame(rows)


def table_4_1() -> pd.DataFrame:
    """Literature comparison, carried as published data (thesis Table 4.1; not computed here)."""
    rows = [
        ("Goldfarb et al.", "NEC AE0505D16", 10.00, 9.31, 1.20, 1.40, 6.00, 48.85),
        ("Badel et al.", "NEC AE0505D44H40F", 7.19, 9.31, 2.77, 3.40, 28.70, 20.24),
        ("Juhasz et al.", "PI P885-50", 17.55, 8.05, 1.50, 1.50, 100.29, 50.00),
    ]
    cols = [
        "model",
        "actuator",
        "α identified [N/V]",
        "α manufacturer [N/V]",
        "C_P identified [µF]",
        "C_P manufacturer [µF]",
        "k_P identified [N/µm]",
        "k_P manufacturer [N/µm]",
    ]
    table = pd.DataFrame(rows, columns=cols)
    table["source"] = "published: Islam 2013 Table 4.1"
    return table


def hysteresis_voltage(sets, fits, per_frequency=(10.0, 100.0)) -> tuple[pd.DataFrame, dict]:
    """U_H = U − U_P for both models (Eq 1.6, 4.21) and its share of U, per frequency."""
    rows, traces = [], {}
    for name, fit in fits.items():
        f = _frequency(name)
        if f not in per_frequency or f in traces:
            continue
        s = set_frame(sets[name])
        kin = kinematics(s["time"], s["x_laser"])
        q = s["q"] - fit.charge_quadratic.q0 - fit.charge_quadratic.I0 * s["time"]
        traces[f] = {"q": q, "U": s["U"]}
        for p in (fit.case1, fit.case2):
            u_h = s["U"] - p.piezo_voltage(kin)
            traces[f][f"U_H case {p.case}"] = u_h
            rows.append(
                {
                    "frequency [Hz]": f,
                    "case": p.case,
                    "max |U_H| [V]": float(np.nanmax(np.abs(u_h))),
                    "U_H share of max U [%]": 100
                    * float(np.nanmax(np.abs(u_h)) / np.nanmax(s["U"])),
                }
            )
    return pd.DataFrame(rows), traces


#: file names of the figures :func:`figures_ch4` builds, in its order
FIGURES = figure_names.CH4


def figures_ch4(sets, fits, force, drive) -> dict:
    """Figures 4.2–4.8 from the sets' series (set 1 at each frequency) and two captures."""
    first = {}
    for name in sets:
        first.setdefault(_frequency(name), name)
    by_f = {f"{f:g} Hz": set_frame(sets[n]) for f, n in sorted(first.items())}
    capacitance = figures.loop(
        [s["x_laser"] * 1e6 for s in by_f.values()],
        [s["C_e"] * 1e6 for s in by_f.values()],
        "x [µm]",
        "C_e [µF]",
        "Capacitance against position",
        labels=list(by_f),
    )
    ratio_x, ratio = [], []
    for label, s in by_f.items():
        kin = kinematics(s["time"], s["x_laser"])
        fast = np.abs(kin.v) > 0.5 * np.max(np.abs(kin.v))
        ratio_x.append(kin.x[fast] * 1e6)
        ratio.append(s["I"][fast] / kin.v[fast])
    current_ratio = figures.loop(
        ratio_x,
        ratio,
        "x [µm]",
        "I/ẋ [C/m]",
        "Current over velocity against position",
        labels=list(by_f),
    )
    qs, qm, xs, i_meas, i_model = [], [], [], [], []
    for f, name in sorted(first.items()):
        s, fit = by_f[f"{f:g} Hz"], fits[name]
        kin = kinematics(s["time"], s["x_laser"])
        q = s["q"] - fit.charge_quadratic.q0 - fit.charge_quadratic.I0 * s["time"]
        model = fit.case2.charge(kin)
        xs.append(kin.x * 1e6)
        qs.append(q * 1e6)
        qm.append(model * 1e6)
        i_meas.append(s["I"] - fit.charge_quadratic.I0)
        i_model.append(np.gradient(model, s["time"]))
    labels = list(by_f)
    _, traces = hysteresis_voltage(sets, fits)
    return dict(
        zip(
            FIGURES,
            (
                figures.time_traces(force["t"], [(force["F"], "F [N]")], "Force at 50 Hz"),
                capacitance,
                current_ratio,
                figures.time_traces(drive["t"], [(drive["U"], "U [V]")], "Driving signal at 10 Hz"),
                figures.model_vs_measured(xs, qs, qm, i_meas, i_model, labels),
                _figure_4_7(by_f, first, fits),
                figures.hysteresis_voltage(traces),
            ),
        )
    )


def _figure_4_7(by_f, first, fits):
    panels = {}
    for f in (10.0, 100.0):
        if f not in first:
            continue
        s, fit = by_f[f"{f:g} Hz"], fits[first[f]]
        kin = kinematics(s["time"], s["x_laser"])
        q1 = s["q"] - fit.charge_linear.q0 - fit.charge_linear.I0 * s["time"]
        q2 = s["q"] - fit.charge_quadratic.q0 - fit.charge_quadratic.I0 * s["time"]
        panels[f] = {
            "x": kin.x,
            "q": q2,
            "traditional": fit.case1.charge(kin),
            "proposed": fit.case2.charge(kin),
            "error traditional": q1 - fit.case1.charge(kin),
            "error proposed": q2 - fit.case2.charge(kin),
        }
    return figures.model_comparison(panels)
