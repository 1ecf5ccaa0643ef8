"""A recording cut into the drive's cycles: which are steady at full amplitude, which are not, and
why.

A recording is measured on its cycles, not its samples: a sensor settling at the start, amplitude
ramps, pauses and the unfinished cycle at the end each bend a measure taken over every sample
(a stroke from max − min includes the settling transient; a loop width from branches averaged over
all cycles mixes the major loop with minor ones). The rules, applied in this order:

1. **Period.** Given by the caller (e.g. a protocol's drive frequency; ``source`` "protocol"), or
   found from the drive U (``source`` "drive"). Candidates: the largest local peaks of U's
   spectrum between two periods a record and :data:`MIN_PERIOD_SAMPLES` samples a period, with and
   without a Hann window, and of its slope's spectrum above the noise floor (an amplitude ramp's
   or a pause's slow envelope can outweigh the drive's own peak), each refined by a parabola
   through the log magnitudes; of these, the one at whose lag U repeats itself best and half of
   whose lag it differs most, r(P) − r(P/2) (2 for a sine, a square or a triangle wave; near 0 for
   a harmonic, a sideband, noise or a short lag of a smooth drive), the larger peak on a tie (an
   odd multiple of the period scores as high). The period reported is then the median interval
   between the crossings (rule 2, interpolated between samples) that bound the used cycles. The
   drive is periodic when the record holds two periods at least, U correlates with itself one
   period later by :attr:`CycleRules.periodic_correlation` at least (or, over three periods where
   it moves at least, U over its local amplitude of rule 2 does, where it moves: amplitude ramps
   and pauses do not hide a period), and one whole cycle is found; otherwise the record is
   reported as having no periodic drive (steps, an arbitrary waveform) with the reason, and no
   cycle is formed. A given period is checked the same way: one
   the drive does not have is reported as such.
2. **Boundaries.** The drive's upward crossings of its local mid-level (U minus its running mean
   over one period, so that a ramp of amplitude on a unipolar drive still crosses it), with a
   Schmitt trigger: a crossing counts once U has been below −h and then rises above +h, h the
   largest of :attr:`CycleRules.hysteresis_fraction` of the local amplitude (√2 × the rms of each
   period-long block), :attr:`CycleRules.noise_factor` × the drive's noise (from its second
   differences) and :attr:`CycleRules.floor_fraction` of the record's amplitude. U is smoothed
   over 1/50 of a period first. A cycle runs from one crossing to the next; the pieces before the
   first and after the last are whole cycles when a period long to within a sample, else
   "partial".
3. **Warm-up.** The capture attribute ``warmup_s`` when the capture gives it, even as 0 (every piece
   that starts before it is dropped as "warm-up"); else the settling transient detected from x. Each
   full cycle (rule 4), in time order, has three measures (:func:`steadiness_measures`): its offset
   from the drive (the mean of x − g·U over a period from its start, g the least-squares gain of the
   later half of the full cycles), its non-closure (the mean of x − g·U over its last tenth minus
   over its first tenth) and its loop width (the largest branch gap). The windows are placed at the
   crossings' fractional times, so that every cycle's sit at the same phase whichever sample its
   boundary fell on. A slow drift moves the measures along a trend; a settling sensor moves a few
   leading cycles far off it. Through each measure a trend v̂(t) = a + b·(t − t̄) is fitted
   (:func:`robust_trend`: a robust line, the median of the slopes between cycles half the cycles
   apart, then least squares through the cycles near it), with the robust scatter of the later half
   about it, s = 1.4826·MAD. A leading cycle is settling while, for one measure, |v − v̂(t)| >
   max(w·S, z·σ·√(1 + 1/m + (t − t̄)²/S_tt)), v̂ the trend of the m cycles after it (the prediction
   interval of a straight-line fit: the trend's own uncertainty at t), σ the larger of s and what
   x's noise gives the measure, S the stroke, w :attr:`CycleRules.warmup_tolerance` (the floor) and
   z :attr:`CycleRules.settling_z` (:func:`settling_run`). The warm-up ends with the leading run's
   last cycle, and every piece that starts before is dropped as "warm-up". The trend is the drift:
   never dropped, reported (:attr:`Cycles.drift`). When the run would reach past the first half of
   the full cycles, x has not settled by the later half: nothing is dropped, and the note says so.
4. **Classes** of the pieces, by the drive's amplitude over each: the amplitude of the sinusoid at
   the drive's frequency that, with an offset, fits U over the piece by least squares (half the
   peak-to-peak for a sine or a raised cosine; insensitive to noise, to a single spike, and to a
   piece not being a whole number of periods long). A piece is whole when its length is within
   :attr:`CycleRules.period_tolerance` of the period. "pause": a whole piece whose amplitude is
   below :attr:`CycleRules.pause_fraction` of the full amplitude, or a longer piece during which
   the drive stood still (its slope below :attr:`CycleRules.pause_fraction` of the full cycles'
   peak slope) for a quarter of a period or more; "irregular": any other piece that is not a
   period long; "minor": a whole piece with an amplitude more than
   :attr:`CycleRules.full_tolerance` below the largest whole piece's after the warm-up given;
   the others are "full" and are the cycles used. A reason later in this list wins: "warm-up"
   over "partial" over "pause" over "irregular" over "minor".

5. **Outliers.** A used cycle whose measure lies off the used cycles' trend by more than
   max(w·S, z·σ·√(1 + leverage)), z :attr:`CycleRules.outlier_z` (:func:`trend_outliers`), is
   flagged (:attr:`Cycles.outliers`): still used for the stroke and loop width's median, least
   and largest, left out of a model's fit (:attr:`Cycles.fitted`).

Everything is vectorised numpy: a cycle's measures are cumulative sums, bincounts and
``reduceat``s over the samples, with no Python loop over samples (and none over cycles but building
the slices); 2^20 samples take about 0.2 s.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from selfsense.methods.metrics import direction

#: a period of fewer samples is not searched for (nor a cycle formed)
MIN_PERIOD_SAMPLES = 8
#: the reasons a piece is dropped, in precedence: one with several is dropped for the first
REASONS = ("warm-up", "partial", "pause", "irregular", "minor")
#: the drive is smoothed over this fraction of a period before its crossings are found
SMOOTH_FRACTION = 1 / 50
#: a note names at most this many cycles
MAX_NAMED = 8
#: the drive's direction (a loop's branch) is taken on it smoothed over this fraction of a period
#: (noise would flip it sample by sample)
SMOOTH_PERIOD_FRACTION = 1 / 200
#: a cycle of fewer samples is not measured alone (its peaks and its loop's middle fall between
#: samples): its loop width is not judged, and characterise measures the used cycles together
MIN_CYCLE_SAMPLES = 48
#: a cycle's loop width: its branches in one bin per this many samples of the cycle, 8 to 40 bins
SAMPLES_PER_BIN = 6
#: a trend (a line) is fitted through this many cycles at least; through fewer, their median (a
#: line through two or three leaves no scatter to judge a cycle by)
TREND_MIN_CYCLES = 4
#: σ of a normal scatter from its median absolute deviation: 1/Φ⁻¹(3/4)
MAD_TO_SIGMA = 1.4826


@dataclass(frozen=True)
class CycleRules:
    """The thresholds of the cycle analysis (see the module's docstring for how each is used)."""

    #: "full": amplitude within this fraction of the largest whole cycle's
    full_tolerance: float = 0.05
    #: "pause": amplitude (or slope) below this fraction of the full cycles'
    pause_fraction: float = 0.1
    #: a whole cycle: length within this fraction of the period
    period_tolerance: float = 0.1
    #: periodic drive: U correlates with U one period later by at least this
    periodic_correlation: float = 0.8
    #: warm-up and outliers: a difference in a cycle's offset, non-closure or loop width below this
    #: fraction of the stroke is never a transient nor an outlier
    warmup_tolerance: float = 0.0025
    #: warm-up: a leading cycle settles while a measure is off the later cycles' trend by more
    #: than this robust z (this many × 1.4826·MAD, widened by the trend's own uncertainty)
    settling_z: float = 5.0
    #: outlier: a used cycle off the used cycles' trend by more than this robust z is flagged
    #: and left out of the hysteresis model's fit
    outlier_z: float = 5.0
    #: Schmitt trigger: ± this fraction of the drive's local amplitude
    hysteresis_fraction: float = 0.2
    #: Schmitt trigger: at least this many times the drive's noise
    noise_factor: float = 5.0
    #: Schmitt trigger: at least this fraction of the record's drive amplitude
    floor_fraction: float = 0.01

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any] | None) -> CycleRules:
        """Rules from a mapping of some of the fields (e.g. a rule's params), defaults for the
        rest."""
        return cls(**{k: float(v) for k, v in (values or {}).items()})


RULES = CycleRules()


@dataclass(frozen=True, eq=False)
class Cycles:
    """A recording's cycles: index ranges into the arrays it was found on.

    ``used``: the steady full-amplitude cycles, in time order (the ones to measure stroke and loop
    width on, or to fit a hysteresis model to); ``dropped``: every other piece of the record with
    its reason ("warm-up", "partial", "pause", "irregular", "minor"). Together they tile the
    record from the first sample to the last. ``period_s`` is NaN and both lists are empty when
    the drive is not periodic (``note`` says why). ``source``: where the period came from,
    "drive" or "protocol" ("" when none). ``warmup_s``: the seconds dropped at the start;
    ``warmup_source``: "capture attribute warmup_s" (given, even as 0), "detected" or "" (none
    given, none detected).
    ``amplitude``: the full cycles' median drive amplitude [U's units] (of the sinusoid at the
    drive's frequency fitted to each: half the peak-to-peak for a sine or a raised cosine);
    ``minor_amplitudes``: the minor cycles', in time order. ``measured_period_s``: the median
    interval between the crossings bounding the used cycles (the period itself when found from
    the drive; beside a given one, the drive's own).
    ``outliers``: the used cycles far outside the others' spread (rule 5), still used for the
    stroke and loop width's median, least and largest but left out of a model's fit
    (:attr:`fitted`). ``drift``: x's trend through the used cycles [x's units], from the first's
    middle to the last's, ``drift_s`` [s] apart (NaN without x); ``drift_floor``: the difference
    below which rule 3 judges nothing (its floor, [x's units]): a drift beyond it is told in
    :meth:`summary`.
    """

    fs: float
    n: int
    period_s: float
    source: str
    used: list[slice]
    dropped: list[tuple[slice, str]]
    warmup_s: float = 0.0
    warmup_source: str = ""
    amplitude: float = np.nan
    minor_amplitudes: list[float] = field(default_factory=list)
    measured_period_s: float = np.nan
    note: str = ""
    outliers: list[slice] = field(default_factory=list)
    drift: float = np.nan
    drift_s: float = 0.0
    drift_floor: float = np.nan

    @property
    def fitted(self) -> list[slice]:
        """The used cycles without the outliers: the ones a model is fitted to."""
        flagged = {(s.start, s.stop) for s in self.outliers}
        return [s for s in self.used if (s.start, s.stop) not in flagged]

    @property
    def periodic(self) -> bool:
        return bool(np.isfinite(self.period_s))

    def counts(self) -> dict[str, int]:
        """Cycles used and dropped per reason: {"used": …, "warm-up": …, …}."""
        out = {"used": len(self.used)} | dict.fromkeys(REASONS, 0)
        for _, reason in self.dropped:
            out[reason] += 1
        return out

    def mask(self) -> np.ndarray:
        """True on the samples of the used cycles."""
        edges = np.zeros(self.n + 1, np.int64)
        np.add.at(edges, [s.start for s in self.used], 1)
        np.add.at(edges, [s.stop for s in self.used], -1)
        return np.cumsum(edges[:-1]) > 0

    def after_warmup(self) -> slice:
        """The samples after the warm-up (the whole record without one)."""
        return slice(min(self.n, int(np.ceil(self.warmup_s * self.fs - 1e-9))), self.n)

    def summary(self, x_scale: float = 1.0, x_unit: str = "in x's units") -> str:
        """One line: the period and its source, the cycles used and dropped and why, the outliers
        and a drift beyond rule 3's floor (x × ``x_scale`` in ``x_unit``: the table's units)."""
        if not self.periodic:
            return self.note
        counts = self.counts()
        why = ", ".join(f"{counts[r]} {r}" for r in REASONS if counts[r])
        text = f"period {self.period_s:.6g} s from the {self.source}; {counts['used']} cycles used"
        text += f", {len(self.dropped)} dropped ({why})" if self.dropped else ", none dropped"
        if self.warmup_source:
            text += f"; warm-up {self.warmup_s:.4g} s ({self.warmup_source})"
        if self.outliers:
            at = ", ".join(f"{s.start / self.fs:.4g}" for s in self.outliers[:MAX_NAMED])
            more = (
                f", … ({len(self.outliers) - MAX_NAMED} more)"
                if len(self.outliers) > MAX_NAMED
                else ""
            )
            text += (
                f"; {len(self.outliers)} used cycles far outside the others' spread (starting at "
                f"{at}{more} s): left out of the hysteresis model's fit"
            )
        if abs(self.drift) > self.drift_floor:
            text += (
                f"; x drifts {self.drift * x_scale:+.3g} {x_unit} over the used cycles' "
                f"{self.drift_s:.4g} s (a trend through them, not a warm-up: none dropped for it)"
            )
        return text + (f"; {self.note}" if self.note else "")


def filled(u: np.ndarray) -> np.ndarray:
    """u with its non-finite samples interpolated from their finite neighbours."""
    u = np.asarray(u, dtype=float)
    bad = ~np.isfinite(u)
    if not bad.any():
        return u
    good = np.flatnonzero(~bad)
    if good.size == 0:
        return np.zeros_like(u)
    out = u.copy()
    out[bad] = np.interp(np.flatnonzero(bad), good, u[good])
    return out


def running_mean(a: np.ndarray, width: int) -> np.ndarray:
    """Mean over ``width`` samples centred on each sample; at the ends the window is moved inward
    (kept whole), so that a periodic signal's mean over one period is right up to its ends."""
    n = len(a)
    width = int(min(max(width, 1), n))
    if width == 1:
        return np.asarray(a, dtype=float)
    shift = float(np.mean(a))  # sums of a signal less its mean keep their precision
    c = np.concatenate(([0.0], np.cumsum(np.asarray(a, dtype=float) - shift)))
    whole = (c[width:] - c[:-width]) / width + shift  # windows starting at 0 … n − width
    head, tail = width // 2, n - (n - width + 1) - width // 2
    return np.concatenate((np.full(head, whole[0]), whole, np.full(tail, whole[-1])))


def noise_sigma(u: np.ndarray, at_most: int = 1 << 16) -> float:
    """The standard deviation of u's white noise, from the median absolute second difference
    (a smooth drive's own second differences are small next to the noise's), over at most
    ``at_most`` of them evenly spread."""
    if len(u) < 3:
        return 0.0
    d2 = np.diff(u, 2)[:: max(1, (len(u) - 2) // at_most)]
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


def spectral_peaks(u: np.ndarray, fs: float, count: int = 4) -> list[float]:
    """Candidate periods [s] of the drive, in this order: in U's spectrum between two periods a
    record and MIN_PERIOD_SAMPLES samples a period, Hann-windowed and then not (a drive active
    only near the record's ends is all but windowed away), the ``count`` largest local peaks of
    each, largest first, then of each's slope spectrum k·|X_k| above ten times its noise floor
    (the median magnitude of the upper half: an amplitude ramp's or a pause's envelope, slow and
    large, hides a drive's peak in the first); each refined by a parabola through its log
    magnitudes."""
    n = len(u)
    a = np.asarray(u, dtype=float)
    spectrum = np.fft.rfft(a - a.mean())
    k_lo, k_hi = 2, min(n // MIN_PERIOD_SAMPLES, len(spectrum) - 2)
    if k_hi <= k_lo:
        return []
    # the Hann window applied in the frequency domain: X_w[k] = X[k]/2 − (X[k−1] + X[k+1])/4
    hann = np.zeros(len(spectrum))
    hann[1:-1] = np.abs(0.5 * spectrum[1:-1] - 0.25 * (spectrum[:-2] + spectrum[2:]))
    out = {}
    for mag in (hann, np.abs(spectrum)):
        band = mag[k_lo - 1 : k_hi + 2]
        peaks = np.flatnonzero((band[1:-1] >= band[:-2]) & (band[1:-1] > band[2:])) + k_lo
        loud = peaks[mag[peaks] > 10 * np.median(mag[len(mag) // 2 :])]
        for k in np.concatenate(
            (
                peaks[np.argsort(mag[peaks])[::-1][:count]],
                loud[np.argsort(loud * mag[loud])[::-1][:count]],
            )
        ):
            left, mid, right = np.log(mag[k - 1 : k + 2] + 1e-300)
            curve = left - 2 * mid + right
            delta = 0.5 * (left - right) / curve if curve < 0 else 0.0
            out.setdefault(int(k), n / ((k + float(np.clip(delta, -0.5, 0.5))) * fs))
    return list(out.values())


def spectral_period(u: np.ndarray, fs: float) -> float:
    """The drive's period [s] from the largest peak of its spectrum (:func:`spectral_peaks`);
    NaN when the record is too short."""
    peaks = spectral_peaks(u, fs, count=1)
    return peaks[0] if peaks else np.nan


def drive_period(u: np.ndarray, fs: float) -> tuple[float, float]:
    """(period [s], U's correlation with itself one period later): of the spectrum's largest
    peaks (:func:`spectral_peaks`, in their order), the one at which U repeats itself best one
    period later and differs most half a period later, r(P) − r(P/2). An amplitude ramp's
    envelope, a distorted drive's harmonics, a carrier's sidebands and noise put peaks of their
    own in the spectrum: a drive's own period scores 2 for a sine, a square or a triangle wave; a
    harmonic or a short lag of a smooth drive (r(P) ≈ r(P/2)) scores near 0 or below. An odd
    multiple of the period scores as high: of scores within 0.1 of each other, the earlier
    peak's is taken (a multiple's peak is leakage or noise). (NaN, NaN) without a candidate."""
    best = (np.nan, np.nan, -np.inf)
    for period in spectral_peaks(u, fs):
        lag = int(round(period * fs))
        if MIN_PERIOD_SAMPLES <= lag and 2 * lag <= len(u):
            r = lag_correlation(u, lag)
            score = r - lag_correlation(u, lag // 2)
            if np.isfinite(score) and score > best[2] + 0.1:  # a tie: the larger peak
                best = (period, r, score)
    return best[0], best[1]


def lag_correlation(u: np.ndarray, lag: int, valid: np.ndarray | None = None) -> float:
    """The correlation of u with itself ``lag`` samples later (its mean removed; over at most
    65 536 pairs of samples, evenly spread; with ``valid``, over the pairs both of whose samples
    are)."""
    if lag <= 0 or lag >= len(u):
        return np.nan
    step = max(1, (len(u) - lag) // (1 << 16))  # 65 536 pairs at most, evenly spread
    head, tail = np.asarray(u[:-lag:step], float), np.asarray(u[lag::step], float)
    if valid is not None:
        both = valid[:-lag:step] & valid[lag::step]
        head, tail = head[both], tail[both]
        if not head.size:
            return np.nan
    mean = 0.5 * (head.mean() + tail.mean())
    head, tail = head - mean, tail - mean
    den = np.sqrt(np.dot(head, head) * np.dot(tail, tail))
    return float(np.dot(head, tail) / den) if den > 0 else np.nan


def upward_crossings(u_ac: np.ndarray, h: np.ndarray | float) -> np.ndarray:
    """Times [samples, fractional] at which ``u_ac`` crosses zero upwards, each counted once it
    has been below −h and then risen above +h (a Schmitt trigger: noise near zero adds none)."""
    n = len(u_ac)
    index = np.arange(n)
    event = np.zeros(n, np.int8)
    event[u_ac > h] = 1
    event[u_ac < -h] = -1
    last = np.maximum.accumulate(np.where(event != 0, index, -1))
    state = np.where(last >= 0, event[np.maximum(last, 0)], 0)
    rises = np.flatnonzero((state[1:] == 1) & (state[:-1] == -1)) + 1
    below = np.maximum.accumulate(np.where(u_ac <= 0, index, -1))
    i = below[rises - 1]  # the last sample at or below zero: the crossing is between i and i + 1
    return i + u_ac[i] / (u_ac[i] - u_ac[i + 1])


def _segment_sums(values: np.ndarray, starts: np.ndarray) -> np.ndarray:
    return np.add.reduceat(values, starts) if len(starts) else np.zeros(0)


def _fundamental(
    u: np.ndarray, starts: np.ndarray, lengths: np.ndarray, period_samples: float
) -> np.ndarray:
    """Per piece: the amplitude of the sinusoid at the drive's frequency that, with an offset,
    fits u best by least squares (right for a piece that is not a whole number of periods long,
    as a cycle cut between samples is not). The sums of the sinusoids over a piece are closed
    forms; of u times them, one pass (e^(−iωj) as the outer product of two tables of √n each)."""
    n, block = len(u), int(np.ceil(np.sqrt(len(u))))
    omega = 2 * np.pi / period_samples
    coarse = np.exp(-1j * omega * block * np.arange(-(-n // block)))
    turn = (coarse[:, None] * np.exp(-1j * omega * np.arange(block))[None, :]).ravel()[:n]
    projected = np.add.reduceat(u * turn, starts)
    length = lengths.astype(float)

    def geometric(w):  # Σ_j e^(iwj) over each piece
        return np.exp(1j * w * starts) * (1 - np.exp(1j * w * length)) / (1 - np.exp(1j * w))

    one, two = geometric(omega), geometric(2 * omega)
    c, s = one.real, one.imag
    normal = np.empty((len(starts), 3, 3))
    normal[:, 0] = np.column_stack((length, c, s))
    normal[:, 1] = np.column_stack((c, 0.5 * (length + two.real), 0.5 * two.imag))
    normal[:, 2] = np.column_stack((s, 0.5 * two.imag, 0.5 * (length - two.real)))
    rhs = np.column_stack((np.add.reduceat(u, starts), projected.real, -projected.imag))
    fitted = np.full((len(starts), 3), np.nan)
    ok = np.abs(np.linalg.det(normal)) > 1e-9 * length**3
    fitted[ok] = np.linalg.solve(normal[ok], rhs[ok][:, :, None])[:, :, 0]
    return np.hypot(fitted[:, 1], fitted[:, 2])


def _aperiodic(fs, n, warmup_s, note, source="") -> Cycles:
    return Cycles(
        fs,
        n,
        np.nan,
        source,
        [],
        [],
        warmup_s=warmup_s or 0.0,
        warmup_source="" if warmup_s is None else "capture attribute warmup_s",
        note=note,
    )


def find_cycles(
    u: np.ndarray,
    fs: float,
    x: np.ndarray | None = None,
    period_s: float | None = None,
    warmup_s: float | None = None,
    rules: CycleRules = RULES,
) -> Cycles:
    """The cycles of a recording of the drive ``u`` (and the displacement ``x``, for the warm-up's
    detection, the drift and the outliers), sampled at ``fs`` [Hz]. ``period_s``: the drive's
    period if known (else found from u); ``warmup_s``: the capture's attribute (None: not given,
    detect it from x). Five steps, the module's rules 1–5: the period, the boundaries, the
    classes, the steadiness, and the cycles assembled."""
    u = filled(u)
    n = len(u)
    start = min(n, int(np.ceil(warmup_s * fs - 1e-9))) if warmup_s else 0
    given = period_s is not None and np.isfinite(period_s) and period_s > 0
    source = "protocol" if given else "drive"
    period = float(period_s) if given else drive_period(u[start:], fs)[0]
    if not np.isfinite(period) or period * fs < MIN_PERIOD_SAMPLES:
        return _aperiodic(fs, n, warmup_s, "no periodic drive: the record is too short for one")
    pieces = _boundary_step(u, fs, period, given, start, rules)
    if isinstance(pieces, str):
        return _aperiodic(fs, n, warmup_s, pieces, source)
    reasons = _class_step(u, pieces, start, rules)
    if isinstance(reasons, str):
        return _aperiodic(fs, n, warmup_s, reasons, source)
    steady = Steadiness()
    if x is not None:
        steady = _steadiness_step(u, filled(x), pieces, reasons, warmup_s is None, rules)
    return _assemble_step(fs, n, source, pieces, reasons, steady, warmup_s, start)


@dataclass
class _Pieces:
    """The record cut at the drive's upward crossings (rule 2), and each piece's drive amplitude
    (rule 4, filled in by :func:`_class_step`).

    ``times``: the crossings [samples, fractional]; piece k runs ``lengths[k]`` samples from
    ``starts[k]`` (pieces 0 and the last: the record's ends); ``smooth``: the drive smoothed over
    SMOOTH_FRACTION of a period; ``lag``: the period in whole samples; ``period`` [s] and
    ``period_samples``: refined from the crossings unless ``given``; ``measured``: the median
    regular interval [s]."""

    period: float
    given: bool
    times: np.ndarray
    starts: np.ndarray
    lengths: np.ndarray
    smooth: np.ndarray
    lag: int
    period_samples: float
    measured: float
    amplitude: np.ndarray = field(default_factory=lambda: np.zeros(0))
    whole: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))

    def bounds(self, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The start and end [samples, fractional] of pieces ``k``: their crossings; at the
        record's ends, a period from the other one."""
        times = self.times
        begin = np.where(k >= 1, times[np.clip(k - 1, 0, None)], times[0] - self.period_samples)
        finish = np.where(k < len(times), times[np.clip(k, None, len(times) - 1)], np.nan)
        return begin, np.where(np.isfinite(finish), finish, begin + self.period_samples)


def _boundary_step(u, fs, period, given, start, rules) -> _Pieces | str:
    """Rules 1 and 2: the period checked (periodic or not, and why not), the crossings and the
    pieces between them; a note (str) when the drive is not periodic."""
    n = len(u)
    lag = int(round(period * fs))
    what = f"the {'protocol' if given else 'drive'}'s period {period:.4g} s"
    if n - start < 2 * lag:
        return f"no periodic drive: under two of {what}"
    # the drive less its running mean over a period, smoothed: its upward zero crossings (the
    # means of the warm-up given and of the rest apart: a hold before the drive would bias them)
    smooth = running_mean(u, int(round(lag * SMOOTH_FRACTION)))
    parts = [part for part in (slice(0, start), slice(start, n)) if part.stop > part.start]
    u_ac = np.concatenate([smooth[p] - running_mean(smooth[p], lag) for p in parts])
    # the local amplitude: √2 × the rms of each period-long block
    blocks = np.arange(0, n, lag)
    block_rms = np.sqrt(np.add.reduceat(u_ac * u_ac, blocks) / np.diff(np.append(blocks, n)))
    local = np.repeat(np.sqrt(2) * block_rms, np.diff(np.append(blocks, n)))
    # periodic: U repeats itself a period later; or, over three periods at least where it moves
    # (fewer: two steps up and down are a square wave's period as much as a step test's), its
    # shape does whatever its amplitude (ramps) and wherever it holds still (pauses): U over its
    # local amplitude, over the pairs of samples both of which lie in blocks that move
    r = lag_correlation(u[start:], lag)
    moving = local > rules.pause_fraction * float(local[start:].max(initial=0.0))
    if not r >= rules.periodic_correlation and np.count_nonzero(moving[start:]) >= 3 * lag:
        shape = np.where(moving, u_ac / np.where(moving, local, 1.0), 0.0)
        r = lag_correlation(shape[start:], lag, moving[start:])
    if not r >= rules.periodic_correlation:
        return f"no periodic drive: U correlates {r:.2f} with itself one period ({what}) later"
    sample = u_ac[start :: max(1, (n - start) // (1 << 16))]
    scale = 0.5 * float(np.subtract(*np.percentile(sample, [99.5, 0.5])))
    h = np.maximum(
        rules.hysteresis_fraction * local,
        max(rules.noise_factor * noise_sigma(u), rules.floor_fraction * scale),
    )
    times = upward_crossings(u_ac, h)
    # piece k (0 < k < len(times)) runs from crossing k − 1 to crossing k: samples from the first
    # after one to the last before the next; pieces 0 and len(times) are the record's ends
    bounds = np.concatenate(([0], np.floor(times).astype(int) + 1, [n]))
    period_samples = period * fs
    # the median whole cycle between two crossings refines a period found from the spectrum
    intervals = np.diff(times)
    regular = np.abs(intervals / period_samples - 1) <= rules.period_tolerance
    measured = float(np.median(intervals[regular])) / fs if regular.any() else np.nan
    if not given and regular.sum() >= 3:  # fewer: a crossing next to a hold is off, keep P
        period, period_samples = measured, measured * fs
    return _Pieces(
        period, given, times, bounds[:-1], np.diff(bounds), smooth, lag, period_samples, measured
    )


def _class_step(u, pieces: _Pieces, start: int, rules: CycleRules) -> np.ndarray | str:
    """Rule 4 (and rule 3's warm-up given): each piece's reason to be dropped, "" for a full
    cycle; a note (str) when no whole cycle is found."""
    n, starts, lengths = len(u), pieces.starts, pieces.lengths
    period_samples = pieces.period_samples
    whole = np.abs(lengths - period_samples) <= rules.period_tolerance * period_samples + 1
    partial = np.zeros(len(starts), bool)
    if len(pieces.times):
        # the pieces before the first crossing and after the last: whole only to within a sample
        tight = max(1.0, 0.002 * period_samples)
        partial[0] = abs(lengths[0] - period_samples) > tight
        partial[-1] = abs(lengths[-1] - period_samples) > tight
    else:
        partial[:] = True
    whole &= ~partial
    pieces.amplitude = amplitude = _fundamental(u, starts, lengths, period_samples)
    pieces.whole = whole
    in_warmup = starts < start
    candidates = whole & ~in_warmup
    if not candidates.any():
        what = f"the {'protocol' if pieces.given else 'drive'}'s period {pieces.period:.4g} s"
        return f"no periodic drive: no whole cycle of {what}"
    full_amplitude = float(amplitude[candidates].max())
    # still: the smoothed drive's slope, over ± a fiftieth of a period, under the pause fraction
    # of the full cycles' peak slope
    smooth = pieces.smooth
    w = min(max(1, int(round(pieces.lag * SMOOTH_FRACTION))), (n - 1) // 2)
    slope = np.abs(smooth[2 * w :] - smooth[: -2 * w]) / (2 * w)
    slope = np.concatenate((np.full(w, slope[0]), slope, np.full(w, slope[-1])))
    still = slope < rules.pause_fraction * 2 * np.pi * full_amplitude / period_samples
    still_count = _segment_sums(still.astype(np.int64), starts)

    reasons = np.full(len(starts), "", dtype=object)
    minor = whole & (amplitude < (1 - rules.full_tolerance) * full_amplitude)
    held = ~whole & (lengths > period_samples) & (still_count >= 0.25 * period_samples)
    paused = (whole & (amplitude < rules.pause_fraction * full_amplitude)) | held
    partial &= ~held  # a piece at an end that holds a pause is one
    for mask, reason in (
        (minor, "minor"),
        (~whole, "irregular"),
        (paused, "pause"),
        (partial, "partial"),
        (in_warmup, "warm-up"),
    ):
        reasons[mask] = reason  # later rules override earlier ones: warm-up wins
    return reasons


def _steadiness_step(
    u: np.ndarray,
    x: np.ndarray,
    pieces: _Pieces,
    reasons: np.ndarray,
    detect: bool,
    rules: CycleRules,
) -> Steadiness:
    """Rules 3 and 5 on the full cycles: with ``detect`` (no warm-up given), the settling
    transient (:func:`settling_run`), dropped as warm-up by setting ``reasons``; then the trend
    through the cycles left and the ones far outside their spread (:func:`trend_outliers`)."""
    full = np.flatnonzero(reasons == "")
    if not full.size:
        return Steadiness()
    begin, finish = pieces.bounds(full)
    measures = steadiness_measures(u, x, begin, finish, pieces.period_samples)
    mid = 0.5 * (begin + finish)
    run, note = 0, ""
    if detect:
        run, note = settling_run(mid, measures, rules)
        if run:
            reasons[full[:run]] = "warm-up"
            ends = pieces.starts[full[run - 1]] + pieces.lengths[full[run - 1]]
            reasons[pieces.starts < ends] = "warm-up"  # and the pieces before it
    kept = np.flatnonzero(reasons[full] == "")
    left = {k: replace(m, values=m.values[kept]) for k, m in measures.items()}
    flagged, drift = trend_outliers(mid[kept], left, rules)
    return Steadiness(
        detected=run,
        outliers=[int(i) for i in full[kept][flagged]],
        drift=drift,
        drift_span=float(mid[kept][-1] - mid[kept][0]) if kept.size else 0.0,
        drift_floor=rules.warmup_tolerance * measures["offset"].stroke,
        note=note,
    )


def _assemble_step(fs, n, source, pieces, reasons, steady, warmup_s, start) -> Cycles:
    """Rule 1's period from the used cycles' crossings, and the cycles as index ranges."""
    starts, lengths, times = pieces.starts, pieces.lengths, pieces.times
    slices = [slice(int(s), int(s + k)) for s, k in zip(starts, lengths)]
    used = [s for s, why in zip(slices, reasons) if why == ""]
    period, measured = pieces.period, pieces.measured
    # the period measured: the median interval between the crossings that bound the used cycles
    inner = np.flatnonzero(reasons[1:-1] == "") + 1
    if inner.size:
        measured = float(np.median(times[inner] - times[inner - 1])) / fs
        period = measured if not pieces.given and inner.size >= 3 else period
    warmup_end = start
    if steady.detected:
        last = int(np.flatnonzero(reasons == "warm-up")[-1])
        warmup_end = int(starts[last] + lengths[last])
    if warmup_s is not None:
        warmup_source = "capture attribute warmup_s"
    else:
        warmup_source = "detected" if steady.detected else ""
    return Cycles(
        fs,
        n,
        period,
        source,
        used,
        [(s, str(why)) for s, why in zip(slices, reasons) if why != ""],
        warmup_s=float(warmup_s) if warmup_s is not None else warmup_end / fs,
        warmup_source=warmup_source,
        amplitude=float(np.median(pieces.amplitude[reasons == ""])) if used else np.nan,
        minor_amplitudes=[float(a) for a in pieces.amplitude[reasons == "minor"]],
        measured_period_s=measured,
        note=steady.note,
        outliers=[slices[i] for i in steady.outliers],
        drift=steady.drift,
        drift_s=steady.drift_span / fs,
        drift_floor=steady.drift_floor,
    )


@dataclass(frozen=True)
class Steadiness:
    """Rules 3 and 5's answer: how many leading full cycles were detected as settling, the used
    pieces flagged as outliers (indices of the pieces), x's drift through the used cycles [x's
    units] over ``drift_span`` [samples] between the first's and the last's middles, rule 3's
    floor [x's units], and a note."""

    detected: int = 0
    outliers: list[int] = field(default_factory=list)
    drift: float = np.nan
    drift_span: float = 0.0
    drift_floor: float = np.nan
    note: str = ""


def rising_with_period(u: np.ndarray, period_samples: float) -> np.ndarray:
    """+1 where the drive rises, −1 where it falls, on the drive smoothed over
    SMOOTH_PERIOD_FRACTION of its period [samples] (noise would flip it sample by sample)."""
    width = max(1, int(round(period_samples * SMOOTH_PERIOD_FRACTION)))
    smooth = np.convolve(u, np.ones(width) / width, mode="same") if width > 1 else u
    return direction(smooth)


def loop_bins(per_cycle: float) -> int:
    """The bins of a cycle's loop of ``per_cycle`` samples: one per SAMPLES_PER_BIN, 8 to 40."""
    return int(np.clip(per_cycle // SAMPLES_PER_BIN, 8, 40))


def _aligned_sums(c: np.ndarray, t0: np.ndarray, m: int) -> np.ndarray:
    """Σ_{j=1..m} v(t0 + j), v interpolated linearly between samples, from c = [0, cumsum(v)]:
    sums over windows placed at fractional times, so that they sit at the same phase of every
    cycle however its boundary fell between samples."""
    last = len(c) - 1
    i0 = np.floor(t0).astype(int)
    f = t0 - i0

    def window(first):  # Σ v[first + 1 … first + m]
        lo, hi = np.clip(first + 1, 0, last), np.clip(first + m + 1, 0, last)
        return c[hi] - c[lo]

    return (1 - f) * window(i0) + f * window(i0 + 1)


@dataclass(frozen=True)
class Measure:
    """One measure of every full cycle, in time order, [x's units]: its values, the scatter x's
    white noise alone gives each (σ/√m for a mean of m samples), and the floor below which a
    difference is never a transient nor an outlier (``floor`` × the stroke, rule 3)."""

    values: np.ndarray
    noise: float
    stroke: float


def steadiness_measures(
    u: np.ndarray, x: np.ndarray, begin: np.ndarray, end: np.ndarray, period_samples: float
) -> dict[str, Measure]:
    """The three measures of rule 3 on the full cycles that run from ``begin`` to ``end``
    [samples, fractional: the drive's crossings], in x's units:

    - "offset": the mean of x − g·U over one period from the cycle's start, g the least-squares
      gain of the later half of the cycles (a sensor's settling offset moves it);
    - "closure": the mean of x − g·U over the cycle's last tenth minus over its first tenth (a
      transient that decays within the cycle leaves its loop open);
    - "loop width": the largest distance between the cycle's rising and falling branches
      (:func:`cycle_loops`; a transient within the cycle widens it), when a cycle has
      MIN_CYCLE_SAMPLES samples at least (fewer: its branches cannot be binned, left out).

    The windows sit at the same phase of every cycle, to a fraction of a sample."""
    count = len(begin)
    later = slice(count // 2, None)
    span = max(1, int(np.floor(period_samples)) - 1)
    tenth = max(1, int(round(period_samples / 10)))
    cums = {k: np.concatenate(([0.0], np.cumsum(v))) for k, v in (("u", u), ("x", x))}

    def means(t0, m):
        return {k: _aligned_sums(c, t0, m) / m for k, c in cums.items()}

    whole, head, tail = means(begin, span), means(begin, tenth), means(end - tenth - 1, tenth)
    # the gain of the later half: least squares over their samples
    pick = np.zeros(len(u) + 1, np.int64)
    np.add.at(pick, np.ceil(begin[later]).astype(int), 1)
    np.add.at(pick, np.minimum(np.ceil(end[later]).astype(int), len(u)), -1)
    inside = np.cumsum(pick[:-1]) > 0
    c = np.cov(u[inside], x[inside]) if inside.sum() > 2 else np.zeros((2, 2))
    gain = c[0, 1] / c[0, 0] if c[0, 0] > 0 else 0.0
    offset = whole["x"] - gain * whole["u"]
    closure = (tail["x"] - gain * tail["u"]) - (head["x"] - gain * head["u"])
    lo = np.clip(np.ceil(begin).astype(int), 0, len(x) - 1)
    hi = np.clip(np.ceil(end).astype(int), lo + 1, len(x))
    cycles = [slice(int(a), int(b)) for a, b in zip(lo, hi)]
    strokes, gaps = cycle_loops(
        u, x, rising_with_period(u, period_samples), cycles, loop_bins(span)
    )
    stroke = float(np.nanmedian(strokes[later])) if count else np.nan
    # the scatter x's noise alone gives each measure: a mean of m samples σ/√m, a difference of
    # two means of m σ·√(2/m); a branch gap the difference of two branch means of a bin each,
    # span/(2·bins) samples
    sigma = noise_sigma(x)
    out = {
        "offset": Measure(offset, sigma / np.sqrt(span), stroke),
        "closure": Measure(closure, sigma * np.sqrt(2 / tenth), stroke),
    }
    if span + 1 >= MIN_CYCLE_SAMPLES:
        bins = loop_bins(span)
        out["loop width"] = Measure(gaps, sigma * np.sqrt(4 * bins / span), stroke)
    return out


@dataclass(frozen=True)
class _Trend:
    """A measure's trend through some cycles (:func:`robust_trend`): v̂(t) = a + b·(t − t̄), fitted
    on m cycles with p parameters (2: a line, 1: a constant), S_tt = Σ(t − t̄)² over them, s the
    robust scatter of their residuals, ``kept`` the cycles the second fit was made on."""

    a: float
    b: float
    t_bar: float
    s_tt: float
    s: float
    m: int
    p: int
    kept: np.ndarray

    def at(self, t: np.ndarray) -> np.ndarray:
        return self.a + self.b * (t - self.t_bar)

    def leverage(self, t: np.ndarray) -> np.ndarray:
        """The trend's own variance at t over σ²: 1/m + (t − t̄)²/S_tt (a line), 1/m (constant)."""
        return 1 / self.m + ((t - self.t_bar) ** 2 / self.s_tt if self.p == 2 else 0.0)


def _line(t: np.ndarray, v: np.ndarray, robust: bool = False) -> _Trend | None:
    """The straight line v ≈ a + b·(t − t̄) through the finite values: by least squares, or with
    ``robust`` b the median of the slopes between each value and the one half the values later
    and a the median of v − b·(t − t̄) (a quarter of the values may lie anywhere and leave it
    where the rest are; a settling transient pulls a least-squares line toward itself). A
    constant, their median, with fewer than TREND_MIN_CYCLES (a line through two or three leaves
    no scatter to judge by). With the robust scatter of its residuals s = 1.4826·MAD·√(m/(m − p)):
    the MAD about the residuals' median, 1.4826 making it σ for a normal scatter, √(m/(m − p))
    undoing the p fitted parameters' shrinking of the residuals. None without two values."""
    ok = np.isfinite(v) & np.isfinite(t)
    t, v = t[ok], v[ok]
    m = len(v)
    if m < 2:
        return None
    t_bar = float(t.mean())
    s_tt = float(np.sum((t - t_bar) ** 2))
    if m >= TREND_MIN_CYCLES and s_tt > 0 and robust:
        half = m // 2
        b = float(np.median((v[half : 2 * half] - v[:half]) / (t[half : 2 * half] - t[:half])))
        a, p = float(np.median(v - b * (t - t_bar))), 2
    elif m >= TREND_MIN_CYCLES and s_tt > 0:
        a, b, p = float(v.mean()), float(np.sum((t - t_bar) * (v - v.mean())) / s_tt), 2
    else:
        a, b, p = float(np.median(v)), 0.0, 1
    r = v - (a + b * (t - t_bar))
    s = MAD_TO_SIGMA * float(np.median(np.abs(r - np.median(r)))) * np.sqrt(m / (m - p))
    return _Trend(a, b, t_bar, s_tt, s, m, p, ok)


def robust_trend(
    t: np.ndarray, measure: Measure, z: float, floor: float, scale: float | None = None
) -> _Trend | None:
    """A measure's trend through cycles at ``t`` (the slow drift, which is never a transient):
    a robust line first (:func:`_line`), then by least squares (the more precise) through the
    cycles whose residual from it is within the tolerance max(floor, z·σ),
    σ the larger of the robust scatter (``scale`` where given, else the first fit's) and what x's
    noise gives the measure."""
    first = _line(t, measure.values, robust=True)
    if first is None:
        return None
    residual = measure.values - first.at(t)
    spread = first.s if scale is None else scale
    near = np.abs(residual) <= max(floor, z * max(spread, measure.noise))
    second = _line(t[near], measure.values[near])
    if second is None:
        return first
    kept = np.zeros(len(t), bool)
    kept[np.flatnonzero(near)[second.kept]] = True
    return replace(second, kept=kept)


def _off(t, measures, z, floor, reference, scales=None):
    """Which cycles are off the trend of the cycles ``reference`` for any measure: the residual
    beyond max(floor·S, z·σ·√(1 + leverage)) (S the stroke; σ the larger of the measure's
    robust scatter, ``scales[name]`` or else the trend's, and x's noise's; the leverage the
    trend's own uncertainty at the cycle, the prediction interval of a straight-line fit). A NaN
    measure is off."""
    off = np.zeros(len(t), bool)
    for name, measure in measures.items():
        scale = None if scales is None else scales[name]
        trend = robust_trend(
            t[reference],
            replace(measure, values=measure.values[reference]),
            z,
            floor * measure.stroke,
            scale,
        )
        if trend is None:
            continue
        sigma = max(trend.s if scale is None else scale, measure.noise)
        tolerance = np.maximum(floor * measure.stroke, z * sigma * np.sqrt(1 + trend.leverage(t)))
        off |= ~(np.abs(measure.values - trend.at(t)) <= tolerance)
    return off


def _suffix_off(
    t: np.ndarray, measure: Measure, scale: float, z: float, floor: float, kept: np.ndarray
) -> np.ndarray:
    """Which cycles are off the least-squares trend of the ``kept`` cycles after them (each
    judged against the later ones alone): the residual beyond max(floor, z·σ·√(1 + leverage)), σ
    the larger of ``scale`` and x's noise's, the leverage 1/m + (t − t̄)²/S_tt of the m cycles
    after it (a constant, their mean, while fewer than TREND_MIN_CYCLES). Sums from the record's
    end: every cycle's trend at once."""
    v = measure.values
    ok = np.isfinite(v) & kept
    w, tv, vv = ok.astype(float), np.where(ok, t, 0.0), np.where(ok, v, 0.0)

    def after(a):  # Σ over the cycles after each: reversed cumulative sums, shifted by one
        c = np.cumsum(a[::-1])[::-1]
        return np.append(c[1:], 0.0)

    m, st, sv = after(w), after(tv), after(vv)
    with np.errstate(invalid="ignore", divide="ignore"):
        t_bar, v_bar = st / m, sv / m
        s_tt = after(tv * tv) - m * t_bar**2
        s_tv = after(tv * vv) - m * t_bar * v_bar
        line = (m >= TREND_MIN_CYCLES) & (s_tt > 0)
        b = np.where(line, s_tv / np.where(line, s_tt, 1.0), 0.0)
        lever = 1 / m + np.where(line, (t - t_bar) ** 2 / np.where(line, s_tt, 1.0), 0.0)
        residual = v - (v_bar + b * (t - t_bar))
        sigma = max(scale, measure.noise)
        tolerance = np.maximum(floor, z * sigma * np.sqrt(1 + lever))
        return ~(np.abs(residual) <= tolerance) & (m >= 2)


def settling_run(
    t: np.ndarray, measures: Mapping[str, Measure], rules: CycleRules = RULES
) -> tuple[int, str]:
    """How many of the leading full cycles (their middles at ``t`` [samples], in time order) are
    a settling transient, and a note (rule 3).

    Each measure's robust scatter s is that of the later half of the cycles about their trend
    (:func:`robust_trend`). A leading cycle is off when, for any measure, it is off the trend of
    all the cycles after it (:func:`_suffix_off`: judged against the later cycles, with z
    :attr:`CycleRules.settling_z` and the floor :attr:`CycleRules.warmup_tolerance` of the
    stroke); the settling transient is the leading run of cycles off. The run is then extended
    while the first cycle after it is off the robust trend of the cycles from it on (a long
    transient's later cycles pull the least-squares trend toward the earlier ones; the robust
    trend leaves them out). None when the run would reach past the first half of the cycles:
    then x has not settled by the later half, and the note says so. The trend itself is the
    slow drift, fitted and never dropped."""
    count = len(t)
    if count < 4:
        return 0, ""
    later = np.arange(count) >= count // 2
    scales = {}
    for name, measure in measures.items():
        trend = robust_trend(
            t[later],
            replace(measure, values=measure.values[later]),
            rules.settling_z,
            rules.warmup_tolerance * measure.stroke,
        )
        scales[name] = trend.s if trend is not None else np.inf
    off = np.zeros(count, bool)
    for name, measure in measures.items():
        floor = rules.warmup_tolerance * measure.stroke
        # the later cycles a leading one is judged against: those near the robust trend of all
        # (a far one, settling or an outlier, would pull the least-squares trend toward itself)
        whole = robust_trend(t, measure, rules.settling_z, floor, scales[name])
        kept = whole.kept if whole is not None else np.isfinite(measure.values)
        off |= _suffix_off(t, measure, scales[name], rules.settling_z, floor, kept)
    run = int(np.argmin(off)) if not off.all() else count
    while run < count // 2:
        reference = np.arange(count) >= run
        off = _off(t, measures, rules.settling_z, rules.warmup_tolerance, reference, scales)
        if not off[run]:
            break
        run += int(np.argmin(off[run:])) if not off[run:].all() else count - run
    if run > count // 2:
        return 0, (
            "x has not settled by the later half of the full cycles (their first "
            f"{run} of {count} differ from the rest): no warm-up dropped"
        )
    return run, ""


def trend_outliers(
    t: np.ndarray, measures: Mapping[str, Measure], rules: CycleRules = RULES
) -> tuple[np.ndarray, float]:
    """The used cycles far outside the others' spread (rule 5), and x's drift through them.

    Through each measure's values a trend is fitted (:func:`robust_trend`); a cycle is an outlier
    where, for any measure, its residual exceeds max(w·S, z·σ·√(1 + leverage)) (:func:`_off`, z
    :attr:`CycleRules.outlier_z`). Returns the outliers' mask and the drift: the offset trend's
    change from the first cycle's middle to the last's [x's units] (NaN without two cycles)."""
    count = len(t)
    if count < 2:
        return np.zeros(count, bool), np.nan
    flagged = _off(t, measures, rules.outlier_z, rules.warmup_tolerance, np.ones(count, bool))
    offset = measures["offset"]
    trend = robust_trend(t, offset, rules.outlier_z, rules.warmup_tolerance * offset.stroke)
    drift = float(trend.b * (t[-1] - t[0])) if trend is not None else np.nan
    return flagged, drift


def cycle_loops(
    u: np.ndarray, y: np.ndarray, rising: np.ndarray, cycles: Sequence[slice], bins: int
) -> tuple[np.ndarray, np.ndarray]:
    """Per cycle: the range of y (max − min) and the largest vertical distance between the loop's
    rising and falling branches, each averaged in ``bins`` bins of the cycle's u range (the
    measure of :func:`selfsense.methods.metrics.branch_gap` on each cycle alone), in y's units.

    The cycle's end-point chord (the line through y's means near u's two extremes) is taken off
    sample by sample first: the gap at a given u is the same, and a bin's samples, which do not
    sit at its centre, then differ by the loop's small curvature only. NaN samples are left out.
    """
    if not cycles:
        return np.zeros(0), np.zeros(0)
    starts = np.array([c.start for c in cycles])
    lengths = np.array([c.stop for c in cycles]) - starts
    first = np.concatenate(([0], np.cumsum(lengths)[:-1]))
    rows = np.arange(first[-1] + lengths[-1]) + np.repeat(starts - first, lengths)
    cid = np.repeat(np.arange(len(cycles)), lengths)
    uu, yy, up = np.asarray(u, float)[rows], np.asarray(y, float)[rows], np.asarray(rising)[rows]
    ok = np.isfinite(uu) & np.isfinite(yy)
    uu = np.where(ok, uu, np.nan)
    yy = np.where(ok, yy, np.nan)
    lo, hi = np.fmin.reduceat(uu, first), np.fmax.reduceat(uu, first)
    y_range = np.fmax.reduceat(yy, first) - np.fmin.reduceat(yy, first)
    span = np.where(hi > lo, hi - lo, np.nan)
    rel = (uu - lo[cid]) / span[cid]
    m = len(cycles)

    def means(where, values):
        w = where & ok
        s = np.add.reduceat(np.where(w, values, 0.0), first)
        k = np.add.reduceat(w.astype(np.int64), first)
        return np.where(k > 0, s / np.maximum(k, 1), np.nan)

    near_lo, near_hi = rel <= 0.02, rel >= 0.98
    u_lo, u_hi = means(near_lo, uu), means(near_hi, uu)
    y_lo, y_hi = means(near_lo, yy), means(near_hi, yy)
    slope = (y_hi - y_lo) / (u_hi - u_lo)
    detrended = yy - (y_lo[cid] + slope[cid] * (uu - u_lo[cid]))
    which = np.clip(np.floor(np.nan_to_num(rel) * bins).astype(int), 0, bins - 1)
    key = (cid * bins + which) * 2 + (up > 0)
    w = ok & np.isfinite(detrended)
    sums = np.bincount(key[w], weights=detrended[w], minlength=2 * bins * m)
    counts = np.bincount(key[w], minlength=2 * bins * m)
    branch = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan).reshape(m, bins, 2)
    gap = np.abs(branch[:, :, 1] - branch[:, :, 0])
    has = np.isfinite(gap).any(axis=1)
    gaps = np.full(m, np.nan)
    gaps[has] = np.nanmax(gap[has], axis=1)
    return y_range, gaps


def protocol_period(protocol: Mapping[str, Any]) -> float | None:
    """The drive period [s] of a protocol entry (workflow/protocols/*.yaml) whose periodic
    segments share one frequency and add no multi-sine terms; None otherwise (steps, sweeps)."""
    segments = list(protocol.get("segments", ()))
    if any(seg.get("terms") for seg in segments):
        return None
    frequencies = {float(seg.get("frequency", 0.0)) for seg in segments} - {0.0}
    return 1.0 / frequencies.pop() if len(frequencies) == 1 else None
