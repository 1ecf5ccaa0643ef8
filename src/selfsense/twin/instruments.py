"""The bench's instruments: ripple source and its high-pass filters, probes, sensors, noise.

Everything is evaluated at the DAQ's sample instants. The 100 kHz ripple in particular is
computed as cos(φ(t_k)) at t_k = k/fs, so it aliases onto fs/ns exactly as on the bench; it is
never simulated at a higher rate and decimated.

Two of the signals that depend on time alone, the ripple's carrier and the high-pass's response at
the ripple's frequency, are made per sample by numba loops (:func:`ripple_carrier`,
:func:`analogue_response`) that do numpy's operations in numpy's order, so that they are numpy's
values bit for bit: the phase's running sum in order, glibc's cos and sin (what np.exp of an
imaginary argument calls), complex products in which one term of each part is an exact zero (so
numpy's fused SIMD product rounds as the plain one does) and numpy's complex division (Smith's, with
its reciprocal scale). Each keeps its numpy expression as the reference (``compiled=False``), which
the tests hold it to with ``assert_array_equal``. The two cost half of numpy's, whose every
operation walked the chunk's arrays again. The slow drifts stay np.interp (a loop was no faster),
the noise numpy's generator.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from selfsense.methods.lti import BUTTERWORTH_Q, bilinear, filter_run, highpass2
from selfsense.twin.params import RippleParams


class SlowProcess:
    """A smooth random signal of given peak and bandwidth: a sum of slow sinusoids.

    It is a function of absolute time, so chunked generation needs no state. The sinusoids are
    evaluated on a grid of absolute times POINTS_PER_CYCLE to the fastest one's period and
    interpolated linearly (relative error ≤ (2π/POINTS_PER_CYCLE)²/8 ≈ 1e-4 of the peak): summing
    them at every 48 kHz sample was a third of the time to simulate a capture.
    """

    POINTS_PER_CYCLE = 200

    def __init__(self, rng: np.random.Generator, peak: float, bandwidth: float, terms: int = 6):
        self.freqs = bandwidth * rng.uniform(0.05, 1.0, terms)
        self.phases = rng.uniform(0, 2 * np.pi, terms)
        self.amps = rng.uniform(0.5, 1.0, terms)
        self.amps *= peak / self.amps.sum() if terms else 0.0
        self.step = 1.0 / (self.POINTS_PER_CYCLE * self.freqs.max()) if terms else np.inf

    def exact(self, t: np.ndarray) -> np.ndarray:
        """The sum of sinusoids itself at times t."""
        return np.sin(2 * np.pi * np.asarray(t)[:, None] * self.freqs + self.phases) @ self.amps

    def __call__(self, t: np.ndarray) -> np.ndarray:
        if not len(t) or not np.isfinite(self.step):
            return self.exact(t)
        grid = (
            np.arange(np.floor(t.min() / self.step), np.ceil(t.max() / self.step) + 1) * self.step
        )
        return np.interp(t, grid, self.exact(grid))


class Amplifier:
    """The power amplifier's small-signal response from command to stack: first order, its corner
    set by its gain ``gain`` at the folded ripple frequency fs/ns; 1 is the ideal amplifier, which
    passes the command whole.

    The bilinear map is pre-warped at fs/ns, so that the discrete filter's gain there is ``gain``
    exactly (the analogue corner is f_fold·g/√(1 − g²)). Filter state carries across chunks.
    """

    def __init__(self, gain: float, fs: float, ns: int | None):
        self.ideal = gain >= 1.0
        self.b, self.a = np.array([1.0, 0.0]), np.array([1.0, 0.0])
        self.z = np.zeros(1)
        if self.ideal:
            return
        if not ns:
            raise ValueError("an amplifier gain at the folded ripple needs the DAQ's ns")
        warped = 2 * fs * math.tan(math.pi / ns)  # the analogue ω that fs/ns maps to
        wc = warped * gain / math.sqrt(1.0 - gain * gain)
        self.b, self.a = bilinear(np.array([wc]), np.array([1.0, wc]), fs)

    def __call__(self, command: np.ndarray) -> np.ndarray:
        """The voltage at the stack for ``command`` (the same array when ideal)."""
        if self.ideal:
            return command
        out = np.empty(len(command))
        filter_run(self.b, self.a, np.ascontiguousarray(command, dtype=float), self.z, out)
        return out

    def coefficients(self) -> np.ndarray:
        """[ideal, b0, b1, a0, a1], then five zeros (not the rate-limited stage of
        :meth:`.variants.PowerAmplifier.coefficients`): the compiled closed loop's copy."""
        return np.array([float(self.ideal), *self.b, *self.a, 0.0, 0.0, 0.0, 0.0, 0.0])


class HighPass:
    """The 2nd-order Sallen-Key high-pass on a ripple channel (a Butterworth unless its Q says
    otherwise).

    The ripple tone passes through the analogue response at its instantaneous frequency; the
    low-frequency drive that leaks in is filtered by the bilinear discretisation, accurate far
    below fs/2 where the drive lives. Filter state carries across chunks.
    """

    def __init__(self, cutoff_hz: float, fs: float, q: float = BUTTERWORTH_Q):
        self.b_analog, self.a_analog = highpass2(cutoff_hz, q)
        self.b, self.a = bilinear(self.b_analog, self.a_analog, fs)
        self.zi = np.zeros(len(self.a) - 1)

    def response(self, f_hz: np.ndarray, compiled: bool = True) -> np.ndarray:
        """H(j2πf) of the analogue filter (scipy.signal.freqs without its per-call overhead,
        which the closed-loop twin paid for every 12-sample block); ``compiled``: by
        :func:`analogue_response`, else in numpy, the reference."""
        f_hz = np.asarray(f_hz)
        if not compiled or f_hz.ndim != 1 or f_hz.dtype != np.float64:
            s = 2j * np.pi * f_hz
            return np.polyval(self.b_analog, s) / np.polyval(self.a_analog, s)
        out = np.empty(len(f_hz), dtype=complex)
        analogue_response(
            np.ascontiguousarray(f_hz),
            np.asarray(self.b_analog, dtype=float),
            np.asarray(self.a_analog, dtype=float),
            out,
        )
        return out

    def leak(self, x: np.ndarray) -> np.ndarray:
        y = np.empty(len(x))
        filter_run(self.b, self.a, np.ascontiguousarray(x, dtype=float), self.zi, y)
        return y


def resolve(values: np.ndarray, resolution: float) -> np.ndarray:
    """What an instrument of the given resolution records: its input rounded to multiples of it
    (:class:`.params.InstrumentParams`; 0: recorded as it is)."""
    return resolution * np.rint(values / resolution) if resolution else values


def effective_resistance(C_e: np.ndarray, rp: RippleParams) -> np.ndarray:
    """R_e of the series R–C at the ripple (Fig 3.14): falls as C_e rises, φ = phase_deg at
    C_ref."""
    R_ref = 1.0 / (2 * np.pi * rp.f_nominal * rp.C_ref * np.tan(np.radians(rp.phase_deg)))
    return R_ref + rp.R_slope * (C_e - rp.C_ref)


def small_signal(
    C_P: np.ndarray, U_H: np.ndarray, rp: RippleParams
) -> tuple[np.ndarray, np.ndarray]:
    """The series C_e and R_e the ripple sees (Eq 3.12's quantities): the clamped C_P plus the
    domain state's share, dC_H·U_H, and :func:`effective_resistance` of that C_e plus dR_H·U_H
    (:class:`.params.RippleParams`)."""
    C_e = C_P + rp.dC_H * U_H
    return C_e, effective_resistance(C_e, rp) + rp.dR_H * U_H


class RippleSource:
    """The boost converter's ripple with a slowly wandering frequency; phase carries across
    chunks."""

    def __init__(self, rp: RippleParams, fs: float, rng: np.random.Generator):
        self.rp = rp
        self.fs = fs
        self.wander = SlowProcess(rng, rp.wander, rp.wander_bandwidth)
        self.phase = rng.uniform(0, 2 * np.pi)

    def carrier(self, t: np.ndarray, compiled: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Ripple frequency [Hz] and complex ripple voltage at times t; the phase carries from
        one call to the next, so t must follow the previous call's. ``compiled``: by
        :func:`ripple_carrier`, else in numpy, the reference."""
        wander = self.wander(t)
        if not compiled or not len(t):
            f_r = self.rp.f_nominal + wander
            phi = self.phase + 2 * np.pi * np.cumsum(f_r) / self.fs - 2 * np.pi * f_r / self.fs
            if len(t):
                self.phase = float((phi[-1] + 2 * np.pi * f_r[-1] / self.fs) % (2 * np.pi))
            return f_r, self.rp.amplitude * np.exp(1j * phi)
        f_r, u = np.empty(len(t)), np.empty(len(t), dtype=complex)
        last = ripple_carrier(
            wander, self.rp.f_nominal, self.phase, self.fs, self.rp.amplitude, f_r, u
        )
        self.phase = float((np.float64(last) + 2 * np.pi * f_r[-1] / self.fs) % (2 * np.pi))
        return f_r, u

    @staticmethod
    def current(f_r: np.ndarray, u: np.ndarray, C_e: np.ndarray, R_e: np.ndarray) -> np.ndarray:
        """Complex ripple current of voltage u through the actuator's series R_e–C_e
        (R_e from :func:`effective_resistance`, which the caller also records)."""
        admittance = 1.0 / (R_e + 1.0 / (1j * 2 * np.pi * f_r * C_e))
        return u * admittance


@numba.njit(cache=True)
def ripple_carrier(wander, f_nominal, phase, fs, amplitude, f_r, u):
    """RippleSource.carrier's numpy operations per sample into f_r and u; returns the last sample's
    phase. np.cumsum adds in order, np.exp(1j·φ) is glibc's cexp of (±0, φ), that is (cos φ,
    sin φ), and the amplitude's product with it has a zero imaginary factor (numpy's complex
    product written out, which with a zero part is exact however numpy fuses it)."""
    two_pi = 2 * np.pi
    total = 0.0
    phi = phase
    for k in range(wander.size):
        f = f_nominal + wander[k]
        total = f if k == 0 else total + f
        phi = phase + two_pi * total / fs - two_pi * f / fs
        c, s = math.cos(phi), math.sin(phi)
        f_r[k] = f
        u[k] = complex(amplitude * c - 0.0 * s, amplitude * s + 0.0 * c)
    return phi


@numba.njit(cache=True)
def _polyval(p, sr, si):
    """np.polyval(p, s) at one s = sr + j·si, real coefficients: y = y·s + p_k from y = 0, with
    numpy's complex product and sum (a real p_k is p_k + 0j)."""
    yr, yi = 0.0, 0.0
    for k in range(p.size):
        yr, yi = (yr * sr - yi * si) + p[k], (yr * si + yi * sr) + 0.0
    return yr, yi


@numba.njit(cache=True)
def analogue_response(f_hz, b, a, out):
    """HighPass.response's numpy operations per sample into out: s = (2j·π)·f as numpy makes it,
    numerator and denominator by Horner (:func:`_polyval`: s has a zero real part, so in each part
    of a product one of its two terms is an exact zero, and numpy's fused multiply-add rounds once
    where the plain product does) and numpy's complex division (Smith's, with its reciprocal
    scale)."""
    wr, wi = 0.0, 2.0 * np.pi  # Python's 2j * np.pi
    for k in range(f_hz.size):
        f = f_hz[k]
        sr, si = wr * f - wi * 0.0, wr * 0.0 + wi * f
        nr, ni = _polyval(b, sr, si)
        dr, di = _polyval(a, sr, si)
        if abs(dr) >= abs(di):
            if dr == 0.0 and di == 0.0:
                out[k] = complex(nr / abs(dr), ni / abs(dr))
                continue
            rat = di / dr
            scl = 1.0 / (dr + di * rat)
            out[k] = complex((nr + ni * rat) * scl, (ni - nr * rat) * scl)
        else:
            rat = dr / di
            scl = 1.0 / (di + dr * rat)
            out[k] = complex((nr * rat + ni) * scl, (ni * rat - nr) * scl)
