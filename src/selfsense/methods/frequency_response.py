"""Frequency response of G(s) = x(s)/q(s) from a stepped-sine sweep (thesis Fig 5.3, Eq 5.2).

Eq 5.1 with F = 0 in the Laplace domain gives Eq 5.2,

    G(s) = x(s)/q(s) = x(s)·s/I(s) = 1 / ((C_P/α)(m s² + b s + k) + α),

whose poles are the stack's resonance with its charge held (stiffened from k to k + α²/C_P).
The measured response comes from a sweep of sine segments (the run of role
frequency_response.sweep): each segment's position and current are reduced to one complex
amplitude each by a lock-in over whole periods after the settling cycles, and G = X/Q.

Choices, with the reasons:

- The lock-in is a single-bin DFT over whole periods weighted by a periodic Hann window. Over
  whole periods the window still rejects DC (laser zero, current-probe offset) and every harmonic
  exactly, and its sidelobes fall fast enough to reject the ripple current that folds onto
  fs/ns (4 kHz on the stack's DAQ, ≈ 0.2 A: more than the drive current near the resonance) and
  slow drifts (laser, creep), which a rectangular window leaks at 1/(π·cycles).
- q is the running sum h·ΣI, the integral every stage takes of the measured current
  (:func:`selfsense.methods.ripple.impedance_series`); its phasor is exactly I·h/(1 − e^(−jωh)),
  which tends to Eq 5.2's I/(jω) for ωh ≪ 1 but at 48 kHz already differs by 13.5° at 3.6 kHz.
- The model's C_P is the clamped capacitance at the sweep's operating point,
  C_P = C_P0 + ΔCx·x̄ (Eq 4.4–4.6), x̄ the mean laser position during the sweep above its value
  during the leading hold at 0 V: the sweep runs about a DC bias, and Eq 5.2's C_P is the
  small-signal (incremental) one there.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import control
import numpy as np
import pandas as pd
import scipy.optimize
import scipy.signal

#: Fig 5.3 / Chapter 5 text: "the electromechanical resonance frequency (700 Hz)"
THESIS_RESONANCE_HZ = 700.0
#: the capture channels a sweep is measured from
CHANNELS = ("x_laser", "I")
#: fewest whole periods a point's window may hold: the Hann window over fewer does not reject DC
MIN_CYCLES = 2


@dataclass(frozen=True)
class SweepPoint:
    """One frequency of the sweep: the samples [start, stop) analysed, whole periods of f."""

    frequency: float  # [Hz]
    start: int
    stop: int


@dataclass(frozen=True)
class SweepPlan:
    rest: tuple[int, int]  # samples of the leading hold at 0 V: the laser's zero
    points: tuple[SweepPoint, ...]


def sweep_plan(segments: Sequence, fs: float, settle_s: float) -> SweepPlan:
    """Where each point of a stepped-sine sweep lies in its capture.

    ``segments`` are the drive's segments in order (objects with ``duration`` [s], ``frequency``
    [Hz] and ``hi``, as :func:`selfsense.methods.drive.drive_from_protocol` builds them); the first
    must be a hold at 0 V. A sine segment's first ⌈settle_s·f⌉ periods are discarded and
    the whole periods after them analysed. Segments with fewer than :data:`MIN_CYCLES` periods
    left are transitions (the half-cycle rises between drive levels), not points.
    """
    first = segments[0] if segments else None
    if first is None or first.frequency > 0 or first.hi != 0:
        raise ValueError(
            "a sweep must start with a hold at 0 V: the laser's zero for C_P's operating point"
        )
    points, t = [], 0.0
    for seg in segments:
        f = seg.frequency
        if f > 0:
            # durations in the catalogue are whole periods; the tolerance absorbs float rounding
            settle = math.ceil(settle_s * f - 1e-9)
            cycles = math.floor(seg.duration * f + 1e-6) - settle
            if cycles >= MIN_CYCLES:
                start = round((t + settle / f) * fs)
                points.append(SweepPoint(float(f), start, start + round(cycles * fs / f)))
        t += seg.duration
    return SweepPlan((0, round(first.duration * fs)), tuple(points))


def phasor(y: np.ndarray, frequency: float, fs: float) -> complex:
    """Complex amplitude Y of y ≈ Re(Y e^(jωt)) + …, t from the window's first sample.

    A Hann-weighted single-bin DFT at ``frequency``; ``y`` should span whole periods.
    """
    y = np.asarray(y, dtype=float)
    w = scipy.signal.windows.hann(len(y), sym=False)
    t = np.arange(len(y)) / fs
    return complex(2.0 * np.sum(w * y * np.exp(-2j * np.pi * frequency * t)) / np.sum(w))


def charge_phasor(current: complex, frequency: float, fs: float) -> complex:
    """Phasor of q = h·ΣI (the pipeline's integral of the current) from the current's phasor."""
    h = 1.0 / fs
    return current * h / (1.0 - np.exp(-2j * np.pi * frequency * h))


@dataclass(frozen=True)
class Measured:
    """The sweep's measured response, one entry per point (SI units)."""

    frequency: np.ndarray  # [Hz]
    G: np.ndarray  # x/q [m/C], complex
    x_amplitude: np.ndarray  # [m]
    I_amplitude: np.ndarray  # [A]
    position: np.ndarray  # mean position above the rest position [m]

    @property
    def operating_position(self) -> float:
        """x̄: the sweep's mean position above its rest position [m]."""
        return float(np.mean(self.position))


def measure(
    rest_x: np.ndarray, points: Iterable[tuple[SweepPoint, Mapping[str, np.ndarray]]], fs: float
) -> Measured:
    """G(jω) = X/Q per point (Eq 5.2) from ``x_laser`` [m] and ``I`` [A] over each point's window.

    ``points`` yields (point, {"x_laser": …, "I": …}) — one window at a time, so a caller can
    stream them from the capture; ``rest_x`` is the laser during the leading hold at 0 V.
    """
    x_rest = float(np.nanmean(rest_x))
    rows = []
    for point, data in points:
        f = point.frequency
        X, I = phasor(data["x_laser"], f, fs), phasor(data["I"], f, fs)
        rows.append(
            (
                f,
                X / charge_phasor(I, f, fs),
                abs(X),
                abs(I),
                float(np.mean(data["x_laser"])) - x_rest,
            )
        )
    f, G, xa, ia, pos = (np.array(c) for c in zip(*rows))
    return Measured(f.astype(float), G.astype(complex), xa, ia, pos)


def transfer_function(
    model: Mapping[str, float], position: float = 0.0
) -> control.TransferFunction:
    """Eq 5.2, G(s) = 1/((C_P/α)(m s² + b s + k) + α), with C_P = C_P0 + ΔCx·position (Eq 4.4).

    ``model`` holds C_P0 [F], dC_x [F/m], alpha [N/V], k [N/m], m [kg], b [N s/m] (as
    results/<dataset>/ch4/model.json does).
    """
    c = (model["C_P0"] + model["dC_x"] * position) / model["alpha"]
    return control.tf([1.0], [c * model["m"], c * model["b"], c * model["k"] + model["alpha"]])


def evaluate(G: control.TransferFunction, frequency: np.ndarray) -> np.ndarray:
    """G(j2πf), complex, on the grid ``frequency`` [Hz]."""
    f = np.asarray(frequency, dtype=float)
    return np.asarray(G(2j * np.pi * f), dtype=complex).reshape(f.shape)


def model_peak(G: control.TransferFunction, f_lo: float, f_hi: float) -> tuple[float, float]:
    """Frequency [Hz] and value of the largest |G(j2πf)| in [f_lo, f_hi] (Eq 5.2's resonance)."""
    grid = np.geomspace(f_lo, f_hi, 2000)
    i = int(np.argmax(np.abs(evaluate(G, grid))))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    best = scipy.optimize.minimize_scalar(
        lambda f: -abs(evaluate(G, np.array([f]))[0]),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-6 * grid[i]},
    )
    return float(best.x), float(-best.fun)


def measured_peak(frequency: np.ndarray, magnitude: np.ndarray) -> tuple[float, float]:
    """Resonance of a stepped sweep: the parabola in (f, ln|G|) through the largest point and its
    neighbours (exact for a Gaussian peak, close for a resonance sampled a few times within its
    half-power width). NaN when the largest point is the sweep's first or last: not bracketed."""
    order = np.argsort(frequency)
    f, mag = np.asarray(frequency, float)[order], np.asarray(magnitude, float)[order]
    i = int(np.argmax(mag))
    if i == 0 or i == len(f) - 1:
        return math.nan, math.nan
    c2, c1, c0 = np.polyfit(f[i - 1 : i + 2], np.log(mag[i - 1 : i + 2]), 2)
    f_peak = -c1 / (2 * c2)
    return float(f_peak), float(np.exp(c0 + c1 * f_peak + c2 * f_peak**2))


def response_table(measured: Measured, G: control.TransferFunction) -> pd.DataFrame:
    """Per frequency: measured and model |G| and phase [deg], and their differences.

    G in m/C is numerically G in µm/µC, the unit the table gives.
    """
    model = evaluate(G, measured.frequency)
    ratio = measured.G / model
    return pd.DataFrame(
        {
            "frequency [Hz]": measured.frequency,
            "measured |G| [µm/µC]": np.abs(measured.G),
            "measured phase [deg]": np.degrees(np.angle(measured.G)),
            "model |G| [µm/µC]": np.abs(model),
            "model phase [deg]": np.degrees(np.angle(model)),
            "magnitude error [%]": 100 * (np.abs(ratio) - 1),
            "phase error [deg]": np.degrees(np.angle(ratio)),
            "x amplitude [µm]": measured.x_amplitude * 1e6,
            "I amplitude [mA]": measured.I_amplitude * 1e3,
            "mean position [µm]": measured.position * 1e6,
        }
    )


def resonance_table(measured: Measured, G: control.TransferFunction, m: float) -> pd.DataFrame:
    """Resonance of the measured response and of the model ``G`` (Eq 5.2, built with the moving
    mass ``m`` [kg], an input), beside the thesis's ≈ 700 Hz; and the mass that would put the
    model's peak on the measured one, m·(f_model/f_measured)² (Eq 5.2's poles go as 1/√m)."""
    f_meas, g_meas = measured_peak(measured.frequency, np.abs(measured.G))
    f_model, g_model = model_peak(
        G, float(measured.frequency.min()), float(measured.frequency.max())
    )
    return pd.DataFrame(
        {
            "response": ["measured", "model"],
            "peak frequency [Hz]": [f_meas, f_model],
            "peak |G| [µm/µC]": [g_meas, g_model],
            "moving mass [kg]": [m * (f_model / f_meas) ** 2, m],
            "thesis Fig 5.3 [Hz]": [THESIS_RESONANCE_HZ, THESIS_RESONANCE_HZ],
        }
    )


def measure_sweep(capture, segments: Sequence, settle_s: float) -> Measured:
    """:func:`measure` over an open stepped-sine capture whose drive has ``segments``, one window
    at a time."""
    plan = sweep_plan(segments, capture.fs, settle_s)
    rest = capture.read(["x_laser"], *plan.rest)["x_laser"]
    return measure(
        rest, ((p, capture.read(CHANNELS, p.start, p.stop)) for p in plan.points), capture.fs
    )
