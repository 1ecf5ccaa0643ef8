"""The few linear-system operations the twin and the observer need, with scipy.signal's
arithmetic but without importing it.

Importing scipy.signal costs ≈ 0.4 s, paid by every job that simulates a capture or runs the
observer (≈ 220 jobs of the thesis campaign) for four functions: Tustin's discretisation of a
state space (the stack's mechanics, Eq 1.4; the HPO, Eq 5.5–5.9), the analogue 2nd-order
Butterworth high-pass of the ripple channels and its bilinear map, and the filter itself. Each
function here does the operations of its scipy.signal counterpart (1.16) in the same order, so
captures and estimates are unchanged bit for bit; the tests hold each to it.
"""

from __future__ import annotations

import math

import numba
import numpy as np


def tustin(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, dt: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(Ad, Bd, Cd, Dd) of x' = Ax + Bu, y = Cx + Du sampled at dt by the bilinear transform
    (s = 2/dt·(z − 1)/(z + 1)), as ``scipy.signal.cont2discrete(..., method="bilinear")``."""
    eye = np.eye(A.shape[0])
    ima = eye - 0.5 * dt * A
    Ad = np.linalg.solve(ima, eye + (1.0 - 0.5) * dt * A)
    Bd = np.linalg.solve(ima, dt * B)
    Cd = np.linalg.solve(ima.transpose(), C.transpose()).transpose()
    return Ad, Bd, Cd, D + 0.5 * np.dot(C, Bd)


#: the quality factor of a 2nd-order Butterworth filter, 1/√2
BUTTERWORTH_Q = 0.7071067811865476


def highpass2(cutoff_hz: float, q: float = BUTTERWORTH_Q) -> tuple[np.ndarray, np.ndarray]:
    """Analogue 2nd-order high-pass s²/(s² + (ω_c/Q) s + ω_c²), ω_c = 2π·cutoff, |H(jω_c)| = Q:
    for Q = 1/√2 the Butterworth whose coefficients ``scipy.signal.butter(2, ω_c, "high",
    analog=True)`` returns (a Sallen-Key's Q is set by its components' ratios)."""
    wc = 2 * np.pi * cutoff_hz
    # ω_c/Q as √2·ω_c·(Q_B/Q): the Butterworth's coefficients to the last bit
    return np.array([1.0, 0.0, 0.0]), np.array(
        [1.0, math.sqrt(2) * wc * (BUTTERWORTH_Q / q), wc * wc]
    )


def bilinear(b: np.ndarray, a: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Digital (b, a) of the analogue transfer function b(s)/a(s) at fs by Tustin's map, normalised
    to a[0] = 1, as ``scipy.signal.bilinear``."""
    fac = np.sqrt(fs * 2)  # split between numerator and denominator against overflow
    zp1 = np.polynomial.Polynomial((+1, 1)) / fac
    zm1 = np.polynomial.Polynomial((-1, 1)) * fac
    N = max(len(a), len(b)) - 1
    numerator = sum(b_ * zp1 ** (N - q) * zm1**q for q, b_ in enumerate(b[::-1]))
    denominator = sum(a_ * zp1 ** (N - p) * zm1**p for p, a_ in enumerate(a[::-1]))
    num, den = numerator.coef[::-1], np.trim_zeros(denominator.coef[::-1], "f")
    return num / den[0], den / den[0]


@numba.njit(cache=True)
def filter_step(x, b, a, z):
    """One sample of the transposed direct form II with a[0] = 1 and len(b) = len(a) ≥ 2, state z
    updated in place, as ``scipy.signal.lfilter`` computes it."""
    y = z[0] + b[0] * x
    last = b.size - 1
    for k in range(last - 1):
        z[k] = z[k + 1] + x * b[k + 1] - y * a[k + 1]
    z[last - 1] = x * b[last] - y * a[last]
    return y


@numba.njit(cache=True)
def filter_run(b, a, x, z, y):
    """:func:`filter_step` over x into y, carrying z (``lfilter(b, a, x, zi=z)``)."""
    for n in range(x.size):
        y[n] = filter_step(x[n], b, a, z)
