"""Real-time ripple impedance measurement (thesis Chapter 3, Eq 3.3-3.13).

The amplifier's boost converter superimposes a small ripple of known frequency
``fr`` (about 100 mV at 100 kHz) on the drive voltage.  The high-pass-filtered
ripple voltage ``Ur`` and current ``Ir`` are sampled at a rate ``fs`` chosen so
that the ripple folds onto exactly ``fs/ns`` (Eq 3.3-3.5).  Folded-bin Fourier
coefficients over ``np`` folded periods (Eq 3.6-3.7) then give the series R-C
model of the actuator, ``Z = R_e + 1/(j*omega_r*C_e)`` (Eq 3.10-3.13).

Phase reference and sign convention
-----------------------------------
Global sample ``k`` (counted from the first sample given to the extractor) is
time ``t_k = k/fs``.  The coefficients are projections on the *true* ripple
phase at the sample instants::

    A = 1/(2 np) * sum s[k] sin(omega_r t_k),   B = 1/(2 np) * sum s[k] cos(omega_r t_k)

summed over ``np`` whole folded periods.  For a channel
``s[k] = X cos(omega_r t_k + phi)`` this gives ``A = -(ns/4) X sin(phi)`` and
``B = (ns/4) X cos(phi)``, i.e. ``B - jA = (ns/4) X exp(j phi)`` is the channel's
phasor scaled by ``ns/4`` (the scale cancels in Eq 3.12-3.13).

``omega_r t_k = 2 pi k (nf/2 + 1/ns)`` for even ``nf`` (Eq 3.4) and
``2 pi k ((nf+1)/2 - 1/ns)`` for odd ``nf`` (Eq 3.5).  Dropping whole turns,
the weights are ``sin(2 pi j/ns)`` and ``cos(2 pi j/ns)`` with ``j = k mod ns``
for even ``nf``, exactly Eq 3.6-3.7, while for odd ``nf`` the alias is mirrored
and the sine weight changes sign.  Using Eq 3.6 verbatim for odd ``nf`` would
conjugate both phasors, i.e. turn the capacitance negative.

With ``V = Z I`` and ``Z = R_e - j/(omega_r C_e)``, the real and imaginary parts
of the phasor equation are Eq 3.11 and Eq 3.10.  The current leads the voltage
(by about 65 degrees for the thesis actuator), which makes
``A_I B_V - A_V B_I = -(ns/4)^2 X_I X_V sin(phi_I - phi_V)`` negative and
``C_e`` from Eq 3.12 positive.  ``omega_r = 2 pi fr`` is the true ripple
frequency: folding relabels the sample phase but the actuator sees ``fr``.

Windows are ``np`` folded periods ``[p ns, (p+1) ns)`` of the global sample
index, advanced by one folded period, so the estimate rate is ``fs/ns``.  The
thesis' Eq 3.6 (``z^(j - i ns)``, ``j = 1..ns``) groups the same whole periods
shifted by one sample; for a stationary ripple the two coincide.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pandas only for the tables: ≈ 0.3 s of every streaming job's start-up otherwise
    import pandas as pd

MECHANICAL_BANDWIDTH_HZ = 2500.0
"""Mechanical bandwidth of the clamped test bed (Section 3.3)."""


@dataclass(frozen=True)
class SamplingPlan:
    """Sampling of a ripple at ``fr`` [Hz] with ``ns`` samples per folded period.

    ``nf`` is the number of folds of ``fr`` around Nyquist and zero
    (Figure 3.7); ``n_periods`` is the thesis' ``np``, the number of folded
    periods per Fourier window.
    """

    fr: float
    ns: int
    nf: int
    n_periods: int

    def __post_init__(self) -> None:
        if not (math.isfinite(self.fr) and self.fr > 0):
            raise ValueError(f"ripple frequency fr must be positive and finite, got {self.fr!r}")
        # ns = 2 would put the folded ripple on Nyquist, where the sine term vanishes.
        for name, minimum in (("ns", 3), ("nf", 0), ("n_periods", 1)):
            value = getattr(self, name)
            if not isinstance(value, numbers.Integral) or value < minimum:
                raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")

    @property
    def mirrored(self) -> bool:
        """True for odd ``nf``: the ripple lands on ``-fs/ns``, i.e. phase-conjugated (Eq 3.5)."""
        return self.nf % 2 == 1

    @property
    def fs(self) -> float:
        """Sampling frequency [Hz]: Eq 3.4 for even ``nf``, Eq 3.5 for odd ``nf``."""
        if self.mirrored:
            return 2 * self.ns * self.fr / ((self.nf + 1) * self.ns - 2)
        return 2 * self.ns * self.fr / (self.nf * self.ns + 2)

    @property
    def fr_folded(self) -> float:
        """Folded ripple frequency ``fs/ns`` [Hz] (Eq 3.3)."""
        return self.fs / self.ns

    @property
    def passband(self) -> float:
        """Passband of the folded-bin Fourier transform ``fs/(ns np)`` [Hz] (Eq 3.8)."""
        return self.fs / self.block_len

    @property
    def bandwidth(self) -> float:
        """Approximate bandwidth of the impedance estimate ``fs/(ns np pi)`` [Hz] (Eq 3.9)."""
        return self.passband / math.pi

    @property
    def block_len(self) -> int:
        """Samples per Fourier window, ``ns np``."""
        return self.ns * self.n_periods


def _hz(value: float) -> str:
    return f"{value:.7g} Hz"


def _plans_near(fs: float, fr: float, ns: int, n_periods: int) -> list[SamplingPlan]:
    # floor(2 fr / fs(nf)) == nf for every valid plan (ns >= 3) and fs(nf) falls
    # monotonically with nf, so plans bracketing any fs lie within two folds.
    guess = math.floor(2 * fr / fs)
    return [SamplingPlan(fr, ns, nf, n_periods) for nf in range(max(0, guess - 2), guess + 3)]


def plan_from_fs(
    fs: float,
    fr: float,
    ns: int,
    n_periods: int,
    min_folded: float = MECHANICAL_BANDWIDTH_HZ,
    rtol: float = 1e-6,
) -> SamplingPlan:
    """Plan for sampling ``fr`` at the given ``fs`` [Hz] (Eq 3.3-3.5).

    Accepts ``fs`` if some integer ``nf`` satisfies Eq 3.4/3.5 within ``rtol``
    and the folded ripple ``fs/ns`` lies above the mechanical bandwidth
    ``min_folded`` (so the ripple cannot move the actuator, Section 3.5.1).
    Otherwise raises a one-line ``ValueError`` naming the problem and the
    nearest valid ``fs`` for this ``fr`` and ``ns``.
    """
    if not (math.isfinite(fs) and fs > 0):
        raise ValueError(f"sampling frequency fs must be positive and finite, got {fs!r}")
    if not min_folded >= 0:
        raise ValueError(f"min_folded must be >= 0, got {min_folded!r}")
    candidates = _plans_near(fs, fr, ns, n_periods)
    match = next((p for p in candidates if math.isclose(p.fs, fs, rel_tol=rtol)), None)
    if match is not None and match.fr_folded > min_folded:
        return match

    if min_folded > 0:
        # The slowest plan still above the mechanical bandwidth may be the nearest one.
        candidates += _plans_near(ns * min_folded, fr, ns, n_periods)
    valid = [p for p in candidates if p.fr_folded > min_folded]
    nearest = min(valid, key=lambda p: abs(p.fs - fs), default=None)
    if match is None:
        problem = f"fs = {_hz(fs)} does not fold fr = {_hz(fr)} onto fs/ns for ns = {ns}"
    else:
        problem = (
            f"folded ripple {_hz(match.fr_folded)} lies inside the mechanical bandwidth "
            f"{_hz(min_folded)}"
        )
    if nearest is None:
        hint = f"no valid fs exists because fr = {_hz(fr)} is not above {_hz(min_folded)}"
    else:
        hint = f"nearest valid fs = {_hz(nearest.fs)} (nf = {nearest.nf})"
    raise ValueError(f"{problem}; {hint}")


def plan_from_capture(capture, n_periods: int) -> SamplingPlan:
    """The plan an open :class:`~selfsense.io.capture.Capture` was sampled with, from its ``fs``
    and its ``fr_nominal``/``ns`` attributes, checked as :func:`plan_from_fs` checks it
    (Eq 3.3-3.5)."""
    return plan_from_fs(
        capture.fs,
        float(capture.attribute("fr_nominal")),
        int(capture.attribute("ns")),
        int(n_periods),
    )


def table_3_1(fr: float = 100e3) -> pd.DataFrame:
    """Table 3.1: sampling and folded ripple frequency for (ns, nf) pairs (Eq 3.3-3.5)."""
    import pandas as pd

    rows = [(4, 0), (4, 2), (4, 12), (12, 0), (12, 4)]
    plans = [SamplingPlan(fr, ns, nf, 1) for ns, nf in rows]
    return pd.DataFrame(
        {
            "ns": [p.ns for p in plans],
            "nf": [p.nf for p in plans],
            "fs [kHz]": [p.fs / 1e3 for p in plans],
            "fr_folded [kHz]": [p.fr_folded / 1e3 for p in plans],
        }
    )


def table_3_2(fs: float = 48e3, fr: float = 100e3, ns: int = 12) -> pd.DataFrame:
    """Table 3.2: passband (Eq 3.8) and bandwidth (Eq 3.9) against the number of periods np."""
    import pandas as pd

    plans = [plan_from_fs(fs, fr, ns, n) for n in (1, 2, 4, 8, 12, 16)]
    return pd.DataFrame(
        {
            "np": [p.n_periods for p in plans],
            "passband [kHz]": [p.passband / 1e3 for p in plans],
            "bandwidth [kHz]": [p.bandwidth / 1e3 for p in plans],
        }
    )


def impedance_from_coefficients(A_V, B_V, A_I, B_I, fr: float):
    """Effective capacitance [F] and resistance [Ohm] of the series R-C model.

    Eq 3.12 ``C_e = -(1/omega_r) (A_I^2 + B_I^2) / (A_I B_V - A_V B_I)`` and
    Eq 3.13 ``R_e = (A_I A_V + B_V B_I) / (A_I^2 + B_I^2)`` with
    ``omega_r = 2 pi fr`` the true (unfolded) ripple frequency.  Windows
    without ripple current give nan/inf.
    """
    omega_r = 2 * math.pi * fr
    current_power = A_I * A_I + B_I * B_I
    with np.errstate(divide="ignore", invalid="ignore"):
        C_e = -current_power / (omega_r * (A_I * B_V - A_V * B_I))
        R_e = (A_I * A_V + B_V * B_I) / current_power
    return C_e, R_e


@dataclass(frozen=True, eq=False)
class RippleBlocks:
    """Impedance estimates, one per Fourier window.

    ``sample_index`` is the global index of each window's last sample;
    ``A_*``/``B_*`` are the Eq 3.6/3.7 coefficients (scaled phasor
    ``B - jA``, see the module docstring).
    """

    sample_index: np.ndarray
    C_e: np.ndarray
    R_e: np.ndarray
    A_V: np.ndarray
    B_V: np.ndarray
    A_I: np.ndarray
    B_I: np.ndarray

    def __len__(self) -> int:
        return len(self.sample_index)

    @classmethod
    def concatenate(cls, parts: list[RippleBlocks]) -> RippleBlocks:
        """Join consecutive outputs of :meth:`RippleExtractor.process`."""
        names = ("sample_index", "C_e", "R_e", "A_V", "B_V", "A_I", "B_I")
        if not parts:
            return cls(np.empty(0, np.int64), *(np.empty(0) for _ in names[1:]))
        return cls(*(np.concatenate([getattr(p, n) for p in parts]) for n in names))


def _fold_weights(plan: SamplingPlan) -> tuple[np.ndarray, np.ndarray]:
    # sin/cos of the true ripple phase omega_r*k/fs at k = 0..ns-1; whole turns
    # drop out, leaving +-2*pi*k/ns with the sign flipped by a mirrored fold.
    k = np.arange(plan.ns)
    phase = 2 * np.pi * (-k % plan.ns if plan.mirrored else k) / plan.ns
    return np.sin(phase), np.cos(phase)


def _moving_sum(x: np.ndarray, width: int) -> np.ndarray:
    # Shift-and-add in a fixed oldest-to-newest order: every window is summed
    # identically however the stream was chunked, and unlike a running cumsum
    # no rounding error accumulates over long streams.
    n = max(x.shape[1] - width + 1, 0)
    total = x[:, :n].copy()
    for shift in range(1, width):
        total += x[:, shift : shift + n]
    return total


class PeriodWindows:
    """Streaming weighted sums over windows of ``np`` folded periods (hop: one period).

    Each channel's samples are cut into folded periods ``[p ns, (p+1) ns)`` of the global sample
    index, reduced per period with each weight row, and summed over the last ``np`` periods.
    Leftover samples and the last ``np - 1`` per-period sums carry over, so chunking never
    changes the result and memory stays bounded. The ripple extractor uses sin/cos weights
    (Eq 3.6-3.7); window means of slow channels use a row of ones, so they line up exactly with
    the impedance estimates.
    """

    def __init__(self, ns: int, n_periods: int, weights: np.ndarray, n_channels: int) -> None:
        self.ns, self.n_periods = ns, n_periods
        self._weights = np.atleast_2d(weights)
        self._tail = np.empty((n_channels, 0))
        self._period_sums = np.empty((n_channels * len(self._weights), 0))
        self._periods_done = 0

    def process(self, *chunks) -> tuple[np.ndarray, np.ndarray]:
        """Consume equal-length 1-D chunks; return (last sample index, window sums) of the
        windows completed, sums ordered channel-major then weight."""
        x = np.asarray(chunks, dtype=np.float64)
        if x.ndim != 2 or x.shape[0] != self._tail.shape[0]:
            raise ValueError(
                f"expected {self._tail.shape[0]} equally long 1-D chunks, got shape {x.shape}"
            )
        ns = self.ns
        # Prepending the leftover keeps every folded period aligned to global
        # multiples of ns, which is what references the phase to sample 0.
        x = np.concatenate((self._tail, x), axis=1)
        n_new = x.shape[1] // ns
        cut = n_new * ns
        self._tail = x[:, cut:].copy()
        periods = x[:, :cut].reshape(x.shape[0], n_new, ns)
        # einsum reduces each period row with the same fixed-length kernel,
        # so a period's sum does not depend on which chunk carried it.
        new_sums = np.stack([np.einsum("ij,j->i", ch, w) for ch in periods for w in self._weights])
        sums = np.concatenate(
            (self._period_sums, new_sums.reshape(len(self._period_sums), n_new)), axis=1
        )
        first_period = self._periods_done - self._period_sums.shape[1]
        self._periods_done += n_new
        keep = min(sums.shape[1], self.n_periods - 1)
        self._period_sums = sums[:, sums.shape[1] - keep :].copy()
        window = _moving_sum(sums, self.n_periods)
        last_period = first_period + self.n_periods - 1 + np.arange(window.shape[1], dtype=np.int64)
        return (last_period + 1) * ns - 1, window


class RippleExtractor:
    """Streaming impedance extraction (Eq 3.6, 3.7, 3.12, 3.13).

    Feed the sampled ripple voltage and current in chunks of any size; each
    call returns the windows of ``np`` folded periods completed by that chunk.
    """

    def __init__(self, plan: SamplingPlan) -> None:
        self.plan = plan
        self._windows = PeriodWindows(plan.ns, plan.n_periods, np.stack(_fold_weights(plan)), 2)

    def process(self, ur_chunk, ir_chunk) -> RippleBlocks:
        """Consume equal-length chunks of ripple voltage [V] and current [A]."""
        ur = np.asarray(ur_chunk, dtype=np.float64)
        ir = np.asarray(ir_chunk, dtype=np.float64)
        if ur.ndim != 1 or ur.shape != ir.shape:
            raise ValueError(
                "ur and ir chunks must be 1-D and equally long, "
                f"got shapes {ur.shape} and {ir.shape}"
            )
        index, sums = self._windows.process(ur, ir)
        A_V, B_V, A_I, B_I = sums / (2 * self.plan.n_periods)
        C_e, R_e = impedance_from_coefficients(A_V, B_V, A_I, B_I, self.plan.fr)
        return RippleBlocks(index, C_e, R_e, A_V, B_V, A_I, B_I)


class WindowMeans:
    """Means of other channels over exactly the windows of a :class:`RippleExtractor`."""

    def __init__(self, plan: SamplingPlan, n_channels: int) -> None:
        self._windows = PeriodWindows(plan.ns, plan.n_periods, np.ones((1, plan.ns)), n_channels)
        self._size = plan.block_len

    def process(self, *chunks) -> tuple[np.ndarray, np.ndarray]:
        index, sums = self._windows.process(*chunks)
        return index, sums / self._size


def extract_impedance(ur, ir, plan: SamplingPlan) -> RippleBlocks:
    """Impedance estimates for a whole capture (sample 0 is the phase reference)."""
    return RippleExtractor(plan).process(ur, ir)


def impedance_series(chunks, plan: SamplingPlan, fs: float, companions=("U", "x_laser")):
    """Stream a capture's chunks into C_e, R_e and window means of companion channels.

    ``chunks`` yields (first sample index, {channel: array}) as
    :meth:`selfsense.io.capture.Capture.iter_chunks` does, with ``Ur``, ``Ir`` and the companions.
    If ``I`` is a companion, the uncorrected charge ``q = ∫ I dt`` is added too (its window
    mean), carried across chunks. Yields one dict of equal-length arrays per chunk, keyed
    ``time`` (centre of each window [s]), ``C_e``, ``R_e``, the Fourier coefficients and the
    companions.
    """
    extractor = RippleExtractor(plan)
    derived = ("q",) if "I" in companions else ()
    means = WindowMeans(plan, len(companions) + len(derived))
    charge = 0.0
    for _, data in chunks:
        blocks = extractor.process(data["Ur"], data["Ir"])
        extra = []
        if derived:
            q = charge + np.cumsum(data["I"]) / fs
            charge = float(q[-1]) if q.size else charge
            extra.append(q)
        _, avg = means.process(*(data[c] for c in companions), *extra)
        out = {
            "time": (blocks.sample_index - (plan.block_len - 1) / 2) / fs,
            "C_e": blocks.C_e,
            "R_e": blocks.R_e,
            "A_V": blocks.A_V,
            "B_V": blocks.B_V,
            "A_I": blocks.A_I,
            "B_I": blocks.B_I,
        }
        out |= dict(zip(companions + derived, avg))
        yield out


#: units of the series :func:`impedance_series` yields (for writing them)
SERIES_UNITS = {
    "time": "s",
    "C_e": "F",
    "R_e": "ohm",
    "A_V": "V",
    "B_V": "V",
    "A_I": "A",
    "B_I": "A",
    "U": "V",
    "x_laser": "m",
    "I": "A",
    "q": "C",
}
