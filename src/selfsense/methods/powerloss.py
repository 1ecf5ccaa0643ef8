"""Power-loss (leakage impedance) models and compensation for current-driven piezo actuators.

Implements the analysis of Ronkanen, Kallio & Koivo, "Current control of
piezoelectric actuators with power loss compensation", IROS 2002
(referred to below as "the paper"; equation numbers are the paper's).

Physical picture
----------------
The displacement of the actuator follows its charge, delta(t) = a * int i dt
(Eq. 2), so a current source sets the velocity (Eq. 3).  Part of the current
fed in is lost: the actuator behaves as a capacitance C in parallel with a loss
impedance X (Eq. 5, with the frequency term neglected for slow motion).  The
total current must therefore be i_t = i_c + i_l (Eq. 4) with i_l = V / X
(Eq. 13).  At rest X equals the internal resistance R, found from a static hold
(Section 4); while moving, X drops with the drive-current magnitude
(Section 5, Table 1), which the paper describes with the empirical models
(7)-(11).  The best one, (10), gives the compensation law (15)
i_t = i_c + V / R * sqrt((c * i_c)^2 + 1).

Units: everything is SI inside (A, V, Ohm, F, s, m).  Only the sum of squared
errors is additionally reported in GOhm^2, because that is how Table 2 prints it.

Interpretations (the PDF text is scrambled; these are the choices made here)
---------------------------------------------------------------------------
* R is *fixed* from the static hold (105 V / 5 nA = 21 GOhm) and not fitted:
  Section 5 states the objective is a model "in which resistance would be
  21 GOhm when current intersects zero", and calls only b and c "constants".
* The SSE of Table 2 is computed over the three points (0 A, 21 GOhm),
  (100 nA, 6 GOhm), (300 nA, 2 GOhm): each Table-1 row "+-I" is one point at
  the magnitude |I|, and the static hold enters at i = 0 (not at 5 nA).  All
  models give X(0) = R, so the zero-current point contributes nothing to the
  SSE with R fixed.  With this reading the fitted SSEs reproduce Table 2.
* Model (8) X = R * b**(-|c i|) equals R * exp(-|c i| ln b): only the product
  c * ln b is identifiable, which is why Table 2 lists the same SSE for (7)
  and (8).  Here b is held fixed (default 10) and only c is fitted.
* Model (9) is implemented as printed, X = R / |c i + 1|, with c > 0.  For
  i >= 0 this equals R / (|c i| + 1); for negative currents the printed form
  has a pole at i = -1/c.  An unconstrained c < 0 would place that pole between
  the data points, so c is restricted to be positive (all constants are fitted
  through ln c).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import cumulative_trapezoid
from scipy.optimize import least_squares
from scipy.signal import savgol_filter

from selfsense.methods.metrics import branch_gap

__all__ = [
    "PAPER_HOLD_VOLTAGE",
    "PAPER_HOLD_CURRENT",
    "PAPER_HOLD_RESISTANCE",
    "PAPER_TABLE_1",
    "PAPER_TABLE_2_SSE_GOHM2",
    "PAPER_C_EQ12",
    "ImpedanceModel",
    "IMPEDANCE_MODELS",
    "get_impedance_model",
    "ImpedanceFit",
    "fit_impedance_model",
    "paper_fit_points",
    "table_2",
    "RampImpedanceEstimate",
    "impedance_from_ramp",
    "displacement_from_current",
    "current_for_velocity",
    "leakage_current",
    "compensated_current",
    "voltage_from_charge",
    "compensated_current_from_charge",
    "hold_resistance",
    "HoldEstimate",
    "hold_from_record",
    "charging_current",
    "constant_stretches",
    "ramp_velocity",
    "velocity_spread",
    "PIDState",
    "CurrentPID",
    "turning_points",
    "linear_gain",
    "max_error",
    "branch_hysteresis_percent",
    "drift_percent",
    "repeatability",
]

GIGA = 1e9

# ---------------------------------------------------------------------------
# Published numbers (kept here so tests and reports compare against one source)
# ---------------------------------------------------------------------------
PAPER_HOLD_VOLTAGE = 105.0  # V, Section 4
PAPER_HOLD_CURRENT = 5e-9  # A, current that holds the bender still (Section 4)
PAPER_HOLD_RESISTANCE = 21e9  # Ohm, printed result of Ohm's law (Section 4)
#: Table 1: drive-current magnitude [A] -> impedance giving ideal ramp velocity [Ohm].
PAPER_TABLE_1: Mapping[float, float] = MappingProxyType({300e-9: 2e9, 100e-9: 6e9})
#: Table 2: sums of squared errors in GOhm^2, keyed by equation number.
PAPER_TABLE_2_SSE_GOHM2: Mapping[int, float] = MappingProxyType(
    {7: 2.1, 8: 2.1, 9: 0.18, 10: 0.0052, 11: 1.2}
)
PAPER_C_EQ12 = 3.4e7  # 1/A, the constant of the best model (10), Eq. 12


# ---------------------------------------------------------------------------
# Static hold (Section 4)
# ---------------------------------------------------------------------------
def hold_resistance(voltage: ArrayLike, hold_current: ArrayLike) -> NDArray[np.float64] | float:
    """Internal resistance from a static hold, R = V / i_hold (Ohm's law, Section 4).

    Once the actuator has been charged and stopped, the current that keeps it
    still only replaces what leaks through R, so R = V / i_hold.  The paper's
    105 V / 5 nA gives 21 GOhm.
    """
    v = np.asarray(voltage, dtype=float)
    i = np.asarray(hold_current, dtype=float)
    if np.any(i == 0):
        raise ValueError("hold_current must be non-zero (zero current means no measurable leakage)")
    r = v / i
    if np.any(r <= 0):
        # A hold current opposing the voltage would mean a negative resistance.
        raise ValueError("voltage and hold_current must have the same sign")
    return float(r) if r.ndim == 0 else r


@dataclass(frozen=True)
class HoldEstimate:
    """Internal resistance from a recorded static hold (Section 4, Fig. 2).

    ``R`` counts only the current that leaks: the hold current less what still
    charges the actuator, (dx/dt)/a.  ``R_ohm`` is the paper's plain V/i_hold,
    equal to ``R`` when the hold keeps the position exactly.
    """

    R: float
    R_ohm: float
    voltage: float
    current: float
    velocity: float


def hold_from_record(
    time: ArrayLike, voltage: ArrayLike, current: ArrayLike, displacement: ArrayLike, a: float
) -> HoldEstimate:
    """R from the samples of a hold (Section 4): mean V over the leaking part of the mean current.

    The paper found the hold current by trial until the bender stood still, then
    applied Ohm's law.  A recorded hold need not be perfectly balanced, so the
    residual velocity (a straight-line fit of the displacement) is converted to
    the charging current it needs via Eq. (2), (dx/dt)/a, and removed first.
    """
    t = np.asarray(time, float)
    v, i, x = (np.asarray(y, float) for y in (voltage, current, displacement))
    velocity = float(np.polyfit(t, x, 1)[0])
    v_mean, i_mean = float(np.mean(v)), float(np.mean(i))
    return HoldEstimate(
        R=float(hold_resistance(v_mean, i_mean - velocity / a)),
        R_ohm=float(hold_resistance(v_mean, i_mean)),
        voltage=v_mean,
        current=i_mean,
        velocity=velocity,
    )


# ---------------------------------------------------------------------------
# Impedance models (7)-(11)
# ---------------------------------------------------------------------------
def _x_exp(i: NDArray, R: float, c: float) -> NDArray:
    return R * np.exp(-np.abs(c * i))


def _x_base_b(i: NDArray, R: float, c: float, b: float = 10.0) -> NDArray:
    return R * np.power(b, -np.abs(c * i))


def _x_abs_linear(i: NDArray, R: float, c: float) -> NDArray:
    return R / np.abs(c * i + 1.0)


def _x_sqrt(i: NDArray, R: float, c: float) -> NDArray:
    return R / np.sqrt((c * i) ** 2 + 1.0)


def _x_quadratic(i: NDArray, R: float, c: float) -> NDArray:
    return R / (c * i**2 + 1.0)


@dataclass(frozen=True)
class ImpedanceModel:
    """One empirical loss-impedance model X(i; R, params) of Section 5.

    ``func(i, R, *params, **fixed)`` evaluates the model.  ``initial_guess``
    is a starting point for the fit; the fit is multi-started over decades
    around it, so only the order of magnitude matters.
    """

    name: str
    equation: int
    formula: str
    func: Callable[..., NDArray]
    param_names: tuple[str, ...]
    initial_guess: tuple[float, ...]
    param_units: tuple[str, ...]
    fixed: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))

    def __call__(self, current: ArrayLike, R: float, *params: float, **fixed: float) -> NDArray:
        kw = {**self.fixed, **fixed}
        return self.func(np.asarray(current, dtype=float), float(R), *params, **kw)


IMPEDANCE_MODELS: Mapping[str, ImpedanceModel] = MappingProxyType(
    {
        "exp": ImpedanceModel("exp", 7, "X = R*exp(-|c*i|)", _x_exp, ("c",), (1e7,), ("1/A",)),
        "base_b": ImpedanceModel(
            "base_b",
            8,
            "X = R*b**(-|c*i|)",
            _x_base_b,
            ("c",),
            (1e7,),
            ("1/A",),
            # b and c are not separately identifiable (only c*ln b is): fix b.
            MappingProxyType({"b": 10.0}),
        ),
        "abs_linear": ImpedanceModel(
            "abs_linear", 9, "X = R/|c*i + 1|", _x_abs_linear, ("c",), (1e7,), ("1/A",)
        ),
        "sqrt": ImpedanceModel(
            "sqrt", 10, "X = R/sqrt((c*i)**2 + 1)", _x_sqrt, ("c",), (1e7,), ("1/A",)
        ),
        "quadratic": ImpedanceModel(
            # Note c multiplies i**2 here, so its unit is 1/A^2 (~1e14 for nA-scale data).
            "quadratic",
            11,
            "X = R/(c*i**2 + 1)",
            _x_quadratic,
            ("c",),
            (1e14,),
            ("1/A^2",),
        ),
    }
)


def get_impedance_model(name: str | int) -> ImpedanceModel:
    """Look a model up by registry name (``"sqrt"``) or equation number (``10``, ``"(10)"``)."""
    if isinstance(name, str) and name in IMPEDANCE_MODELS:
        return IMPEDANCE_MODELS[name]
    try:
        eq = int(str(name).strip().strip("()"))
    except ValueError:
        eq = None
    for model in IMPEDANCE_MODELS.values():
        if model.equation == eq:
            return model
    raise KeyError(f"unknown impedance model {name!r}; known: {list(IMPEDANCE_MODELS)} or 7..11")


@dataclass(frozen=True)
class ImpedanceFit:
    """Result of fitting one model with R fixed.

    ``sse`` is in Ohm^2; ``sse_gohm2`` in GOhm^2 as printed in Table 2.
    """

    model: ImpedanceModel
    R: float
    params: Mapping[str, float]
    sse: float
    n_points: int
    success: bool

    @property
    def sse_gohm2(self) -> float:
        return self.sse / GIGA**2

    def predict(self, current: ArrayLike) -> NDArray[np.float64]:
        """Impedance X [Ohm] at drive current(s) ``current`` [A]."""
        return self.model(current, self.R, *(self.params[p] for p in self.model.param_names))


def _validate_points(currents: ArrayLike, impedances: ArrayLike) -> tuple[NDArray, NDArray]:
    i = np.atleast_1d(np.asarray(currents, dtype=float))
    x = np.atleast_1d(np.asarray(impedances, dtype=float))
    if i.shape != x.shape or i.ndim != 1:
        raise ValueError("currents and impedances must be 1-D arrays of equal length")
    if not (np.all(np.isfinite(i)) and np.all(np.isfinite(x))):
        raise ValueError("currents and impedances must be finite")
    if np.any(x <= 0):
        raise ValueError("impedances must be positive")
    return i, x


def fit_impedance_model(
    name: str | int,
    currents: ArrayLike,
    impedances: ArrayLike,
    R: float,
    *,
    decades: int = 4,
) -> ImpedanceFit:
    """Least-squares fit of model (7)-(11) to (current, impedance) points with R fixed.

    R comes from the static hold (Section 4) and is not a free parameter: the
    paper wants X(0) = 21 GOhm exactly and fits only the constant(s) b, c.
    Residuals are formed in GOhm (for conditioning; the SSE is then directly in
    Table 2's unit) and each constant is fitted as ln c, which keeps it positive
    and makes the problem scale free.  The fit is restarted at initial guesses
    spread over +-``decades`` decades and the lowest SSE is kept, because single
    exponential/rational models like these have flat regions where a local
    solver can stall.
    """
    model = get_impedance_model(name)
    i, x = _validate_points(currents, impedances)
    R = float(R)
    if not (np.isfinite(R) and R > 0):
        raise ValueError("R must be positive and finite")
    if i.size < len(model.param_names):
        raise ValueError("need at least as many points as free parameters")

    x_g = x / GIGA

    def residuals(theta: NDArray) -> NDArray:
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            pred = model(i, R, *np.exp(theta)) / GIGA
        r = pred - x_g
        # Pole of model (9) or overflow: replace by a large finite penalty so the
        # solver is pushed away rather than crashing on inf/nan.
        return np.where(np.isfinite(r), r, 1e6)

    base = np.log(np.asarray(model.initial_guess, dtype=float))
    best = None
    for k in np.arange(-decades, decades + 1):
        theta0 = base + k * np.log(10.0)
        res = least_squares(residuals, theta0, method="trf", xtol=1e-14, ftol=1e-14, gtol=1e-14)
        if best is None or res.cost < best.cost:
            best = res
    assert best is not None
    params = MappingProxyType(
        {p: float(v) for p, v in zip(model.param_names, np.exp(best.x), strict=True)}
    )
    sse_g = float(np.sum(residuals(best.x) ** 2))
    return ImpedanceFit(
        model=model,
        R=R,
        params=params,
        sse=sse_g * GIGA**2,
        n_points=int(i.size),
        success=bool(best.success),
    )


def paper_fit_points(R: float = PAPER_HOLD_RESISTANCE) -> tuple[NDArray, NDArray]:
    """The points Table 2's SSE is computed over (see module docstring).

    (0 A, R) from the static hold, then each Table 1 row as one point at |I|.
    """
    rows = sorted(PAPER_TABLE_1.items())
    currents = np.array([0.0] + [c for c, _ in rows])
    impedances = np.array([R] + [z for _, z in rows])
    return currents, impedances


def table_2(
    currents: ArrayLike | None = None,
    impedances: ArrayLike | None = None,
    R: float = PAPER_HOLD_RESISTANCE,
) -> pd.DataFrame:
    """Reproduce Table 2: fit every model (7)-(11) and tabulate its SSE in GOhm^2.

    With no data given, uses :func:`paper_fit_points`.  Columns: model,
    equation, formula, parameters (readable string), c, c_unit, SSE [GOhm^2],
    paper SSE [GOhm^2], best (True for the lowest SSE).
    """
    if currents is None and impedances is None:
        currents, impedances = paper_fit_points(R)
    elif currents is None or impedances is None:
        raise ValueError("give both currents and impedances, or neither")
    rows = []
    for model in IMPEDANCE_MODELS.values():
        fit = fit_impedance_model(model.name, currents, impedances, R)
        parts = [
            f"{p}={fit.params[p]:.4g} {u}"
            for p, u in zip(model.param_names, model.param_units, strict=True)
        ]
        parts += [f"{k}={v:g} (fixed)" for k, v in model.fixed.items()]
        rows.append(
            {
                "model": model.name,
                "equation": f"({model.equation})",
                "formula": model.formula,
                "parameters": ", ".join(parts),
                "c": fit.params["c"],
                "c_unit": model.param_units[0],
                "SSE [GOhm^2]": fit.sse_gohm2,
                "paper SSE [GOhm^2]": PAPER_TABLE_2_SSE_GOHM2[model.equation],
            }
        )
    df = pd.DataFrame(rows)
    df["best"] = df["SSE [GOhm^2]"] == df["SSE [GOhm^2]"].min()
    return df


# ---------------------------------------------------------------------------
# Estimating X from a ramp experiment (Section 5)
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class RampImpedanceEstimate:
    """Loss impedance identified from one ramp record.

    ``gain`` is a [m/C] (Eq. 2) for ``method="displacement"`` and 1/C [1/F]
    for ``method="voltage"``; ``offset`` is the fitted initial displacement or
    voltage; ``rms_residual`` is in the unit of the fitted signal.
    """

    impedance: float
    gain: float
    offset: float
    rms_residual: float
    method: str
    n_samples: int

    @property
    def capacitance(self) -> float:
        """C [F]; only meaningful for ``method="voltage"``."""
        if self.method != "voltage":
            raise AttributeError("capacitance is only identified by method='voltage'")
        return 1.0 / self.gain


def impedance_from_ramp(
    time: ArrayLike,
    displacement: ArrayLike | None,
    current: ArrayLike,
    voltage: ArrayLike,
    *,
    method: Literal["displacement", "voltage"] = "displacement",
    segments: ArrayLike | None = None,
) -> RampImpedanceEstimate:
    """Estimate the loss impedance X from a constant-|i| ramp record (Section 5).

    The paper tunes X by trial: it compensates with a guessed X and checks
    whether the ramp velocity stays constant (Figs. 3-5).  Velocity is constant
    exactly when the charge that reaches the capacitance, dQ/dt = i - V/X,
    equals the charging current.  This function identifies X directly from that
    charge balance, integrated over time to avoid differentiating noisy data:

    * ``"displacement"``: delta(t) = delta0 + a*int(i dt) - (a/X)*int(V dt)
      (Eq. 2 with the loss current V/X of Eq. 13 removed from the charge);
    * ``"voltage"``: V(t) = V0 + (1/C)*int(i dt) - (1/(C X))*int(V dt).

    Both are linear in their three unknowns, solved by ordinary least squares,
    and X = gain / (gain/X).  ``current`` is the *total* current actually
    driven into the actuator (what the current meter reads), so a record taken
    with any trial compensation is usable.  X is assumed constant over the
    record, i.e. the record should be at one drive-current magnitude (the
    paper's +-I ramps).  If no loss is detectable (fitted loss term <= 0)
    the impedance is returned as +inf.

    Caveat: the integrals use the trapezoidal rule, so a current reversal that
    falls on a sample instant mis-counts about |I|*dt/2 of charge; sample fast
    enough that this is small against the leaked charge int(V dt)/X.  A current
    meter with a lag tau mis-places tau*|dI| at every reversal in the same way.
    Both errors are constant between reversals, so ``segments`` (one label per
    sample, constant over each constant-current stretch) gives every stretch
    its own offset and removes them; ``offset`` is then the first stretch's.
    """
    t = np.asarray(time, dtype=float)
    i = np.asarray(current, dtype=float)
    v = np.asarray(voltage, dtype=float)
    if method == "displacement":
        if displacement is None:
            raise ValueError("method='displacement' needs the displacement record")
        y = np.asarray(displacement, dtype=float)
    elif method == "voltage":
        y = v
    else:
        raise ValueError(f"unknown method {method!r}")
    if not (t.ndim == 1 and t.shape == i.shape == v.shape == y.shape):
        raise ValueError("time, displacement, current and voltage must be 1-D and equal length")
    if t.size < 4:
        raise ValueError("need at least 4 samples")
    if np.any(np.diff(t) <= 0):
        raise ValueError("time must be strictly increasing")

    if segments is None:
        offsets = np.ones((t.size, 1))
    else:
        labels = np.asarray(segments)
        if labels.shape != t.shape:
            raise ValueError("segments must label every sample")
        offsets = (labels[:, None] == np.unique(labels)[None, :]).astype(float)
        offsets = offsets[:, np.argsort(np.argmax(offsets, axis=0))]  # first stretch first
    q = cumulative_trapezoid(i, t, initial=0.0)  # delivered charge [C]
    w = cumulative_trapezoid(v, t, initial=0.0)  # int V dt [V s]; w/X = leaked charge
    # Column scaling so lstsq's rank decision is not fooled by nC vs kV*s magnitudes.
    A = np.column_stack([offsets, q, -w])
    scale = np.max(np.abs(A), axis=0)
    scale[scale == 0] = 1.0
    coef, *_ = np.linalg.lstsq(A / scale, y, rcond=None)
    offset, (gain, loss) = (coef / scale)[0], (coef / scale)[-2:]
    resid = y - A @ (coef / scale)
    impedance = float(gain / loss) if loss > 0 and gain > 0 else float("inf")
    return RampImpedanceEstimate(
        impedance=impedance,
        gain=float(gain),
        offset=float(offset),
        rms_residual=float(np.sqrt(np.mean(resid**2))),
        method=method,
        n_samples=int(t.size),
    )


def charging_current(
    current: ArrayLike, voltage: ArrayLike, impedance: float
) -> NDArray[np.float64]:
    """i_c = i_t - V/X (Eqs. 4, 13): the part of the measured current that reaches the
    capacitance."""
    return np.asarray(current, float) - np.asarray(voltage, float) / impedance


def constant_stretches(command: ArrayLike) -> NDArray[np.int64]:
    """Label every sample with the index of the constant-command stretch it belongs to."""
    c = np.asarray(command, float)
    return np.concatenate([[0], np.cumsum(np.diff(c) != 0)])


def velocity_spread(
    time: ArrayLike, displacement: ArrayLike, command: ArrayLike, window: float
) -> float:
    """How far a ramp's speed is from constant (the paper's test of X, Figs. 3-5), in %.

    Standard deviation of |velocity| over its mean, on the samples at least one
    ``window`` away from a change of the current command (the reversals).
    """
    t = np.asarray(time, float)
    speed = np.abs(ramp_velocity(t, displacement, window))
    changes = t[1:][np.diff(np.asarray(command, float)) != 0]
    away = (
        np.all(np.abs(t[:, None] - changes[None, :]) >= window, axis=1)
        if changes.size
        else np.ones(t.size, bool)
    )
    return float(100.0 * np.std(speed[away]) / np.mean(speed[away]))


def ramp_velocity(time: ArrayLike, displacement: ArrayLike, window: float) -> NDArray[np.float64]:
    """Velocity of a ramp record (Figs. 3-5): the slope of a straight line fitted over ``window`` s.

    A first-order Savitzky-Golay derivative, i.e. a sliding least-squares slope,
    so sensor noise is averaged instead of amplified by differencing.
    """
    t = np.asarray(time, float)
    dt = float(np.median(np.diff(t)))
    n = max(3, int(round(window / dt)) | 1)
    return savgol_filter(np.asarray(displacement, float), n, 1, deriv=1, delta=dt, mode="interp")


# ---------------------------------------------------------------------------
# Control principle (Eqs. 2-3) and feedforward compensation (Eqs. 13-15)
# ---------------------------------------------------------------------------
def displacement_from_current(time: ArrayLike, current: ArrayLike, a: float) -> NDArray[np.float64]:
    """Eq. (2): delta(t) = a * int_0^t i dt (loss-free charge-displacement law)."""
    return a * cumulative_trapezoid(
        np.asarray(current, float), np.asarray(time, float), initial=0.0
    )


def current_for_velocity(velocity: ArrayLike, a: float) -> NDArray[np.float64] | float:
    """Eq. (3): i(t) = v(t) / a (the 'displacement to current' block of Fig. 1)."""
    out = np.asarray(velocity, dtype=float) / a
    return float(out) if out.ndim == 0 else out


def leakage_current(
    i_c: ArrayLike, V: ArrayLike, R: float, c: float
) -> NDArray[np.float64] | float:
    """Loss current i_l = V / X(i_c) with X from model (10) (Eqs. 10, 13).

    It flows in the direction of V, regardless of the sign of the charging
    current (Section 5: a positive i_l is added to a negative i_c).
    """
    i_c = np.asarray(i_c, dtype=float)
    out = np.asarray(V, dtype=float) / R * np.sqrt((c * i_c) ** 2 + 1.0)
    return float(out) if out.ndim == 0 else out


def compensated_current(
    i_c: ArrayLike, V: ArrayLike, R: float, c: float
) -> NDArray[np.float64] | float:
    """Eq. (15): total current i_t = i_c + V/R * sqrt((c*i_c)^2 + 1).

    i_c is the current meant to charge the actuator (sets the velocity, Eq. 3),
    V the actuator voltage (the paper reads it from the PID output times the
    amplifier gain), R the static-hold resistance and c the constant of model
    (10).  Equivalent to i_c + V / X(i_c) with X = R / sqrt((c i_c)^2 + 1).
    """
    out = np.asarray(i_c, dtype=float) + leakage_current(i_c, V, R, c)
    return float(out) if np.ndim(out) == 0 else out


def voltage_from_charge(time: ArrayLike, i_c: ArrayLike, C: float) -> NDArray[np.float64]:
    """Voltage estimate V(t) = (1/C) int_0^t i_c dt used in Eq. (14).

    Valid when the compensation is right, because then all of i_c (and only
    i_c) ends up on the capacitance.
    """
    return cumulative_trapezoid(np.asarray(i_c, float), np.asarray(time, float), initial=0.0) / C


def compensated_current_from_charge(
    time: ArrayLike, i_c: ArrayLike, C: float, R: float, c: float
) -> NDArray[np.float64]:
    """Eq. (14): Eq. (15) with V replaced by the charge estimate (1/C) int i_c dt."""
    i_c = np.asarray(i_c, dtype=float)
    return np.asarray(compensated_current(i_c, voltage_from_charge(time, i_c, C), R, c))


# ---------------------------------------------------------------------------
# Current loop of Fig. 1
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class PIDState:
    """Internal state of :class:`CurrentPID` (integral sum, previous error)."""

    integral: float = 0.0
    prev_error: float | None = None


@dataclass(frozen=True)
class CurrentPID:
    """Discrete PID of Fig. 1: drives the voltage amplifier so the measured current tracks i_t.

    Parallel form u = kp*e + ki*sum(e*dt) + kd*de/dt, output clamped to
    [u_min, u_max] (the amplifier input range).  The integral is frozen while
    the output saturates in the direction of the error (conditional
    integration), so the loop recovers quickly from a clamp.  Pure: ``step``
    returns the output and a new state instead of mutating.

    Tuning note: the load is capacitive, i = C*G*du/dt (G amplifier gain), so
    seen from the current the integral term acts like a proportional gain and
    the proportional term like a derivative one.  The paper reads the actuator
    voltage for Eq. (15) as G times this controller's output.
    """

    kp: float
    ki: float
    kd: float
    dt: float
    u_min: float = -np.inf
    u_max: float = np.inf

    def __post_init__(self) -> None:
        if not self.dt > 0:
            raise ValueError("dt must be positive")
        if not self.u_min < self.u_max:
            raise ValueError("u_min must be below u_max")

    def step(self, state: PIDState, setpoint: float, measurement: float) -> tuple[float, PIDState]:
        e = float(setpoint) - float(measurement)
        # No derivative kick on the first sample (no previous error yet).
        de = 0.0 if state.prev_error is None else (e - state.prev_error) / self.dt
        integral = state.integral + e * self.dt
        u_raw = self.kp * e + self.ki * integral + self.kd * de
        u = min(max(u_raw, self.u_min), self.u_max)
        if u != u_raw and np.sign(e) == np.sign(u_raw - u):
            integral = state.integral  # anti-windup: do not integrate into saturation
        return u, PIDState(integral=integral, prev_error=e)


# ---------------------------------------------------------------------------
# Positioning performance (Section 7: Figs. 8-11)
# ---------------------------------------------------------------------------
def turning_points(y: ArrayLike, min_swing: float) -> NDArray[np.int64]:
    """Indices of the alternating extremes of ``y``, ignoring reversals smaller than ``min_swing``.

    A zig-zag scan: an extreme is confirmed once ``y`` has moved ``min_swing``
    back from it, so noise and holds do not split a ramp.  The first and last
    samples are included, making consecutive pairs the branches of the record.
    """
    y = np.asarray(y, float)
    points = [0]
    hi = lo = 0  # extremes since the start, until the first swing sets the trend
    trend = 0
    for k in range(1, y.size):
        if trend == 0:
            hi = k if y[k] > y[hi] else hi
            lo = k if y[k] < y[lo] else lo
            if y[hi] - y[lo] >= min_swing:
                trend, extreme = (1, hi) if hi > lo else (-1, lo)
        elif trend * (y[k] - y[extreme]) > 0:
            extreme = k
        elif trend * (y[extreme] - y[k]) >= min_swing:
            points.append(extreme)
            trend, extreme = -trend, k
    if points[-1] != y.size - 1:
        points.append(y.size - 1)
    return np.asarray(points, dtype=np.int64)


def linear_gain(drive: ArrayLike, displacement: ArrayLike) -> float:
    """Least-squares gain of a line through the origin, displacement ~ g * drive.

    The best a linear (hysteresis- and creep-free) model of open-loop voltage
    control can do for a record: its errors are then hysteresis and drift only.
    """
    u, x = np.asarray(drive, float), np.asarray(displacement, float)
    return float(np.dot(u, x) / np.dot(u, u))


def max_error(required: ArrayLike, measured: ArrayLike) -> float:
    """Maximum inaccuracy, max |measured - required| (Section 7, Fig. 8)."""
    return float(np.max(np.abs(np.asarray(measured, float) - np.asarray(required, float))))


def branch_hysteresis_percent(required: ArrayLike, measured: ArrayLike, min_swing: float) -> float:
    """Hysteresis of a record in % of its measured range (Fig. 9).

    The record is cut at the reversals of the required displacement; for every
    pair of consecutive branches (one rising, one falling) the largest gap in
    measured displacement at equal required displacement is found
    (:func:`selfsense.methods.metrics.branch_gap`), and the largest over all pairs is
    divided by the measured peak-to-peak.  Pairing consecutive branches keeps
    the nested loops of a decaying ramp apart instead of averaging them.
    """
    req, meas = np.asarray(required, float), np.asarray(measured, float)
    tp = turning_points(req, min_swing)
    gaps = []
    for first, turn, last in zip(tp[:-2], tp[1:-1], tp[2:]):
        # each sample's branch from where it lies, not from a (noisy) local slope; a turning
        # sample ends the branch that reached it
        start = first + (first > 0)
        up = 1 if req[turn] > req[first] else -1
        rising = np.where(np.arange(start, last + 1) <= turn, up, -up)
        gaps.append(branch_gap(req[start : last + 1], meas[start : last + 1], rising))
    if not gaps:
        raise ValueError("the record has no rising and falling branch to compare")
    return 100.0 * max(gaps) / float(np.ptp(meas))


def _mean_near(time: NDArray, values: NDArray, t0: float, half_width: float) -> float:
    sel = np.abs(time - t0) <= half_width
    return float(np.mean(values[sel]))


def drift_percent(
    time: ArrayLike, displacement: ArrayLike, t_hold: float, duration: float, average: float = 1.0
) -> float:
    """Drift of a held position in % of that position (Fig. 11).

    Position ``duration`` s after the hold starts against the position at its
    start, each averaged over +-``average``/2 s against sensor noise; the
    displacement is counted from the record's start (the unloaded zero).
    """
    t, x = np.asarray(time, float), np.asarray(displacement, float)
    zero = _mean_near(t, x, t[0] + average / 2, average / 2)
    start = _mean_near(t, x, t_hold + average / 2, average / 2) - zero
    end = _mean_near(t, x, min(t_hold + duration, t[-1]) - average / 2, average / 2) - zero
    return 100.0 * (end - start) / start


def repeatability(
    time: ArrayLike,
    required: ArrayLike,
    measured: ArrayLike,
    min_swing: float,
    average: float = 1.0,
) -> pd.DataFrame:
    """Peaks of every cycle of a repeated ramp (Fig. 10): one row per cycle.

    Columns: cycle, time [s] of its maximum, max and min of the measured
    displacement at the required extremes (averaged over +-``average``/2 s),
    midpoint and peak-to-peak.  The drift of the record is the change of the
    midpoint, and the peak-to-peak change its growth, both relative to the first
    cycle's peak-to-peak.
    """
    t, req, meas = (np.asarray(y, float) for y in (time, required, measured))
    tp = turning_points(req, min_swing)[1:-1]
    highs = [k for k in tp if req[k] > np.median(req)]
    lows = [k for k in tp if req[k] <= np.median(req)]
    rows = []
    for cycle, (hi, lo) in enumerate(zip(highs, lows)):
        top = _mean_near(t, meas, t[hi], average / 2)
        bottom = _mean_near(t, meas, t[lo], average / 2)
        rows.append(
            {
                "cycle": cycle + 1,
                "time [s]": float(t[hi]),
                "max [m]": top,
                "min [m]": bottom,
                "midpoint [m]": 0.5 * (top + bottom),
                "peak-to-peak [m]": top - bottom,
            }
        )
    if not rows:
        raise ValueError("the record has no complete cycle")
    return pd.DataFrame(rows)
