"""An actuator's own hysteresis model from its U–x recording: the Maxwell operator of thesis
Eq 1.11–1.12, identified on steady cycles and judged on held-out ones.

In the thesis's electromechanical model the drive voltage is the piezo voltage plus the Maxwell
operator's voltage, U = U_P + U_H(q) (Eq 4.2, 4.4), and quasi-statically both U_P and q are
proportional to the position x. With only U and x recorded, the model is therefore written in x:

    U = u0 + c0·x + Σ_i k_i·clip(x − b_i, −r_i, r_i),

element i a Maxwell slip element of stiffness k_i [V/m] that slides once the position has moved
r_i from its anchor b_i (the anchor then follows: b_i = clip(b_i, x − r_i, x + r_i)). U(x) is the
model's explicit direction: a feedforward compensator computes the voltage for a desired position
with it, sample by sample (the inverse of the actuator's U → x). The forward direction, x from U,
solves the same balance for x at every sample (:func:`positions`).

Identification: for n elements the thresholds are fixed on an even grid r_j = (j − ½)/n · h (h
half the steady cycles' stroke: an element with r ≥ h never slides, which c0 already covers), and
U is then linear in (u0, c0, k_1…k_n), which are fitted by bounded least squares with c0 > 0 and
k_i ≥ 0 (a passive, monotone loop). The steady cycles are dealt in turn to three sets: a fit set,
a validation set that chooses n, and a test set that reports the errors, so that the errors shown
are those of cycles neither the fit nor the choice of n has seen.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numba
import numpy as np

#: orders tried, 1 … MAX_ORDER elements
MAX_ORDER = 12
#: the order chosen: the smallest whose validation rms is within this fraction of the best order's
#: (more elements than that buy less than the cycle-to-cycle scatter of the validation cycles), or
#: within RESOLUTION of the drive span of it (noise-free data: every order that fits is exact)
ORDER_TOLERANCE = 0.05
RESOLUTION = 1e-9
#: at most this many steady cycles enter the fit, evenly spread over the record (a third each to
#: the fit, the choice of order and the test)
MAX_CYCLES = 90
#: and at most this many of their samples (the model is rate independent: thinning a cycle keeps
#: its loop while it keeps a few hundred samples, which this leaves for MAX_CYCLES)
MAX_FIT_SAMPLES = 50_000
#: held-out errors need at least one cycle in each of the three sets
MIN_CYCLES = 3
#: c0's lower bound as a fraction of the loop's mean slope ΔU/Δx: keeps the forward balance
#: strictly monotone (a loop's slope never falls to zero in a piezo's stack or bender)
MIN_SLOPE_FRACTION = 1e-3
#: Newton iterations before a balance gives up (bisection halves the bracket when Newton leaves it)
MAX_ITERATIONS = 200


@dataclass(frozen=True)
class MaxwellSlip:
    """U = u0 + c0·x + Σ k_i·clip(x − b_i, −r_i, r_i) [V, m] (Eq 1.11–1.12 in the position
    domain); the anchors start relaxed at the record's first position."""

    u0: float
    c0: float
    r: np.ndarray
    k: np.ndarray

    @property
    def order(self) -> int:
        return len(self.r)

    def voltage(self, x: np.ndarray) -> np.ndarray:
        """The voltage the model needs for the position x (the feedforward direction)."""
        return self.u0 + self.c0 * x + element_strains(x, self.r) @ self.k

    def position(self, u: np.ndarray) -> np.ndarray:
        """The position the model gives for the voltage u (the forward direction)."""
        return positions(np.ascontiguousarray(u, float), self.u0, self.c0, self.r, self.k)


@numba.njit(cache=True)
def _strains(x, r, rows, out):
    b = np.full(r.size, x[0])
    k = 0
    for t in range(x.size):
        if k >= rows.size:
            break
        for i in range(r.size):
            lo, hi = x[t] - r[i], x[t] + r[i]
            if b[i] < lo:
                b[i] = lo
            elif b[i] > hi:
                b[i] = hi
        if t == rows[k]:
            for i in range(r.size):
                out[k, i] = x[t] - b[i]
            k += 1


def element_strains(x: np.ndarray, r: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
    """clip(x − b_i, −r_i, r_i) of every element, anchors relaxed at x[0] and moved by the whole
    record: the play operator's complement, an (n_rows, n_elements) array at ``rows`` (increasing
    sample indices; None: every sample)."""
    rows = np.arange(len(x)) if rows is None else np.asarray(rows, np.int64)
    out = np.empty((len(rows), len(r)))
    _strains(np.ascontiguousarray(x, float), np.ascontiguousarray(r, float), rows, out)
    return out


def element_strains_reference(
    x: np.ndarray, r: np.ndarray, rows: np.ndarray | None = None
) -> np.ndarray:
    """Plain-numpy :func:`element_strains`."""
    b = np.full(len(r), float(x[0]))
    out = np.empty((len(x), len(r)))
    for t, xt in enumerate(x):
        b = np.clip(b, xt - r, xt + r)
        out[t] = xt - b
    return out if rows is None else out[np.asarray(rows, int)]


@numba.njit(cache=True)
def _balance(x, u, u0, c0, r, k, b):
    """The balance's residual and slope at x for the anchors b (not moved)."""
    f = u0 + c0 * x - u
    df = c0
    for i in range(r.size):
        e = x - b[i]
        if e > r[i]:
            f += k[i] * r[i]
        elif e < -r[i]:
            f -= k[i] * r[i]
        else:
            f += k[i] * e
            df += k[i]
    return f, df


@numba.njit(cache=True)
def newton_step(y, f, df, lo, hi):
    """One step on a monotone increasing residual f(y) with slope df: Newton inside the bracket
    [lo, hi], which the step narrows, and bisection whenever Newton would leave it (at the kinks
    of a Maxwell operator, where the slope jumps). Returns the new y, lo, hi."""
    if f > 0.0:
        hi = y
    else:
        lo = y
    y -= f / df
    if y <= lo or y >= hi:
        y = 0.5 * (lo + hi)
    return y, lo, hi


@numba.njit(cache=True)
def positions(u, u0, c0, r, k):
    """x at every sample of u: the root of U(x) = u with the anchors as they stand, found by
    Newton inside a bracket (bisection where Newton would leave it, at the operator's kinks); the
    residual rises with slope ≥ c0, so the root lies within |f|/c0 of the previous position."""
    out = np.empty(u.size)
    x = (u[0] - u0) / c0
    b = np.full(r.size, x)
    for t in range(u.size):
        f, df = _balance(x, u[t], u0, c0, r, k, b)
        step = abs(f) / c0
        lo, hi = x - step, x + step
        for _ in range(MAX_ITERATIONS):
            if abs(f) <= 1e-12 * (1.0 + abs(u[t])):
                break
            x, lo, hi = newton_step(x, f, df, lo, hi)
            f, df = _balance(x, u[t], u0, c0, r, k, b)
        for i in range(r.size):
            if b[i] < x - r[i]:
                b[i] = x - r[i]
            elif b[i] > x + r[i]:
                b[i] = x + r[i]
        out[t] = x
    return out


def positions_reference(model: MaxwellSlip, u: np.ndarray) -> np.ndarray:
    """Plain-Python :func:`positions`: each sample's balance solved by Brent's method."""
    from scipy.optimize import brentq

    x = (u[0] - model.u0) / model.c0
    b = np.full(model.order, x)
    out = np.empty(len(u))
    for t, ut in enumerate(u):

        def f(y, ut=ut):
            return model.u0 + model.c0 * y + model.k @ np.clip(y - b, -model.r, model.r) - ut

        span = abs(f(x)) / model.c0 + 1e-15
        x = brentq(f, x - span, x + span, xtol=1e-18, rtol=1e-14)
        b = np.clip(b, x - model.r, x + model.r)
        out[t] = x
    return out


def thresholds(order: int, half_stroke: float) -> np.ndarray:
    """r_j = (j − ½)/n · h, j = 1 … n."""
    return (np.arange(order) + 0.5) / order * half_stroke


def _design(x: np.ndarray, r: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The columns of U = u0 + c0·x + Σ k_i·strain_i at ``rows``."""
    return np.column_stack([np.ones(len(rows)), x[rows], element_strains(x, r, rows)])


def _solve(design: np.ndarray, u: np.ndarray, min_slope: float) -> np.ndarray:
    from scipy.optimize import lsq_linear

    lower = np.r_[-np.inf, min_slope, np.zeros(design.shape[1] - 2)]
    scale = np.maximum(np.abs(design).max(axis=0), 1e-300)  # columns of V, V/m: one conditioning
    fit = lsq_linear(design / scale, u, bounds=(lower * scale, np.inf), method="bvls")
    return fit.x / scale


def _rows(cycles: Sequence[slice], step: int = 1) -> np.ndarray:
    return np.concatenate([np.arange(c.start, c.stop, step) for c in cycles]).astype(np.int64)


def _chosen(cycles: Sequence[slice]) -> list[slice]:
    """At most MAX_CYCLES of the cycles, evenly spread over them."""
    if len(cycles) <= MAX_CYCLES:
        return list(cycles)
    return [cycles[k] for k in np.linspace(0, len(cycles) - 1, MAX_CYCLES).round().astype(int)]


@dataclass(frozen=True)
class HysteresisFit:
    """A recording's identified model and how well it does on cycles it has not seen.

    Errors in % of the steady cycles' stroke: ``forward`` is x predicted from the recorded U by the
    model against the recorded x; ``feedforward`` is the compensator's error, the voltage the model
    gives for the recorded x against the voltage that made it, in % of the steady drive span — which
    through the actuator's mean gain (stroke per drive span) is the same % of the stroke. Each as
    (rms, max); NaN without a test cycle."""

    model: MaxwellSlip
    validation_rms: dict[int, float]  # order → validation cycles' rms voltage error [V]
    cycles: tuple[int, int, int]  # fit, validation, test
    forward: tuple[float, float]
    feedforward: tuple[float, float]
    stroke: float  # [m]
    drive_span: float  # [V]
    note: str = field(default="")

    def parameters(self) -> list[tuple[str, float, str]]:
        """(name, value, unit) of every parameter, in µm and V."""
        m = self.model
        rows = [("u0", m.u0, "V"), ("c0", m.c0 * 1e-6, "V/µm")]
        for i, (r, k) in enumerate(zip(m.r, m.k), start=1):
            rows += [(f"r_{i}", r * 1e6, "µm"), (f"k_{i}", k * 1e-6, "V/µm")]
        return rows


def _errors(error: np.ndarray, scale: float) -> tuple[float, float]:
    if not error.size:
        return (np.nan, np.nan)
    return (
        float(100 * np.sqrt(np.mean(error**2)) / scale),
        float(100 * np.max(np.abs(error)) / scale),
    )


def fit_maxwell_slip(
    u: np.ndarray,
    x: np.ndarray,
    cycles: Sequence[slice],
    max_order: int = MAX_ORDER,
    tolerance: float = ORDER_TOLERANCE,
) -> HysteresisFit:
    """Identify the model on a recording's steady cycles (``cycles``: slices of u and x, in time
    order; at most MAX_CYCLES of them, evenly spread, and MAX_FIT_SAMPLES of their samples, are
    used). The whole record runs through the elements, so every cycle starts from the anchors
    its past left; only the cycles' samples enter the fit and the errors."""
    u, x = np.ascontiguousarray(u, float), np.ascontiguousarray(x, float)
    cycles = _chosen(cycles)
    step = max(1, -(-sum(c.stop - c.start for c in cycles) // MAX_FIT_SAMPLES))
    steady = _rows(cycles, step)
    stroke, span = float(np.ptp(x[steady])), float(np.ptp(u[steady]))
    min_slope = MIN_SLOPE_FRACTION * span / stroke
    if len(cycles) < MIN_CYCLES:
        sets = (cycles, [], [])
        note = f"{len(cycles)} steady cycle(s): fitted on all, order {max_order}, no held-out error"
    else:
        sets = (cycles[0::3], cycles[1::3], cycles[2::3])
        note = ""
    fit_rows, val_rows, test_rows = (_rows(s, step) if s else np.array([], np.int64) for s in sets)
    rows = np.concatenate([fit_rows, val_rows])
    order_rows = np.sort(np.concatenate([rows, test_rows]))
    fit_at, val_at, test_at = (
        np.searchsorted(order_rows, r) for r in (fit_rows, val_rows, test_rows)
    )
    validation: dict[int, float] = {}
    if val_rows.size:
        for n in range(1, max_order + 1):
            design = _design(x, thresholds(n, stroke / 2), order_rows)
            p = _solve(design[fit_at], u[fit_rows], min_slope)
            validation[n] = float(np.sqrt(np.mean((design[val_at] @ p - u[val_rows]) ** 2)))
        best = min(validation.values())
        enough = (1 + tolerance) * best + RESOLUTION * span
        order = min(n for n, e in validation.items() if e <= enough)
    else:
        order = max_order
    r = thresholds(order, stroke / 2)
    design = _design(x, r, order_rows)
    p = _solve(design[np.searchsorted(order_rows, rows)], u[rows], min_slope)
    model = MaxwellSlip(float(p[0]), float(p[1]), r, p[2:])
    forward = _errors(model.position(u)[test_rows] - x[test_rows], stroke)
    feedforward = _errors(design[test_at] @ p - u[test_rows], span)
    return HysteresisFit(
        model,
        validation,
        tuple(len(s) for s in sets),
        forward,
        feedforward,
        stroke,
        span,
        note,
    )
