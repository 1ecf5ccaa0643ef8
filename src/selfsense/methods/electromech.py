"""Electromechanical model identification (thesis Chapter 4, Eq 4.15–4.25).

Two cases, as the thesis compares them:

* Case 1, the traditional model with constant capacitance: C_P from the ripple measurement at
  x = 0, k from the static blocked-force / free-stroke test (Eq 4.16), α from the slope of the
  quasi-static charge–position line (Eq 4.15), b by Nelder–Mead on Eq 4.17.
* Case 2, the proposed model with position-dependent capacitance: C_P0 and ΔCx from C_e against
  x (Eq 4.4), k and α from the quadratic q(x) (Eq 4.18), checked against current over velocity
  (Eq 4.19), b by Nelder–Mead on Eq 4.20–4.21.

The moving mass m is not identified (the experiments run far below the bench mode); it is an
input, m_needle + m_stack/3 (§4.3.1). Charge is the integral of the measured current, whose
probe offset I_0 would make it drift: the charge fits therefore carry a q0 + I_0·t term,
estimated together with the model coefficients.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

# scipy.optimize and scipy.signal are imported where used: the closed-loop simulations import this
# module for k/α alone, and the two cost them ≈ 0.5 s of start-up.

EPS0 = 8.8541878128e-12  # vacuum permittivity [F/m]


@dataclass(frozen=True)
class Geometry:
    """Stack geometry for the material properties (Table 2.1)."""

    area: float  # electrode / cross-section area A [m²]
    layer_thickness: float  # t_P [m]
    active_length: float  # L_P [m]

    @property
    def layers(self) -> float:
        return self.active_length / self.layer_thickness


@dataclass(frozen=True)
class Kinematics:
    """Position and its derivatives on a uniform time grid (SI)."""

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray


def kinematics(t: np.ndarray, x: np.ndarray, window_s: float = 2.5e-3) -> Kinematics:
    """Velocity and acceleration by Savitzky–Golay differentiation of the measured position.

    The position itself is kept as measured: smoothing it would bias its amplitude at the
    higher drive frequencies, and the fits it enters average the noise out anyway.
    """
    from scipy.signal import savgol_filter

    dt = float(np.median(np.diff(t)))
    n = max(5, int(round(window_s / dt)) | 1)
    return Kinematics(
        t,
        np.asarray(x, dtype=float),
        savgol_filter(x, n, 3, deriv=1, delta=dt),
        savgol_filter(x, n, 3, deriv=2, delta=dt),
    )


@dataclass(frozen=True)
class ChargeFit:
    """q_measured = q0 + I_0·t + a1·x + a2·x² (Eq 4.15 when a2 = 0, Eq 4.18 otherwise)."""

    a1: float  # [C/m]
    a2: float  # [C/m²]
    q0: float  # [C]
    I0: float  # current-probe offset [A]
    rms_residual: float  # [C]

    def charge(self, x: np.ndarray) -> np.ndarray:
        """The model's charge from position, offset-free."""
        return self.a1 * x + self.a2 * x * x


def fit_charge_position(
    t: np.ndarray, x: np.ndarray, q_measured: np.ndarray, quadratic: bool
) -> ChargeFit:
    """Least squares of the measured (integrated) charge on position, with offset drift terms."""
    columns = [np.ones_like(t), t, x] + ([x * x] if quadratic else [])
    design = np.column_stack(columns)
    ok = np.all(np.isfinite(design), axis=1) & np.isfinite(q_measured)
    coef, *_ = np.linalg.lstsq(design[ok], q_measured[ok], rcond=None)
    residual = q_measured[ok] - design[ok] @ coef
    q0, I0, a1 = coef[:3]
    return ChargeFit(
        float(a1),
        float(coef[3]) if quadratic else 0.0,
        float(q0),
        float(I0),
        float(np.sqrt(np.mean(residual**2))),
    )


def capacitance_line(C_e: np.ndarray, x: np.ndarray) -> tuple[float, float]:
    """C_e = C_P0 + ΔCx·x (Eq 4.4): returns (C_P0 [F], ΔCx [F/m])."""
    ok = np.isfinite(C_e) & np.isfinite(x)
    slope, intercept = np.polyfit(x[ok], C_e[ok], 1)
    return float(intercept), float(slope)


def static_stiffness(F_blocked_rise: float, x_free_rise: float) -> float:
    """k = F_ext at U_max with x = 0 over x at U_max with F = 0 (Eq 4.16)."""
    return F_blocked_rise / x_free_rise


def hold_rise(values: np.ndarray, t: np.ndarray, t_hold: float) -> float:
    """Rise of a signal from its start to the median of its hold (t ≥ t_hold)."""
    start = np.median(values[t < min(t[0] + 0.01, t_hold)])
    return float(np.median(values[t >= t_hold]) - start)


@dataclass(frozen=True)
class ModelParameters:
    """One identified parameter set (SI units)."""

    case: int
    C_P0: float
    dC_x: float
    k: float
    alpha: float
    b: float
    m: float

    @property
    def k_over_alpha(self) -> float:
        return self.k / self.alpha

    def capacitance(self, x):
        """C_P at position x (Eq 4.4)."""
        return self.C_P0 + self.dC_x * np.asarray(x)

    def piezo_voltage(self, kin: Kinematics) -> np.ndarray:
        """U_P = (m ẍ + b ẋ + k x)/α (Eq 4.21)."""
        return (self.m * kin.a + self.b * kin.v + self.k * kin.x) / self.alpha

    def charge(self, kin: Kinematics) -> np.ndarray:
        """Model charge from measured motion: Eq 4.17 (Case 1) or Eq 4.20 (Case 2)."""
        u_p = self.piezo_voltage(kin)
        return (
            self.C_P0 * u_p + 0.5 * self.dC_x * u_p * u_p / self.k_over_alpha + self.alpha * kin.x
        )


def alpha_from_slope(slope: float, C_P: float, k: float) -> float:
    """α from the linear charge–position slope s = C_P k/α + α (Eq 4.15).

    Of the two roots of α² − sα + C_P k = 0 the larger is taken: it is the one for which the
    mechanical term α dominates the slope. When no real root exists (s² < 4 C_P k: the static k
    and the slope cannot both hold for a constant-capacitance model), s/2 is returned, the α
    that comes closest (it minimises α² − sα + C_P k); :func:`slope_is_consistent` tells which.
    """
    disc = slope * slope - 4 * C_P * k
    return float((slope + np.sqrt(max(disc, 0.0))) / 2)


def slope_is_consistent(slope: float, C_P: float, k: float) -> bool:
    """Whether Eq 4.15 has a real α for this slope, capacitance and stiffness."""
    return slope * slope >= 4 * C_P * k


def fit_damping(params: ModelParameters, kin: Kinematics, q: np.ndarray, b0: float) -> float:
    """b minimising the charge error of Eq 4.17 / 4.20 by Nelder–Mead (as the thesis did)."""
    from scipy.optimize import minimize

    ok = np.isfinite(q)

    def cost(vec):
        model = replace(params, b=abs(vec[0])).charge(kin)
        return float(np.mean((q[ok] - model[ok]) ** 2))

    result = minimize(
        cost, [b0], method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-30, "maxiter": 400}
    )
    return float(abs(result.x[0]))


@dataclass(frozen=True)
class SetIdentification:
    """Both cases identified from one set (one capture of 5 cycles)."""

    case1: ModelParameters
    case2: ModelParameters
    charge_linear: ChargeFit
    charge_quadratic: ChargeFit
    alpha_from_current: float  # Eq 4.19 check of Case 2's α
    k_from_current: float
    x_max: float


def identify_set(
    t: np.ndarray,
    C_e: np.ndarray,
    x: np.ndarray,
    q_measured: np.ndarray,
    I: np.ndarray,
    k_static: float,
    m: float,
    b0: float = 100.0,
) -> SetIdentification:
    """Identify Case 1 and Case 2 from one set's series (4 kHz ripple-block rate, SI)."""
    kin = kinematics(t, x)
    C_P0, dC_x = capacitance_line(C_e, kin.x)
    lin = fit_charge_position(t, kin.x, q_measured, quadratic=False)
    quad = fit_charge_position(t, kin.x, q_measured, quadratic=True)
    # Eq 4.18: a2 = ΔCx/2 · k/α and a1 = C_P0 k/α + α
    k_over_alpha = 2 * quad.a2 / dC_x
    alpha2 = quad.a1 - C_P0 * k_over_alpha
    case2 = ModelParameters(2, C_P0, dC_x, alpha2 * k_over_alpha, alpha2, 0.0, m)
    alpha1 = alpha_from_slope(lin.a1, C_P0, k_static)
    case1 = ModelParameters(1, C_P0, 0.0, k_static, alpha1, 0.0, m)
    q1 = q_measured - lin.q0 - lin.I0 * t
    q2 = q_measured - quad.q0 - quad.I0 * t
    case1 = replace(case1, b=fit_damping(case1, kin, q1, b0))
    case2 = replace(case2, b=fit_damping(case2, kin, q2, b0))
    a_i, k_i = current_velocity_check(kin, I - quad.I0, C_P0, dC_x)
    return SetIdentification(case1, case2, lin, quad, a_i, k_i, float(np.ptp(kin.x)))


def current_velocity_check(
    kin: Kinematics, current: np.ndarray, C_P0: float, dC_x: float, min_speed_fraction: float = 0.5
) -> tuple[float, float]:
    """α and k from I/ẋ = (C_P0 k/α + α) + ΔCx (k/α) x (Eq 4.19), where |ẋ| is large.

    Near the stroke's ends ẋ → 0 and the ratio is meaningless, so only samples faster than
    ``min_speed_fraction`` of the peak speed are used.
    """
    fast = np.abs(kin.v) > min_speed_fraction * np.max(np.abs(kin.v))
    slope, intercept = np.polyfit(kin.x[fast], current[fast] / kin.v[fast], 1)
    k_over_alpha = slope / dC_x
    alpha = intercept - C_P0 * k_over_alpha
    return float(alpha), float(alpha * k_over_alpha)


@dataclass(frozen=True)
class MaterialProperties:
    C_T: float  # free capacitance [F] (Eq 4.22)
    eps_T: float  # relative free permittivity [-] (Eq 4.23)
    d33: float  # [m/V] (Eq 4.24)
    k33: float  # coupling [-] (Eq 4.25)
    U_P_max: float  # piezo voltage at full stroke [V]


def material_properties(p: ModelParameters, geometry: Geometry, x_max: float) -> MaterialProperties:
    """C_T = C_P + α²/k, ε_T = C_T t_P/(ε0 A n_l), d33 = α t_P/(L_P k), k33² = 1 − C_P/C_T."""
    C_T = p.C_P0 + p.alpha**2 / p.k
    eps_T = C_T * geometry.layer_thickness / (EPS0 * geometry.area * geometry.layers)
    d33 = p.alpha * geometry.layer_thickness / (geometry.active_length * p.k)
    k33 = float(np.sqrt(1 - p.C_P0 / C_T))
    return MaterialProperties(C_T, eps_T, d33, k33, x_max * p.k_over_alpha)


def sensitivity(
    fit: ChargeFit,
    C_P0: float,
    dC_x: float,
    geometry: Geometry,
    x_max: float,
    changes: dict[str, tuple[float, float]],
) -> dict[str, dict[str, float]]:
    """Table 4.3: Case 2 re-identified with C_P0 and ΔCx scaled, the charge fit unchanged.

    ``changes`` maps a column label to (factor on C_P0, factor on ΔCx).
    """
    out = {}
    for label, (f_c, f_d) in changes.items():
        c0, dc = C_P0 * f_c, dC_x * f_d
        k_over_alpha = 2 * fit.a2 / dc
        alpha = fit.a1 - c0 * k_over_alpha
        p = ModelParameters(2, c0, dc, alpha * k_over_alpha, alpha, 0.0, 0.0)
        mp = material_properties(p, geometry, x_max)
        out[label] = {
            "k": p.k,
            "alpha": p.alpha,
            "d33": mp.d33,
            "k33": mp.k33,
            "U_P_max": mp.U_P_max,
        }
    return out


def as_row(p: ModelParameters, mp: MaterialProperties) -> dict[str, float]:
    return asdict(p) | asdict(mp)


def geometry_from_actuator(actuator: dict, where: str = "actuator") -> Geometry:
    """Geometry from a manifest's actuator section (dimensions_mm, active_volume_mm3,
    layer_thickness_um)."""
    try:
        w, d, _ = actuator["dimensions_mm"]
        area = w * d * 1e-6
        return Geometry(
            area, actuator["layer_thickness_um"] * 1e-6, actuator["active_volume_mm3"] * 1e-9 / area
        )
    except KeyError as err:
        raise ValueError(
            f"{where}: missing key {err.args[0]} needed for the material properties"
        ) from None


#: the model parameters later stages read from the identification's model record
MODEL_KEYS = ("C_P0", "dC_x", "k", "alpha", "b", "m")


def model_record(case2: pd.DataFrame) -> dict[str, float]:
    """The identified model for later stages: the mean of each parameter over the Case 2 sets,
    and k/α [V/m], which splits the hysteresis voltage off the drive for the loss power
    (Eq 7.7–7.11).

    The damping b is the mean over the sets driven at half the highest frequency or more. Its
    charge b·ẋ·C_P/α grows with the drive frequency: at 10 Hz it is ≈ 2e-4 of the charge, below
    what the hysteresis leaves unexplained, so a set's fit lands anywhere from 0 (the bound of
    |b|) to twice the true value; at 50–100 Hz the fits agree within ±25 % (docs/methods.md).
    """
    model = {key: float(case2[key].mean()) for key in MODEL_KEYS}
    fast = case2["frequency [Hz]"] >= 0.5 * case2["frequency [Hz]"].max()
    model["b"] = float(case2.loc[fast, "b"].mean())
    return model | {"k_over_alpha": model["k"] / model["alpha"]}


def load_k_over_alpha(path: str | Path) -> float:
    """k/α [V/m] from a :func:`model_record` the identification stage wrote (``model.json``)."""
    return json.loads(Path(path).read_text())["k_over_alpha"]
