"""Hybrid position observer (HPO) for piezoelectric position self-sensing.

Islam (2013), Chapter 5.  Two self-sensing signals of the same stack are fused:

* charge-based PSS (Eq 5.3): ``x_I = q / a0`` with ``q = ∫ I dt``.  Good at high frequency,
  but a current-probe offset ``I0`` integrates into an unbounded drift;
* capacitance-based PSS (Eq 5.4): ``x_CP = Γ(C_e)``.  Drift-free but noisy and only
  refreshed at a low rate, so only useful at low frequency.

Observer structure (Fig 5.9)::

    x̂   = 1/(a0·s) · (I − Î0)                     plant model G(s)/s with G = 1/a0 (Eq 5.3)
    Î0  = L(s) · (x̂ − x_CP),  L(s) = LP + LI/s    PI offset estimator (Eq 5.5)

which gives the complementary pair (Eq 5.6, 5.8) and the offset path (Eq 5.7)::

    x̂/x_I  = a0 s² / (a0 s² + LP s + LI)
    x̂/x_CP = (LP s + LI) / (a0 s² + LP s + LI)
    x̂/I0   = s / (a0 s² + LP s + LI)

with gains (Eq 5.9, written with an explicit damping ζS; the thesis uses ζS = 1)::

    LP = 2 ζS ωS a0,   LI = ωS² a0.

Everything is in SI units: I [A], x [m], a0 [C/m], ωS [rad/s], so x̂/I0 is in m/A.

Module contents
---------------
* :class:`HPOGains`                – a0, ωS, ζS and the derived LP, LI (Eq 5.9).
* :func:`transfer_functions`       – Eq 5.6–5.8 built with python-control block algebra.
* :func:`magnitude_response`       – |H(j2πf)| on a frequency grid (Fig 5.10).
* :func:`continuous_state_space`   – the 2-input (I, x_CP) → 2-output (x̂, Î0) plant.
* :func:`discretize`               – its discrete-time matrices (scipy ``cont2discrete``).
* :func:`hpo_update`, :func:`hpo_run` – numba per-sample kernels (callable from other
  ``@njit`` code, e.g. the digital twin's real-time loop).
* :func:`reference_simulate`       – plain scipy (``dlsim``) reference of the same system.
* :class:`HybridPositionObserver`  – streaming, chunk-invariant observer object.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numba
import numpy as np

from selfsense.methods.lti import tustin

if TYPE_CHECKING:
    import control

# python-control is imported inside the functions that build transfer functions: with the
# matplotlib it pulls in it costs ≈ 0.4 s per process, and the streaming jobs (one per capture)
# only need the state-space matrices. For the same reason scipy.signal is imported only by the
# zero-order-hold discretisation and the reference: Tustin's comes from selfsense.methods.lti.

__all__ = [
    "THESIS_A0",
    "THESIS_OMEGA_S",
    "THESIS_ZETA_S",
    "HPOGains",
    "load_gains",
    "transfer_functions",
    "magnitude_response",
    "peak_offset_gain",
    "continuous_state_space",
    "DiscreteHPO",
    "discretize",
    "equilibrium_state",
    "hpo_update",
    "hpo_run",
    "reference_simulate",
    "sample_and_hold",
    "HybridPositionObserver",
]

# Table 5.3 (Islam 2013).  LP and LI are *not* stored: they follow from Eq 5.9.  (Table 5.3
# prints LI = 641, but Eq 5.9 with these a0 and ωS gives 671.1 – a known slip in the table.)
THESIS_A0 = 17.0  # C/m, charge-position gain (Eq 5.3)
THESIS_OMEGA_S = 2.0 * np.pi  # rad/s, observer transition frequency (1 Hz)
THESIS_ZETA_S = 1.0  # observer damping

# Names of the transfer functions returned by transfer_functions() (keys of the dict).
TF_NAMES = ("xhat/x_I", "xhat/x_CP", "xhat/x", "xhat/I0")


# ---------------------------------------------------------------------------------------------
# Gains
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class HPOGains:
    """Observer parameters (Table 5.3) with the PI gains derived from Eq 5.9.

    Attributes
    ----------
    a0 : float
        Charge–position gain [C/m], ``x_I = q / a0`` (Eq 5.3).
    omega_s : float
        Transition ("switching") frequency ωS [rad/s] between capacitance PSS (below) and
        charge PSS (above).
    zeta_s : float
        Damping ζS of the observer's characteristic polynomial ``a0 (s² + 2ζS ωS s + ωS²)``.
    """

    a0: float = THESIS_A0
    omega_s: float = THESIS_OMEGA_S
    zeta_s: float = THESIS_ZETA_S

    def __post_init__(self) -> None:
        # Negative/zero values would make the observer unstable or degenerate; fail early.
        for name in ("a0", "omega_s", "zeta_s"):
            v = float(getattr(self, name))
            if not np.isfinite(v) or v <= 0.0:
                raise ValueError(f"HPOGains.{name} must be finite and > 0, got {v!r}")

    @classmethod
    def from_a0(
        cls,
        a0: float = THESIS_A0,
        omega_s: float = THESIS_OMEGA_S,
        zeta_s: float = THESIS_ZETA_S,
    ) -> HPOGains:
        """Gains for a given charge–position gain ``a0`` [C/m] (e.g. one identified from data)."""
        return cls(a0=float(a0), omega_s=float(omega_s), zeta_s=float(zeta_s))

    @classmethod
    def from_record(cls, record: Mapping) -> HPOGains:
        """The gains a :meth:`record` holds (e.g. read back from ``observer.json``)."""
        return cls(record["a0"], record["omega_s"], record["zeta_s"])

    def record(self) -> dict:
        """Plain data for a JSON artefact; :meth:`from_record` reads it back."""
        return asdict(self)

    @property
    def LP(self) -> float:
        """Proportional gain LP = 2 ζS ωS a0 [C·rad/(s·m)] (Eq 5.9)."""
        return 2.0 * self.zeta_s * self.omega_s * self.a0

    @property
    def LI(self) -> float:
        """Integral gain LI = ωS² a0 [C·rad²/(s²·m)] (Eq 5.9)."""
        return self.omega_s**2 * self.a0


def load_gains(path: str | Path) -> HPOGains:
    """The observer gains (Table 5.3) the charge-sensing stage wrote as
    ``record() | provenance``."""
    return HPOGains.from_record(json.loads(Path(path).read_text()))


# ---------------------------------------------------------------------------------------------
# Continuous-time transfer functions (Eq 5.6–5.8, Fig 5.10)
# ---------------------------------------------------------------------------------------------
def transfer_functions(gains: HPOGains) -> dict[str, control.TransferFunction]:
    """Closed-loop transfer functions of the HPO, built by block algebra in python-control.

    Blocks: the integrating plant model ``G(s)/s = 1/(a0 s)`` (Eq 5.3) and the offset estimator
    ``L(s) = LP + LI/s`` (Eq 5.5); the loop gain is ``s⁻¹ G(s) L(s)``.

    Returns a dict with keys

    * ``"xhat/x_I"``  – 1 / (1 + s⁻¹GL)          = a0 s² / (a0 s² + LP s + LI)       (Eq 5.6)
    * ``"xhat/x_CP"`` – s⁻¹GL / (1 + s⁻¹GL)      = (LP s + LI) / (a0 s² + LP s + LI)  (Eq 5.8)
    * ``"xhat/x"``    – their sum (x_I = x_CP = x): ideally exactly 1
    * ``"xhat/I0"``   – s⁻¹G / (1 + s⁻¹GL)       = s / (a0 s² + LP s + LI)  [m/A]   (Eq 5.7)

    The sum is returned *unsimplified* (as python-control forms it) so that callers and tests
    can check the complementarity themselves, e.g. with ``control.minreal``.
    """
    import control

    plant = control.tf([1.0], [gains.a0, 0.0])  # 1/(a0 s): current -> position
    offset_estimator = control.tf([gains.LP, gains.LI], [1.0, 0.0])  # LP + LI/s
    loop = plant * offset_estimator

    h_xi = control.feedback(1.0, loop)  # x_I enters after the integrator
    h_xcp = control.feedback(loop, 1.0)  # x_CP is the "measurement" of the observer
    h_i0 = control.feedback(plant, offset_estimator)  # I0 enters before the integrator
    return {
        "xhat/x_I": h_xi,
        "xhat/x_CP": h_xcp,
        "xhat/x": h_xi + h_xcp,
        "xhat/I0": h_i0,
    }


def magnitude_response(
    tfs: dict[str, control.TransferFunction], freqs_hz: np.ndarray, db: bool = False
) -> dict[str, np.ndarray]:
    """|H(j 2π f)| of each transfer function on the grid ``freqs_hz`` [Hz] (Fig 5.10).

    ``db=True`` returns 20·log10|H|.  Units follow the transfer function: dimensionless for the
    position paths, m/A for ``"xhat/I0"`` (convert at the presentation edge if µm/A is wanted).
    """
    f = np.asarray(freqs_hz, dtype=float)
    s = 2j * np.pi * f
    out = {}
    for name, h in tfs.items():
        # Evaluate the rational function directly (TransferFunction.__call__): no Bode wrapping.
        mag = np.abs(np.asarray(h(s), dtype=complex)).reshape(f.shape)
        out[name] = 20.0 * np.log10(mag) if db else mag
    return out


def peak_offset_gain(gains: HPOGains) -> tuple[float, float]:
    """Peak of |x̂/I0(jω)| [m/A] and the angular frequency [rad/s] where it occurs (Eq 5.7).

    |x̂/I0| = ω / |a0 (ωS² − ω²) + j LP ω| peaks at ω = ωS for any ζS, with value
    1 / LP = 1 / (2 ζS ωS a0).  For the thesis values this is 4.68e-3 m/A = −46.6 dB (in m/A),
    consistent with the thesis's "offset current attenuated by at least 45 dB" – but the dB
    figure depends on the units (in µm/A the same peak is +73.4 dB).
    """
    return 1.0 / gains.LP, gains.omega_s


# ---------------------------------------------------------------------------------------------
# State-space model used for the streaming observer
# ---------------------------------------------------------------------------------------------
def continuous_state_space(gains: HPOGains) -> control.StateSpace:
    """Continuous 2-input, 2-output state-space model of the HPO (Fig 5.9).

    Inputs ``u = [I, x_CP]`` (measured current [A], capacitance PSS position [m]);
    outputs ``y = [x̂, Î0]`` (position estimate [m], estimated offset current [A]).

    States are chosen with a physical meaning so that initial conditions are easy to reason
    about: ``z1 = x̂`` (= q̂/a0) and ``z2 = ∫ (x̂ − x_CP) dt`` (the PI integrator, so that
    ``Î0 = LP (x̂ − x_CP) + LI z2``)::

        ż1 = (I − Î0) / a0 = (−LP z1 − LI z2 + I + LP x_CP) / a0
        ż2 = z1 − x_CP

    Its transfer functions equal Eq 5.6–5.8 (checked in the tests against the block-algebra
    versions of :func:`transfer_functions`).
    """
    import control

    return control.ss(*_state_matrices(gains), inputs=["I", "x_CP"], outputs=["xhat", "I0hat"])


def _state_matrices(gains: HPOGains) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A, B, C, D of :func:`continuous_state_space`."""
    a0, lp, li = gains.a0, gains.LP, gains.LI
    A = np.array([[-lp / a0, -li / a0], [1.0, 0.0]])
    B = np.array([[1.0 / a0, lp / a0], [0.0, -1.0]])
    C = np.array([[1.0, 0.0], [lp, li]])
    D = np.array([[0.0, 0.0], [0.0, -lp]])
    return A, B, C, D


class DiscreteHPO(NamedTuple):
    """Discrete-time HPO matrices (x[k+1] = Ad x[k] + Bd u[k], y[k] = Cd x[k] + Dd u[k]).

    All arrays are C-contiguous float64, ready to hand to the numba kernels.
    """

    Ad: np.ndarray  # (2, 2)
    Bd: np.ndarray  # (2, 2), columns: I, x_CP
    Cd: np.ndarray  # (2, 2), rows: x̂, Î0
    Dd: np.ndarray  # (2, 2)
    dt: float  # sample period [s]
    method: str  # "tustin" or "zoh"


_METHODS = ("tustin", "zoh")


def discretize(gains: HPOGains, fs: float, method: str = "tustin") -> DiscreteHPO:
    """Discretise :func:`continuous_state_space` at sample rate ``fs`` [Hz].

    ``method="tustin"`` (default): the bilinear map turns the charge integrator into the
    trapezoidal rule, the natural discrete version of q = ∫I dt for a *sampled* (not held)
    current, and maps the continuous complementarity x̂/x_I + x̂/x_CP = 1 exactly into the
    z-domain.  It has direct feed-through (Dd ≠ 0 in the x̂ row): x̂[k] uses I[k].
    ``method="zoh"``: exact for piecewise-constant inputs (true for the held x_CP, a rectangle
    rule with half a sample of lag for I); strictly proper x̂ (no feed-through), which a
    controller loop without an algebraic loop may prefer.
    """
    if method not in _METHODS:
        raise ValueError(f"method must be one of {sorted(_METHODS)}, got {method!r}")
    fs = float(fs)
    if not np.isfinite(fs) or fs <= 0.0:
        raise ValueError(f"fs must be finite and > 0, got {fs!r}")
    dt = 1.0 / fs
    if method == "tustin":
        Ad, Bd, Cd, Dd = tustin(*_state_matrices(gains), dt)
    else:
        import scipy.signal

        Ad, Bd, Cd, Dd, _ = scipy.signal.cont2discrete(_state_matrices(gains), dt, method="zoh")
    as_c = lambda m: np.ascontiguousarray(m, dtype=np.float64)  # noqa: E731
    return DiscreteHPO(as_c(Ad), as_c(Bd), as_c(Cd), as_c(Dd), dt, method)


def equilibrium_state(
    disc: DiscreteHPO, position: float = 0.0, offset_current: float = 0.0
) -> np.ndarray:
    """Discrete state in equilibrium with constant inputs ``I = offset_current``,
    ``x_CP = position``.

    In that equilibrium x̂ = position and Î0 = offset_current (the PI integrator has absorbed
    the offset), so starting there produces no start-up transient.  Solving the discrete fixed
    point (rather than using the continuous states) keeps this right for any discretisation,
    whose state coordinates need not equal the continuous ones (Tustin's do not).
    """
    u = np.array([offset_current, position], dtype=np.float64)
    # I − Ad is invertible: the observer poles are at −ωS (ζS = 1), never at z = 1.
    return np.linalg.solve(np.eye(disc.Ad.shape[0]) - disc.Ad, disc.Bd @ u)


# ---------------------------------------------------------------------------------------------
# numba kernels
# ---------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def hpo_update(Ad, Bd, Cd, Dd, state, current, xcp):
    """Advance the discrete HPO by one sample; returns ``(x̂[k], Î0[k])``.

    ``state`` (float64 array of length 2) holds x[k] on entry and is overwritten with x[k+1].
    Written for 2 states / 2 inputs / 2 outputs with unrolled arithmetic: this is the inner
    loop of the digital twin and of every observer run, so it avoids temporaries.  Any
    ``@numba.njit`` function may call it with the arrays of a :class:`DiscreteHPO`.
    """
    s0 = state[0]
    s1 = state[1]
    xhat = Cd[0, 0] * s0 + Cd[0, 1] * s1 + Dd[0, 0] * current + Dd[0, 1] * xcp
    i0hat = Cd[1, 0] * s0 + Cd[1, 1] * s1 + Dd[1, 0] * current + Dd[1, 1] * xcp
    state[0] = Ad[0, 0] * s0 + Ad[0, 1] * s1 + Bd[0, 0] * current + Bd[0, 1] * xcp
    state[1] = Ad[1, 0] * s0 + Ad[1, 1] * s1 + Bd[1, 0] * current + Bd[1, 1] * xcp
    return xhat, i0hat


@numba.njit(cache=True)
def hpo_run(Ad, Bd, Cd, Dd, state, current, xcp, xhat_out, i0hat_out):
    """Run :func:`hpo_update` over arrays ``current``, ``xcp`` (same length) in place.

    Writes ``xhat_out`` and ``i0hat_out`` and leaves ``state`` at the value after the last
    sample, so consecutive calls on consecutive chunks reproduce one call on the whole array
    bit for bit (same operations in the same order).
    """
    for k in range(current.shape[0]):
        xh, ih = hpo_update(Ad, Bd, Cd, Dd, state, current[k], xcp[k])
        xhat_out[k] = xh
        i0hat_out[k] = ih


# ---------------------------------------------------------------------------------------------
# Plain scipy reference
# ---------------------------------------------------------------------------------------------
def reference_simulate(
    disc: DiscreteHPO,
    current: np.ndarray,
    xcp: np.ndarray,
    state0: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reference simulation with ``scipy.signal.dlsim`` on the same discrete system.

    Returns ``(xhat, i0hat, final_state)``.  Used by the tests to validate the numba kernel.
    """
    current = np.asarray(current, dtype=float)
    xcp = np.asarray(xcp, dtype=float)
    if current.shape != xcp.shape or current.ndim != 1:
        raise ValueError("current and xcp must be 1-D arrays of equal length")
    n_states = disc.Ad.shape[0]
    x0 = np.zeros(n_states) if state0 is None else np.asarray(state0, dtype=float)
    if current.size == 0:
        return np.empty(0), np.empty(0), x0.copy()
    import scipy.signal

    u = np.column_stack([current, xcp])
    _, y, x = scipy.signal.dlsim((disc.Ad, disc.Bd, disc.Cd, disc.Dd, disc.dt), u, x0=x0)
    # dlsim only returns states up to the last sample; advance once more for the final state.
    x_final = disc.Ad @ x[-1] + disc.Bd @ u[-1]
    return y[:, 0].copy(), y[:, 1].copy(), x_final


def sample_and_hold(signal: np.ndarray, every: int, phase: int = 0) -> np.ndarray:
    """Hold every ``every``-th sample of ``signal`` (starting at index ``phase``) until the next.

    Models x_CP arriving at a lower rate than fs (e.g. one value per 12 samples at 48 kHz):
    the HPO consumes a per-sample x_CP, so the caller holds the last available value.
    Samples before ``phase`` (no update available yet) hold ``signal[0]``.
    """
    x = np.asarray(signal, dtype=float)
    every = int(every)
    if every < 1:
        raise ValueError("every must be >= 1")
    idx = np.arange(x.size)
    src = phase + ((idx - phase) // every) * every
    src = np.clip(src, 0, max(x.size - 1, 0))
    return x[src]


# ---------------------------------------------------------------------------------------------
# Streaming observer
# ---------------------------------------------------------------------------------------------
class HybridPositionObserver:
    """Streaming discrete-time hybrid position observer (Fig 5.9, Eq 5.5–5.9).

    Parameters
    ----------
    gains : HPOGains
        Observer parameters (Table 5.3 / Eq 5.9).
    fs : float
        Sample rate of the current and of the (held) x_CP signal [Hz].
    method : {"tustin", "zoh"}
        Discretisation of the continuous observer (see :func:`discretize`).
    initial_position, initial_offset : float
        Passed to :meth:`reset`.

    Processing ``step`` on consecutive chunks is bit-identical to one call on the whole
    record; :meth:`update` is the per-sample version of the same kernel.
    """

    def __init__(
        self,
        gains: HPOGains,
        fs: float,
        method: str = "tustin",
        initial_position: float = 0.0,
        initial_offset: float = 0.0,
    ) -> None:
        self.gains = gains
        self.fs = float(fs)
        self.method = method
        self.discrete = discretize(gains, self.fs, method)
        self.state = np.zeros(self.discrete.Ad.shape[0])
        self.last_offset = float(initial_offset)  # most recent Î0 [A]
        self.reset(initial_position, initial_offset)

    @property
    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(Ad, Bd, Cd, Dd)`` for passing to :func:`hpo_update` from numba code."""
        d = self.discrete
        return d.Ad, d.Bd, d.Cd, d.Dd

    def reset(self, initial_position: float = 0.0, initial_offset: float = 0.0) -> None:
        """Put the observer in equilibrium at x̂ = ``initial_position`` [m] with Î0 =
        ``initial_offset`` [A] (see :func:`equilibrium_state`)."""
        # Write in place so that references held by callers (e.g. a twin) stay valid.
        self.state[:] = equilibrium_state(self.discrete, initial_position, initial_offset)
        self.last_offset = float(initial_offset)

    def step_full(self, current: np.ndarray, xcp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Process a chunk; returns ``(x̂, Î0)`` per sample and carries the state forward."""
        current = np.ascontiguousarray(current, dtype=np.float64)
        xcp = np.ascontiguousarray(xcp, dtype=np.float64)
        if current.ndim != 1 or current.shape != xcp.shape:
            raise ValueError(
                f"current and xcp must be 1-D of equal length, got {current.shape} and {xcp.shape}"
            )
        xhat = np.empty_like(current)
        i0hat = np.empty_like(current)
        if current.size:
            hpo_run(*self.matrices, self.state, current, xcp, xhat, i0hat)
            self.last_offset = float(i0hat[-1])
        return xhat, i0hat

    def step(self, current: np.ndarray, xcp: np.ndarray) -> np.ndarray:
        """Process a chunk of current [A] and held x_CP [m]; returns x̂ [m] per sample."""
        return self.step_full(current, xcp)[0]

    def update(self, current: float, xcp: float) -> float:
        """Process one sample; returns x̂ [m].  Î0 of that sample is in :attr:`last_offset`.

        Convenience for Python-level loops; inside numba code call :func:`hpo_update` with
        :attr:`matrices` and :attr:`state` instead (it is the same kernel).
        """
        xhat, i0hat = hpo_update(*self.matrices, self.state, float(current), float(xcp))
        self.last_offset = i0hat
        return xhat
