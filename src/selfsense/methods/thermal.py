"""Self-heating of the piezo stack: lumped thermal model (thesis Chapter 7).

The thesis (Islam 2013, Section 7.1) balances hysteresis heat against surface
losses, Eq 7.2/7.3::

    rho c v dT/dt = P_loss - k_T A (T - T_amb)

which, with ``dT = T - T_amb``, is the first-order transfer function of Eq 7.4::

    dT(s) = P_loss(s) * gamma / (tau s + 1)
    tau   = rho v c / (k_T A)          (Eq 7.5)
    gamma = 1 / (k_T A)                (Eq 7.6)

and the heat source is the hysteresis voltage times the current (Eq 7.7-7.10)::

    P_loss = U_H I = (U - (k/alpha) x) I

with ``k/alpha = U_max / x_max`` (Eq 7.11).  The full predictor is Eq 7.12,
``T_SH = T_ref + (U - (k/alpha) x) I * gamma / (tau s + 1)``.  ``x`` can come
from the laser (``T_SH(PS)``) or from the hybrid position observer
(``T_SH(HPO)``); this module does not care where it comes from.

Conventions
-----------
* SI units throughout (m, m^2, m^3, s, W, V, A, kg); temperatures at the edges
  are in degrees Celsius, temperature *differences* are in kelvin.
* Slow-rate series (power, temperature) live on a uniform grid ``t_k``.  The
  power ``P[k]`` is the mean power over ``[t_k, t_k + dt)`` and is held
  constant there (zero-order hold); ``T[k]`` is the temperature at ``t_k``.
  With that convention the discretisation below is exact, not an Euler step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal, NamedTuple

import numpy as np

# scipy.optimize, .signal and .stats are imported where used: together 0.75 s of start-up that the
# streaming rules (thermal_extract, coupled's readers) would pay without calling them

__all__ = [
    "ThermalProperties",
    "ThermalModel",
    "KTEstimates",
    "P885_PROPERTIES",
    "TABLE_7_1",
    "K_T_TABLE_7_1",
    "K_OVER_ALPHA_TABLE_7_1",
    "T_REF",
    "k_T_from_tau",
    "k_T_from_gamma",
    "k_over_alpha_from_stroke",
    "power_loss",
    "PowerAverager",
    "average_power",
    "zoh_coefficients",
    "predict_temperature",
    "SelfHeatingTrace",
    "SelfHeatingEstimator",
    "ThermalFit",
    "identify_step",
    "identify_series",
    "steady_state_rise",
    "LinearFit",
    "linear_fit",
]


# --------------------------------------------------------------------------
# Physical properties and model parameters (Eq 7.5, 7.6)
# --------------------------------------------------------------------------


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{name} must be a finite positive number, got {value!r}")
    return value


@dataclass(frozen=True)
class ThermalProperties:
    """Lumped physical properties of the actuator (thesis Table 2.1).

    Attributes
    ----------
    rho : density [kg/m^3]
    c : specific heat [J/(kg K)]
    volume : active volume v [m^3]
    area : heat-exchanging surface A [m^2]
    """

    rho: float
    c: float
    volume: float
    area: float

    def __post_init__(self) -> None:
        for name in ("rho", "c", "volume", "area"):
            object.__setattr__(self, name, _positive(name, getattr(self, name)))

    @property
    def heat_capacity(self) -> float:
        """rho * c * v [J/K], the left-hand side coefficient of Eq 7.2."""
        return self.rho * self.c * self.volume

    @property
    def volume_to_area(self) -> float:
        """v / A [m], the geometry factor of the literature model (Eq 7.1)."""
        return self.volume / self.area


#: PI P-885.90 stack as used in the thesis (Table 2.1): v = 740 mm^3,
#: A = 640 mm^2, rho = 7800 kg/m^3, c = 350 J/(kg K).
P885_PROPERTIES = ThermalProperties(rho=7800.0, c=350.0, volume=740e-9, area=640e-6)


def k_T_from_tau(tau: float, props: ThermalProperties) -> float:
    """Heat-transfer coefficient implied by the time constant, Eq 7.5 solved
    for k_T: ``k_T = rho v c / (tau A)`` [W/(m^2 K)]."""
    return props.heat_capacity / (_positive("tau", tau) * props.area)


def k_T_from_gamma(gamma: float, props: ThermalProperties) -> float:
    """Heat-transfer coefficient implied by the static gain, Eq 7.6 solved for
    k_T: ``k_T = 1 / (gamma A)`` [W/(m^2 K)]."""
    return 1.0 / (_positive("gamma", gamma) * props.area)


class KTEstimates(NamedTuple):
    """The two k_T values a (tau, gamma) pair implies (Eq 7.5 and Eq 7.6).

    tau and gamma share the single unknown k_T once rho, c, v and A are fixed,
    so a measured pair over-determines it.  Agreement of the two estimates is
    a consistency check on the lumped model and on the material data; they
    agree exactly iff ``tau / gamma == rho c v``.
    """

    from_tau: float
    from_gamma: float

    @property
    def relative_mismatch(self) -> float:
        """(from_tau - from_gamma) / from_gamma."""
        return (self.from_tau - self.from_gamma) / self.from_gamma


@dataclass(frozen=True)
class ThermalModel:
    """First-order self-heating model ``dT = P gamma / (tau s + 1)`` (Eq 7.4).

    Attributes
    ----------
    tau : thermal time constant [s] (Eq 7.5)
    gamma : static gain, thermal resistance to ambient [K/W] (Eq 7.6)
    """

    tau: float
    gamma: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "tau", _positive("tau", self.tau))
        object.__setattr__(self, "gamma", _positive("gamma", self.gamma))

    @classmethod
    def from_k_T(cls, k_T: float, props: ThermalProperties) -> ThermalModel:
        """Model from a heat-transfer coefficient and physical properties
        (Eq 7.5 and Eq 7.6); by construction the result is self-consistent."""
        kA = _positive("k_T", k_T) * props.area
        return cls(tau=props.heat_capacity / kA, gamma=1.0 / kA)

    def k_T_estimates(self, props: ThermalProperties) -> KTEstimates:
        """Both k_T values implied by this (tau, gamma); see :class:`KTEstimates`."""
        return KTEstimates(k_T_from_tau(self.tau, props), k_T_from_gamma(self.gamma, props))

    @property
    def implied_heat_capacity(self) -> float:
        """tau / gamma [J/K]; equals rho c v when the model is consistent."""
        return self.tau / self.gamma

    def steady_state_rise(self, P: float | np.ndarray) -> float | np.ndarray:
        """Final temperature rise for a constant mean loss P: Eq 7.4 at s = 0,
        ``dT_inf = gamma P`` [K]."""
        if np.ndim(P) == 0:
            return self.gamma * float(P)
        return self.gamma * np.asarray(P, dtype=float)

    def step_response(self, t: np.ndarray, P: float) -> np.ndarray:
        """Analytic rise after a power step at t = 0 from equilibrium:
        ``gamma P (1 - exp(-t/tau))`` [K] (zero for t < 0)."""
        t = np.asarray(t, dtype=float)
        return np.where(t >= 0.0, -self.gamma * P * np.expm1(-np.maximum(t, 0.0) / self.tau), 0.0)


#: Table 7.1 as printed: tau = 100 s, gamma = 57 K/W (printed "W/K").  These
#: are rounded and not mutually consistent with Table 2.1 (see KTEstimates).
TABLE_7_1 = ThermalModel(tau=100.0, gamma=57.0)
#: Table 7.1 heat-transfer coefficient [W/(m^2 K)].
K_T_TABLE_7_1 = 28.0
#: Table 7.1 stiffness over force factor k/alpha [V/m].  Table 4.3 gives
#: 25.1e6 / 9.36 = 2.68e6 V/m instead; both are thesis numbers.
K_OVER_ALPHA_TABLE_7_1 = 2.85e6
#: Table 7.1 reference (ambient) temperature [deg C].
T_REF = 23.0


def k_over_alpha_from_stroke(U_max: float, x_max: float) -> float:
    """Eq 7.11: ``k/alpha = U_max / x_max`` [V/m] from the full-stroke point."""
    return _positive("U_max", U_max) / _positive("x_max", x_max)


# --------------------------------------------------------------------------
# Power loss (Eq 7.7, 7.10) and its streaming average
# --------------------------------------------------------------------------


def power_loss(U, x, I, k_over_alpha: float = K_OVER_ALPHA_TABLE_7_1) -> np.ndarray:
    """Instantaneous hysteresis power ``(U - (k/alpha) x) I`` [W], Eq 7.10.

    ``(k/alpha) x`` is the linear piezo voltage U_P (Eq 7.8), so the bracket is
    the hysteresis voltage U_H (Eq 7.9).  Per sample; the heat that matters is
    its mean over many cycles (the reactive part averages out), see
    :class:`PowerAverager`.  Inputs broadcast like numpy arrays.
    """
    U = np.asarray(U, dtype=float)
    x = np.asarray(x, dtype=float)
    I = np.asarray(I, dtype=float)
    return (U - float(k_over_alpha) * x) * I


def _samples_per_interval(fs: float, interval: float) -> int:
    fs = _positive("fs", fs)
    interval = _positive("interval", interval)
    exact = fs * interval
    n = int(round(exact))
    # A non-integer window would make the boundaries drift against the sample
    # clock and depend on rounding, which breaks chunk invariance; refuse it.
    if n < 1 or abs(n - exact) > 1e-9 * max(1.0, exact):
        raise ValueError(
            f"interval * fs must be a positive integer number of samples, got {exact!r}"
        )
    return n


class PowerAverager:
    """Streaming block mean of per-sample power (fast rate -> slow rate).

    Feeds of arbitrary length are accepted; every completed block of
    ``n = fs * interval`` samples yields one mean.  Only the incomplete tail
    (< n samples) is kept between calls, so memory does not grow with the
    capture length, and the output does not depend on where the chunks were
    cut: each block mean is computed from one contiguous row of n samples
    whatever the chunking.

    Output ``k`` is the mean over samples ``[k n, (k+1) n)``, i.e. over
    ``[t0 + k interval, t0 + (k+1) interval)`` - the zero-order-hold value that
    :func:`predict_temperature` expects at ``t_k = t0 + k interval``.
    """

    def __init__(self, fs: float, interval: float = 0.1) -> None:
        self.fs = float(fs)
        self.n_per_interval = _samples_per_interval(fs, interval)
        self._tail = np.empty(0, dtype=float)
        self.n_emitted = 0

    @property
    def interval(self) -> float:
        """Exact block duration n / fs [s]."""
        return self.n_per_interval / self.fs

    @property
    def pending(self) -> int:
        """Samples buffered towards the next (incomplete) block."""
        return int(self._tail.size)

    def update(self, p) -> np.ndarray:
        """Add samples; return the means of the blocks completed by them."""
        p = np.asarray(p, dtype=float).ravel()
        data = np.concatenate([self._tail, p]) if self._tail.size else p
        n = self.n_per_interval
        m = data.size // n
        means = data[: m * n].reshape(m, n).mean(axis=1)
        # copy: do not keep the caller's (possibly huge) chunk alive via a view
        self._tail = data[m * n :].copy()
        self.n_emitted += m
        return means

    def flush(self) -> np.ndarray:
        """Mean of the incomplete final block (0 or 1 values), then reset the
        tail.  That value covers fewer than n samples; callers that need equal
        intervals should discard it."""
        if self._tail.size == 0:
            return np.empty(0, dtype=float)
        out = np.array([self._tail.mean()])
        self._tail = np.empty(0, dtype=float)
        self.n_emitted += 1
        return out


def average_power(p, fs: float, interval: float = 0.1, t0: float = 0.0):
    """One-shot :class:`PowerAverager`: returns ``(t, P)`` with ``t`` the block
    start times and ``P`` the block means; an incomplete tail is dropped."""
    avg = PowerAverager(fs, interval)
    P = avg.update(p)
    return t0 + np.arange(P.size) * avg.interval, P


# --------------------------------------------------------------------------
# Temperature prediction (Eq 7.4, 7.12)
# --------------------------------------------------------------------------


def zoh_coefficients(model: ThermalModel, dt: float) -> tuple[float, float]:
    """Exact zero-order-hold discretisation of ``gamma / (tau s + 1)``.

    Returns ``(a, b)`` for ``dT[k+1] = a dT[k] + b P[k]`` with
    ``a = exp(-dt/tau)`` and ``b = gamma (1 - a)``; identical to
    ``scipy.signal.cont2discrete(..., method="zoh")`` but in closed form
    (expm1 keeps ``1 - a`` accurate when dt << tau).
    """
    dt = _positive("dt", dt)
    one_minus_a = -math.expm1(-dt / model.tau)
    return 1.0 - one_minus_a, model.gamma * one_minus_a


def _uniform_step(t: np.ndarray) -> float:
    if t.ndim != 1 or t.size < 2:
        raise ValueError("t must be a 1-D array with at least two samples")
    d = np.diff(t)
    dt = float(np.mean(d))
    if not dt > 0 or np.max(np.abs(d - dt)) > 1e-6 * dt:
        raise ValueError("t must be strictly increasing and uniformly spaced (ZOH grid)")
    return dt


def _unit_response(P: np.ndarray, a: float) -> np.ndarray:
    """Response of ``(1 - a) z^-1 / (1 - a z^-1)`` to P from rest: the ZOH rise
    per unit gamma, aligned so that ``out[0] = 0`` (T[k] at the start of P[k])."""
    from scipy import signal

    return signal.lfilter([0.0, 1.0 - a], [1.0, -a], P)


def predict_temperature(
    t,
    P,
    model: ThermalModel,
    T0: float | None = None,
    T_amb: float = T_REF,
) -> np.ndarray:
    """Simulate Eq 7.4/7.12 on a slow-rate grid, exactly (ZOH, not Euler).

    Parameters
    ----------
    t : uniformly spaced times [s].
    P : mean loss power [W] on ``[t_k, t_k + dt)`` (scalar or same length as t).
    model : tau, gamma.
    T0 : temperature at ``t[0]`` [deg C]; None means at ambient (equilibrium).
    T_amb : ambient temperature [deg C] (thesis T_ref = 23 deg C).

    Returns
    -------
    T : temperature at each ``t_k`` [deg C]; ``T[0] = T0`` and the last power
    sample only acts after the last time stamp.
    """
    t = np.asarray(t, dtype=float)
    if t.ndim == 1 and t.size == 1:
        return np.array([T_amb if T0 is None else float(T0)])
    dt = _uniform_step(t)
    P = np.broadcast_to(np.asarray(P, dtype=float), t.shape)
    a, b = zoh_coefficients(model, dt)
    x0 = 0.0 if T0 is None else float(T0) - float(T_amb)
    from scipy import signal

    # lfilter with b0 = 0: y[0] equals the initial state, y[k+1] = a y[k] + b P[k]
    dT, _ = signal.lfilter([0.0, b], [1.0, -a], P, zi=[x0])
    return float(T_amb) + dT


@dataclass(frozen=True, eq=False)
class SelfHeatingTrace:
    """Slow-rate output of the self-heating predictor.

    t : interval start times [s]; P : mean loss power on each interval [W];
    T : predicted temperature at ``t`` [deg C].
    """

    t: np.ndarray
    P: np.ndarray
    T: np.ndarray


class SelfHeatingEstimator:
    """Streaming Eq 7.12: raw ``U, x, I`` at fs in, ``T_SH`` at slow rate out.

    ``x`` is the laser position for ``T_SH(PS)`` or the observer estimate for
    ``T_SH(HPO)``.  State (power tail and temperature) is carried across calls,
    so long captures can be processed chunk by chunk with flat memory, and a
    temperature-compensated observer can read :attr:`temperature` between
    chunks (the thesis closes that loop because temperature is slow).
    """

    def __init__(
        self,
        fs: float,
        model: ThermalModel,
        k_over_alpha: float = K_OVER_ALPHA_TABLE_7_1,
        interval: float = 0.1,
        T0: float | None = None,
        T_amb: float = T_REF,
        t0: float = 0.0,
    ) -> None:
        self.model = model
        self.k_over_alpha = float(k_over_alpha)
        self.T_amb = float(T_amb)
        self.t0 = float(t0)
        self._avg = PowerAverager(fs, interval)
        self._a, self._b = zoh_coefficients(model, self._avg.interval)
        self._dT = 0.0 if T0 is None else float(T0) - self.T_amb

    @property
    def temperature(self) -> float:
        """Temperature at the end of the last completed interval [deg C]."""
        return self.T_amb + self._dT

    def update(self, U, x, I) -> SelfHeatingTrace:
        """Consume one chunk of samples; return the intervals it completed."""
        P = self._avg.update(power_loss(U, x, I, self.k_over_alpha))
        k0 = self._avg.n_emitted - P.size
        t = self.t0 + (k0 + np.arange(P.size)) * self._avg.interval
        if P.size == 0:
            return SelfHeatingTrace(t, P, np.empty(0))
        from scipy import signal

        dT, zf = signal.lfilter([0.0, self._b], [1.0, -self._a], P, zi=[self._dT])
        # zf is the state after the last sample: the rise at the next boundary
        self._dT = float(zf[0])
        return SelfHeatingTrace(t, P, self.T_amb + dT)

    def run(self, U, x, I, chunk_size: int = 1 << 18) -> SelfHeatingTrace:
        """Eq 7.12 over whole records: ``T_SH(PS)`` or ``T_SH(HPO)`` depending on which position
        ``x`` is passed, from the estimator's current state.

        The inputs are sliced ``chunk_size`` samples at a time, so memory-mapped or lazily loaded
        arrays are never materialised whole.  The incomplete final interval is dropped (its power
        would act only after the last time stamp).
        """
        if int(chunk_size) < 1:
            raise ValueError("chunk_size must be at least 1")
        n = len(U)
        if len(x) != n or len(I) != n:
            raise ValueError("U, x and I must have the same length")
        parts = []
        for i in range(0, n, int(chunk_size)):
            j = i + int(chunk_size)
            parts.append(self.update(np.asarray(U[i:j]), np.asarray(x[i:j]), np.asarray(I[i:j])))
        if not parts:
            e = np.empty(0)
            return SelfHeatingTrace(e, e, e)
        return SelfHeatingTrace(*(np.concatenate([getattr(p, f) for p in parts]) for f in "tPT"))


# --------------------------------------------------------------------------
# Identification (Section 7.3)
# --------------------------------------------------------------------------

T0Spec = float | Literal["ambient", "free"]


@dataclass(frozen=True)
class ThermalFit:
    """Result of :func:`identify_step` / :func:`identify_series`.

    tau [s], gamma [K/W], T_amb and T0 [deg C] (fitted or as given);
    k_T_from_tau / k_T_from_gamma [W/(m^2 K)] via Eq 7.5 / 7.6 with the given
    properties; r_squared and residual_max (max |T - T_fit|, K) and rmse [K];
    tau_stderr / gamma_stderr are the usual least-squares standard errors,
    which assume white noise and so are optimistic for real thermometers.
    """

    tau: float
    gamma: float
    T_amb: float
    T0: float
    k_T_from_tau: float
    k_T_from_gamma: float
    r_squared: float
    residual_max: float
    rmse: float
    tau_stderr: float
    gamma_stderr: float
    n: int
    fitted: np.ndarray = field(repr=False, compare=False)

    @property
    def model(self) -> ThermalModel:
        return ThermalModel(self.tau, self.gamma)

    @property
    def k_T(self) -> KTEstimates:
        return KTEstimates(self.k_T_from_tau, self.k_T_from_gamma)


def _profile_fit(y, basis, t_span, dt_min, tau_bounds, props, T_amb, T0, n_grid=81):
    """Variable projection: for a given tau the model is linear in
    (T_amb, T0, gamma), so only tau needs a (1-D, bounded) search.  No initial
    guess is needed and the linear part is solved exactly.

    ``basis(tau) -> (e, s)`` where ``e`` is the free-decay factor from the
    initial state and ``s`` the unit-gamma forced rise, so that
    ``T = T_amb (1 - e) + T0 e + gamma s``.
    """
    y = np.asarray(y, dtype=float)
    lo, hi = tau_bounds if tau_bounds is not None else (dt_min / 2.0, 20.0 * t_span)
    lo, hi = _positive("tau lower bound", lo), _positive("tau upper bound", hi)
    if not hi > lo:
        raise ValueError("tau_bounds must be increasing")

    def design(tau):
        e, s = basis(tau)
        rhs = y.copy()
        cols, names = [], []
        if T_amb is None and T0 == "ambient":
            cols += [np.ones_like(y)]
            names += ["T_amb"]
        elif T_amb is None and T0 == "free":
            cols += [1.0 - e, e]
            names += ["T_amb", "T0"]
        elif T_amb is None:  # T0 known
            rhs -= float(T0) * e
            cols += [1.0 - e]
            names += ["T_amb"]
        else:
            rhs -= float(T_amb) * (1.0 - e)
            if T0 == "ambient":
                rhs -= float(T_amb) * e
            elif T0 == "free":
                cols += [e]
                names += ["T0"]
            else:
                rhs -= float(T0) * e
        cols.append(s)
        names.append("gamma")
        return np.column_stack(cols), rhs, names

    def solve(tau):
        X, rhs, names = design(tau)
        coef, *_ = np.linalg.lstsq(X, rhs, rcond=None)
        r = rhs - X @ coef
        return float(r @ r), coef, X, names

    grid = np.geomspace(lo, hi, n_grid)
    ssr = np.array([solve(tau)[0] for tau in grid])
    i = int(np.argmin(ssr))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, n_grid - 1)]
    from scipy import optimize

    res = optimize.minimize_scalar(
        lambda u: solve(math.exp(u))[0],
        bounds=(math.log(a), math.log(b)),
        method="bounded",
        options={"xatol": 1e-10},
    )
    tau = math.exp(res.x)
    ssr_min, coef, X, names = solve(tau)
    # Conditioning of the column-normalised design: exactly collinear columns
    # (e.g. 1 - e and P(1 - e) for one power level) are not separable.
    Xn = X / np.linalg.norm(X, axis=0)
    if not np.all(np.isfinite(Xn)) or np.linalg.cond(Xn) > 1e8:
        raise ValueError(
            "gamma, T_amb and T0 are not separately identifiable from this record "
            "(single power level with both temperatures free): give T_amb or T0, "
            "or use a record with several power levels"
        )
    if tau <= lo * 1.001 or tau >= hi * 0.999:
        raise ValueError(f"tau fit hit the search bound ({tau:.4g} s); widen tau_bounds")
    p = dict(zip(names, coef))
    gamma = float(p["gamma"])
    if not gamma > 0:
        raise ValueError(f"fitted gamma is not positive ({gamma:.4g}); no heating in record?")
    T_amb_hat = float(p.get("T_amb", T_amb))
    if T0 == "ambient":
        T0_hat = T_amb_hat
    elif T0 == "free":
        T0_hat = float(p["T0"])
    else:
        T0_hat = float(T0)

    e, s = basis(tau)
    fitted = T_amb_hat * (1.0 - e) + T0_hat * e + gamma * s
    resid = y - fitted
    sst = float(np.sum((y - y.mean()) ** 2))

    # Standard errors from the full Jacobian (tau by central difference).
    h = 1e-6 * tau
    e_p, s_p = basis(tau + h)
    e_m, s_m = basis(tau - h)
    d_tau = (
        (T_amb_hat * (1 - e_p) + T0_hat * e_p + gamma * s_p)
        - (T_amb_hat * (1 - e_m) + T0_hat * e_m + gamma * s_m)
    ) / (2 * h)
    J = np.column_stack([d_tau, X])
    dof = y.size - J.shape[1]
    tau_se = gamma_se = float("nan")
    if dof > 0:
        try:
            cov = np.linalg.inv(J.T @ J) * (ssr_min / dof)
            tau_se = float(math.sqrt(max(cov[0, 0], 0.0)))
            gamma_se = float(math.sqrt(max(cov[-1, -1], 0.0)))
        except np.linalg.LinAlgError:
            pass

    props = props if props is not None else P885_PROPERTIES
    return ThermalFit(
        tau=tau,
        gamma=gamma,
        T_amb=T_amb_hat,
        T0=T0_hat,
        k_T_from_tau=k_T_from_tau(tau, props),
        k_T_from_gamma=k_T_from_gamma(gamma, props),
        r_squared=1.0 - ssr_min / sst if sst > 0 else float("nan"),
        residual_max=float(np.max(np.abs(resid))),
        rmse=float(math.sqrt(ssr_min / y.size)),
        tau_stderr=tau_se,
        gamma_stderr=gamma_se,
        n=int(y.size),
        fitted=fitted,
    )


def _check_T0(T0) -> T0Spec:
    if isinstance(T0, str):
        if T0 not in ("ambient", "free"):
            raise ValueError("T0 must be a temperature, 'ambient' or 'free'")
        return T0
    return float(T0)


def identify_step(
    t,
    T,
    P: float,
    *,
    t_step: float | None = None,
    T_amb: float | None = None,
    T0: T0Spec = "ambient",
    props: ThermalProperties | None = None,
    tau_bounds: tuple[float, float] | None = None,
) -> ThermalFit:
    """Fit tau and gamma to a heating step with known mean loss power P [W].

    After the step at ``t_step`` (default ``t[0]``; earlier samples are
    ignored) the exact solution of Eq 7.3 is::

        T(t) = T_amb + (T0 - T_amb) e^{-(t-t_step)/tau} + gamma P (1 - e^{-(t-t_step)/tau})

    This is how the thesis reads tau off Fig 7.1; here gamma is fitted too
    instead of being derived from Eq 7.5/7.6, so both k_T estimates can be
    compared.  ``t`` need not be uniform.

    T_amb : known ambient [deg C] or None to fit it.
    T0 : ``"ambient"`` (default, record starts at equilibrium), ``"free"``
        (fitted; needs T_amb given for a single step) or a known value.
    props : physical properties for the k_T estimates (default P-885.90).
    tau_bounds : search range for tau [s] (default dt/2 ... 20 x record length).

    Passing ``P = 1`` makes ``gamma`` the asymptotic rise in kelvin, which is
    what :func:`steady_state_rise` does when the power is unknown.
    """
    t = np.asarray(t, dtype=float).ravel()
    T = np.asarray(T, dtype=float).ravel()
    if t.shape != T.shape:
        raise ValueError("t and T must have the same length")
    P = float(P)
    if P == 0.0:
        raise ValueError("P must be non-zero for a heating step")
    ts = float(t[0]) if t_step is None else float(t_step)
    keep = t >= ts
    t, T = t[keep], T[keep]
    if t.size < 4:
        raise ValueError("need at least four samples after the step")
    tau_rel = t - ts
    dt_min = float(np.min(np.diff(t))) if t.size > 1 else 1.0
    if not dt_min > 0:
        raise ValueError("t must be strictly increasing")

    def basis(tau):
        em1 = np.expm1(-tau_rel / tau)
        return 1.0 + em1, -P * em1

    return _profile_fit(
        T, basis, float(tau_rel[-1]), dt_min, tau_bounds, props, T_amb, _check_T0(T0)
    )


def identify_series(
    t,
    T,
    P,
    *,
    T_amb: float | None = None,
    T0: T0Spec = "ambient",
    props: ThermalProperties | None = None,
    tau_bounds: tuple[float, float] | None = None,
) -> ThermalFit:
    """Fit tau and gamma so that :func:`predict_temperature` driven by the
    slow-rate power ``P(t)`` best matches the measured ``T(t)`` (least squares).

    Handles any power profile (staircases, heating and cooling, mixed
    frequency runs as in Fig 7.6/7.12).  ``t`` must be the uniform grid of
    ``P`` and ``T`` with the ZOH convention of :func:`predict_temperature`.
    With two or more distinct power levels T_amb and T0 can both be free.
    """
    t = np.asarray(t, dtype=float).ravel()
    T = np.asarray(T, dtype=float).ravel()
    P = np.asarray(P, dtype=float).ravel()
    if not (t.shape == T.shape == P.shape):
        raise ValueError("t, T and P must have the same length")
    if t.size < 4:
        raise ValueError("need at least four samples")
    dt = _uniform_step(t)
    k = np.arange(t.size)

    def basis(tau):
        a = math.exp(-dt / tau)
        return a**k, _unit_response(P, a)

    return _profile_fit(T, basis, float(t[-1] - t[0]), dt, tau_bounds, props, T_amb, _check_T0(T0))


def steady_state_rise(
    t,
    T,
    *,
    t_step: float | None = None,
    T_amb: float | None = None,
    T0: T0Spec = "ambient",
    tau_bounds: tuple[float, float] | None = None,
) -> float:
    """Asymptotic temperature rise ``T_inf - T_amb`` [K] of a heating record.

    The thesis runs are ~400 s, only ~3.5 tau, so the last sample is still a
    few per cent short of the steady state; fitting the exponential and taking
    its asymptote removes that bias.  Use this for the Fig 7.2 (vs frequency)
    and Fig 7.3 (vs V^2) points; for a known power use
    ``ThermalModel.steady_state_rise(P) = gamma P``.
    """
    fit = identify_step(t, T, 1.0, t_step=t_step, T_amb=T_amb, T0=T0, tau_bounds=tau_bounds)
    return fit.gamma


# --------------------------------------------------------------------------
# Linear trends of Section 7.2 (Fig 7.2, 7.3)
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class LinearFit:
    """Ordinary least-squares line ``y = slope x + intercept``."""

    slope: float
    intercept: float
    r_squared: float
    slope_stderr: float
    intercept_stderr: float
    n: int

    def __call__(self, x):
        return self.slope * np.asarray(x, dtype=float) + self.intercept


def linear_fit(x, y) -> LinearFit:
    """Straight-line fit for Chapter 7's trends: steady rise vs driving
    frequency at 100 V (Fig 7.2; pass ``x = f``) and vs voltage squared at
    150 Hz (Fig 7.3; pass ``x = V**2``)."""
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if x.shape != y.shape or x.size < 2:
        raise ValueError("x and y must have the same length, at least 2")
    from scipy import stats

    r = stats.linregress(x, y)
    return LinearFit(
        slope=float(r.slope),
        intercept=float(r.intercept),
        r_squared=float(r.rvalue**2),
        slope_stderr=float(r.stderr),
        intercept_stderr=float(r.intercept_stderr),
        n=int(x.size),
    )
