"""A lab's own recording into the capture contract (docs/bring-your-own-data.md): the import
behind ``selfsense import``.

The file's reader is chosen by its suffix (:func:`open_source`; a ``.mat`` file by its content):
CSV/TSV (:mod:`selfsense.io.csv_source`), MATLAB v4–v7.3 (:mod:`selfsense.io.mat_source`), NI
TDMS (:mod:`selfsense.io.tdms_source`), each locating the columns asked for and checking their
types. The import converts each channel to its contract unit (times its ``--scale`` or
``--gain``), checks the time axis, packs int16 with the manifest's ranges (or ranges derived from
the data) and writes ``raw/<dataset>/<experiment>.nc``, then scaffolds or updates
``raw/<dataset>/dataset.yaml``.

Everything is judged before anything is published: the arguments (fs, names, ranges, factors),
the columns asked for (not all empty, not one value throughout), overload sentinels (``9.9E+37``,
``1e308``, ±inf: stored as missing and counted, refused beyond
:data:`~selfsense.io.contract.CLIP_LIMIT` of a channel) before a range is derived from the data, a
derived range against what a piezo bench can record (:data:`PLAUSIBLE`: a unit slip shows as
metres of stroke; where a --scale or --gain made it so, the refusal names the option), the time
axis against a least-squares line through it, the clipping against the ranges, and the span of
each channel in its range (at least :data:`MIN_CODES` int16 codes: a factor of 1e-320 leaves none).
A reader refuses one column named for two channels and a sample the file never held (a v7.3
variable declared longer than written). The source is read twice, in its reader's chunks: a
first pass checks and sums up, the second streams into the capture, so memory does not grow with
the file's length (a v4–v7 ``.mat`` file is loaded whole by scipy). Imports into one dataset take
its lock (:mod:`selfsense.io.dataset_lock`) and run one after another. The capture is written to a
hidden temporary, read back, and linked to its name only if no file has it (an existing capture is
never overwritten); the manifest follows by an atomic rename. A failure leaves nothing behind: no
capture, no temporary, no manifest change, no new folder. Every refusal is an
:class:`~selfsense.io.sources.ImportProblem`, one line naming the file or the argument and, where
it can, what to type instead.
"""

from __future__ import annotations

import errno
import logging
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from selfsense import __version__
from selfsense.io.capture import (
    CHANNEL_UNITS,
    INT16_FULL,
    MIN_SAMPLES,
    SLOW_CHANNELS,
    CaptureError,
    CaptureWriter,
    channel_spec,
    open_capture,
)
from selfsense.io.contract import CLIP_LIMIT, clipping_problem
from selfsense.io.csv_source import CsvSource
from selfsense.io.dataset_lock import LOCK_TIMEOUT_S, dataset_lock
from selfsense.io.manifest import (
    ManifestError,
    check_dataset_name,
    check_experiment_name,
    load_dataset,
    validate_document,
)
from selfsense.io.mat_source import Mat73Source, MatSource, is_hdf5
from selfsense.io.provenance import atomic_path, temporary_path
from selfsense.io.sources import (
    DECLARED_FS_RTOL,
    OVERLOAD,
    SCALE_KINDS,
    UNITS,
    Column,
    ImportProblem,
    Source,
)
from selfsense.io.tdms_source import TdmsSource

LOG = logging.getLogger("selfsense.io.importer")


@dataclass(frozen=True)
class Plausible:
    """What a piezo bench can record of one contract quantity, judged on a range derived from
    the data (a first import: no --range, no manifest range). ``peak``: the largest |value|;
    ``span``: the largest and smallest max − min; ``what``: what the channel would not be;
    ``typical``: the magnitude a unit suggestion aims at (the one nearest it, in decades)."""

    what: str
    typical: float
    peak: float = math.inf
    span: tuple[float, float] = (0.0, math.inf)


#: the plausibility of a derived range, per contract quantity, and why each limit
PLAUSIBLE: dict[str, Plausible] = {
    # piezo stacks run at up to ≈ 1 kV (Islam's at −30…150 V), high-voltage shear and tube
    # actuators at a few kV; no bench amplifier gives 10 kV (a kV column read as V: 150 kV)
    "V": Plausible("a piezo drive's voltage", typical=100.0, peak=1e4),
    # linear piezo amplifiers give at most ≈ 10–20 A peak, switching ones for large stacks tens of
    # amperes; 100 A none (µA or mA read as A, or a shunt's volts read as amperes beyond it)
    "A": Plausible("a piezo drive's current", typical=0.1, peak=100.0),
    # a stack strokes ≤ 0.3 mm, an amplified actuator or bender a few mm: 1 cm none (µm read as m:
    # metres); below 0.1 nm no displacement sensor tells motion from noise (m read as nm)
    "m": Plausible("a piezo actuator's displacement", typical=3e-5, span=(1e-10, 1e-2)),
    # the largest stacks block at ≈ 100 kN; 1 MN no bench's load cell measures (mN read as N is
    # within it: only a kN slip beyond)
    "N": Plausible("a force on a piezo actuator", typical=1e3, peak=1e6),
}
#: a channel's values span at least this many of the 65534 int16 codes of its range. Fewer, and
#: its quantisation step exceeds 1.6 % of its span, as coarse as the loop widths and
#: nonlinearities the analyses report in % of stroke; a bench's ADC gives a channel that uses
#: only a tenth of its range 6500 codes (a 12-bit one 410 levels), so fewer is a factor, a unit
#: or a range too wide for the data, not a recording
MIN_CODES = 64
#: what a refusal calls a range the import derives from the data
DERIVED = "derived from the data"
#: a derived ADC range leaves this fraction of the data's span free on each side
RANGE_MARGIN = 0.1
#: a derived range spans at least this fraction of the data's magnitude (a constant channel)
MIN_RELATIVE_SPAN = 1e-6
#: the time axis may stray this many samples from the least-squares line through it (as the
#: capture contract's time axis may)
TIME_TOLERANCE = 0.25
#: dataset and experiment names are at most this long: they become file names, to which the
#: capture's two temporaries add up to 114 characters, and a file name has at most 255 bytes
MAX_NAME = 100
#: capture attributes the import sets itself (an --attr may not), and the prefix of the ones
#: recording a channel's --scale or --gain (scale_<channel>, scale_kind_<channel>)
OWN_ATTRS = frozenset(
    {
        "dataset",
        "experiment",
        "fs",
        "source",
        "software_version",
        "imported_from",
        "import_note",
        "Conventions",
        "clipped_samples",
    }
)
SCALE_ATTR_PREFIX = "scale_"


# -- the first pass: what the columns hold -------------------------------------------------------


@dataclass
class _ChannelSummary:
    """A channel's cells: how many, missing, overloaded; the finite ones' span as recorded
    (``raw_lo``, ``raw_hi``) and in the contract unit (:attr:`lo`, :attr:`hi`); how many fall
    outside a range known before the pass."""

    label: str
    factor: float
    known: tuple[float, float] | None
    n: int = 0
    missing: int = 0
    overload: int = 0
    first_overload: tuple[int, float] | None = None
    raw_lo: float = math.inf
    raw_hi: float = -math.inf
    outside: int = 0

    def add(self, start: int, raw: np.ndarray) -> None:
        self.n += len(raw)
        nan = np.isnan(raw)
        over = ~nan & ~(np.abs(raw) < OVERLOAD)
        self.missing += int(np.count_nonzero(nan))
        count = int(np.count_nonzero(over))
        if count and self.first_overload is None:
            k = int(np.argmax(over))
            self.first_overload = (start + k + 1, float(raw[k]))
        self.overload += count
        good = raw[~(nan | over)]
        if good.size:
            self.raw_lo = min(self.raw_lo, float(good.min()))
            self.raw_hi = max(self.raw_hi, float(good.max()))
            if self.known:
                good = good * self.factor
                self.outside += int(
                    np.count_nonzero((good < self.known[0]) | (good > self.known[1]))
                )

    @property
    def valid(self) -> int:
        return self.n - self.missing - self.overload

    @property
    def lo(self) -> float:
        return min(self.raw_lo * self.factor, self.raw_hi * self.factor)  # a factor may be < 0

    @property
    def hi(self) -> float:
        return max(self.raw_lo * self.factor, self.raw_hi * self.factor)


@dataclass
class _LineFit:
    """Least squares of y (time from the first sample) over x (the sample index), merged chunk by
    chunk (Chan et al.'s pairwise update: no sum of squares of large numbers)."""

    n: int = 0
    mx: float = 0.0
    my: float = 0.0
    sxx: float = 0.0
    sxy: float = 0.0

    def add(self, x: np.ndarray, y: np.ndarray) -> None:
        m = len(x)
        if not m:
            return
        mx, my = float(x.mean()), float(y.mean())
        dx = x - mx
        sxx, sxy = float(dx @ dx), float(dx @ (y - my))
        n = self.n + m
        ex, ey = mx - self.mx, my - self.my
        self.sxx += sxx + ex * ex * self.n * m / n
        self.sxy += sxy + ex * ey * self.n * m / n
        self.mx += ex * m / n
        self.my += ey * m / n
        self.n = n

    @property
    def slope(self) -> float:
        return self.sxy / self.sxx if self.sxx > 0 else math.nan

    @property
    def intercept(self) -> float:
        return self.my - self.slope * self.mx


@dataclass
class _Summary:
    """The first pass over a source: rows, each channel's summary, the time axis' line."""

    rows: int = 0
    channels: dict[str, _ChannelSummary] = field(default_factory=dict)
    t0: float | None = None
    fit: _LineFit = field(default_factory=_LineFit)


def _time_values(
    source: Source, label: str, start: int, raw: np.ndarray, factor: float
) -> np.ndarray:
    """The time column's values in s; every one finite, or one line naming the first that is
    not."""
    bad = ~(np.abs(raw) < OVERLOAD)
    if bad.any():
        k = int(np.argmax(bad))
        what = "empty" if np.isnan(raw[k]) else f"{raw[k]:g}"
        raise ImportProblem(
            f"{source.path}: the time {label} is {what} at data row {start + k + 1}: "
            "every sample needs its time (or leave --time out and give --fs)"
        )
    return raw * factor


def _first_pass(
    source: Source, req: Request, known: Mapping[str, tuple[float, float] | None]
) -> _Summary:
    factors = channel_factors(req)
    summary = _Summary(
        channels={
            c.name: _ChannelSummary(source.labels[c.name], factors[c.name], known.get(c.name))
            for c in req.channels
        }
    )
    for start, chunk in source.chunks(progress=True):
        for c in req.channels:
            summary.channels[c.name].add(start, chunk[c.name])
        if req.time is not None:
            t = _time_values(source, source.labels["time"], start, chunk["time"], req.time.factor)
            if summary.t0 is None and len(t):
                summary.t0 = float(t[0])
            summary.fit.add(np.arange(start, start + len(t), dtype=np.float64), t - summary.t0)
        summary.rows = start + len(next(iter(chunk.values())))
    return summary


def channel_factors(req: Request) -> dict[str, float]:
    """Per channel, from the recorded column to the contract's unit: the unit's factor times
    the channel's --scale or --gain."""
    scales = req.scales or {}
    return {c.name: c.factor * scales.get(c.name, (1.0, ""))[0] for c in req.channels}


def _judge_channels(source: Source, summary: _Summary) -> list[str]:
    """Refuse a channel without a single value, overloaded beyond CLIP_LIMIT, or holding one
    value throughout as recorded (a column counted from 0 where 1 was meant, a DAQ's idle input:
    never a measurement, and an analysis would divide by its zero span; one that a factor
    collapses is the factor's fault, :func:`_resolution`'s); notes for the overloads stored as
    missing."""
    notes = []
    for name, s in summary.channels.items():
        if s.valid == 0:
            raise ImportProblem(
                f"{source.path}: {s.label} holds no value to import: of its {s.n} cells "
                f"{s.missing} are empty or NaN and {s.overload} are overloads (|v| ≥ {OVERLOAD:g}"
                " or ±inf)"
            )
        if s.overload > CLIP_LIMIT * s.n:
            row, value = s.first_overload
            raise ImportProblem(
                f"{source.path}: {s.label} is overloaded in {100 * s.overload / s.n:.3g} % of "
                f"its {s.n} samples (more than {100 * CLIP_LIMIT:g} %; |v| ≥ {OVERLOAD:g} or "
                f"±inf, first {value:g} at data row {row}): the DAQ's sentinel for a saturated "
                "input, too many to store as missing"
            )
        if s.raw_lo == s.raw_hi:
            where = f"all {s.n} {source.rows}" + (
                f" ({s.n - s.valid} empty or overloaded)" if s.valid < s.n else ""
            )
            hint = source.varying(name)
            raise ImportProblem(
                f"{source.path}: {s.label} holds one value ({s.raw_lo:.10g}) in {where}: "
                f"not a measurement" + (f"; {hint}" if hint else "")
            )
        if s.overload:
            row, value = s.first_overload
            notes.append(
                f"{name}: {s.overload} overload value(s) (|v| ≥ {OVERLOAD:g} or ±inf, first "
                f"{value:g} at data row {row}) stored as missing"
            )
    return notes


_PREFIXES = (
    (1e9, "G"),
    (1e6, "M"),
    (1e3, "k"),
    (1.0, ""),
    (1e-3, "m"),
    (1e-6, "µ"),
    (1e-9, "n"),
    (1e-12, "p"),
)


def _quantity(value: float, unit: str) -> str:
    """A magnitude with an SI prefix, three digits: 49.4 m, 150 kV, 0.02 nm."""
    for factor, prefix in _PREFIXES:
        if abs(value) >= factor or factor == _PREFIXES[-1][0]:
            return f"{value / factor:.3g} {prefix}{unit}"
    return f"{value:.3g} {unit}"  # pragma: no cover - the loop always returns


def _implausible(quantity: str, lo: float, hi: float) -> str | None:
    """What is wrong with data spanning [lo, hi] (contract unit) for a channel of the
    quantity, by PLAUSIBLE; None if nothing."""
    rule = PLAUSIBLE.get(quantity)
    if rule is None:
        return None
    peak, span = max(abs(lo), abs(hi)), hi - lo
    if peak > rule.peak:
        return (
            f"reaches {_quantity(peak, quantity)}: not {rule.what} "
            f"(at most {_quantity(rule.peak, quantity)})"
        )
    if span > rule.span[1]:
        return (
            f"spans {_quantity(span, quantity)}: not {rule.what} "
            f"(at most {_quantity(rule.span[1], quantity)})"
        )
    if span < rule.span[0]:
        return (
            f"spans {_quantity(span, quantity)}: less than any sensor tells from noise for "
            f"{rule.what} (at least {_quantity(rule.span[0], quantity)})"
        )
    return None


def _flag(req: Request, channel: str) -> str:
    """The --scale or --gain option that scaled the channel, as typed; "" if none did."""
    given = (req.scales or {}).get(channel)
    if given is None:
        return ""
    option = next(o for o, kind in SCALE_KINDS.items() if kind == given[1])
    exact = [text for text in (f"{given[0]:g}", repr(given[0])) if float(text) == given[0]]
    return f"{option} {channel}={min(exact, key=len)}"  # 20, not 20.0; 1e-320, not 9.99989e-321


def _plausibility(source: Source, req: Request, c: Column, s: _ChannelSummary) -> None:
    """Refuse a derived range no piezo bench records, naming the factor where one scaled the
    column (and what the column is without it), else the unit that would bring it in (the one
    of the quantity's family nearest PLAUSIBLE's typical magnitude), and --range."""
    problem = _implausible(c.quantity, s.lo, s.hi)
    if problem is None:
        return
    flag = _flag(req, c.name)
    if flag:
        lo, hi = sorted((s.raw_lo * c.factor, s.raw_hi * c.factor))
        unscaled = _implausible(c.quantity, lo, hi) is None
        without = f" (without the factor it spans {_quantity(hi - lo, c.quantity)})"
        raise ImportProblem(
            f"{flag}: {c.name} {problem}{without if unscaled else ''}; check the factor, or give "
            f"--range {c.name}=LOW,HIGH to keep it"
        )
    rule = PLAUSIBLE[c.quantity]
    units = UNITS[c.quantity]
    fits = []
    for unit, factor in units.items():
        if not unit.isascii() and any(units[u] == factor for u in units if u.isascii()):
            continue  # µm: typed as um
        k = factor / units[c.unit]
        lo, hi = sorted((s.lo * k, s.hi * k))
        if unit != c.unit and _implausible(c.quantity, lo, hi) is None:
            size = max(abs(lo), abs(hi)) if math.isinf(rule.span[1]) else hi - lo
            fits.append((abs(math.log10(size / rule.typical)), unit))
    suggestion = (
        f"if the column is in {min(fits)[1]} type {c.typed(min(fits)[1])}, or "
        if fits
        else "check the column and its unit, or "
    )
    raise ImportProblem(
        f"{source.path}: {c.name} {problem}; {suggestion}give --range {c.name}=LOW,HIGH to keep it"
    )


def _range_origin(
    manifest: Mapping[str, Any] | None, path: Path, req: Request, channel: str
) -> str:
    """Where a channel's range comes from, as a refusal names it (the manifest's wins: a --range
    must agree with it)."""
    if manifest is not None and channel in manifest["daq"]["ranges"]:
        return f"daq.ranges.{channel} in {path}"
    if channel in (req.ranges or {}):
        return f"--range {channel}"
    return DERIVED


def _resolution(
    source: Source,
    req: Request,
    c: Column,
    s: _ChannelSummary,
    rng: tuple[float, float],
    origin: str,
) -> None:
    """Refuse a channel whose values span fewer than MIN_CODES int16 codes of its range: packed,
    it would be a few steps (a factor of 1e-320 leaves U one code, all zeros). The span bounds
    the codes a channel can take whatever its samples, so this is judged before anything is
    written; a channel of few levels within a wider span (a two-level step drive) is what it
    recorded, and kept."""
    spec = channel_spec(c.name, *rng)
    codes = max(0.0, min(s.hi, rng[1]) - max(s.lo, rng[0])) / spec.scale_factor
    if codes >= MIN_CODES:
        return
    unit = CHANNEL_UNITS[c.name][0]
    problem = (
        f"{c.name} spans {codes:.3g} of the {2 * INT16_FULL} int16 codes of its range "
        f"[{rng[0]:g}, {rng[1]:g}] {unit} ({origin}), fewer than {MIN_CODES}: packed, it would be "
        "a few steps, not a measurement"
    )
    flag = _flag(req, c.name)
    if flag:
        raise ImportProblem(f"{flag}: {problem}; check the factor")
    if origin == DERIVED:  # a range fitted to the data spans this few only below its floor
        remedy = f"its values are too small to be in {c.unit}: check the column's unit"
    elif origin.startswith("--range"):
        remedy = "give a range that fits the data, or check the column's unit"
    else:
        remedy = "the dataset's range is too wide for this recording, or the column's unit wrong"
    raise ImportProblem(f"{source.path}: {s.label}: {problem}; {remedy}")


def _judge_time(source: Source, req: Request, summary: _Summary) -> tuple[float, str]:
    """fs [Hz] from the slope of the least-squares line through the time column, or as given, or
    as the file declares it (a TDMS channel's wf_increment), which must agree with a given one;
    and a note when the time axis did not start at 0. The residuals are checked in the second
    pass, before each chunk is written."""
    declared = source.declared_fs
    if req.time is None:
        fs = float(req.fs) if req.fs is not None else declared[0]
        if req.fs is not None and declared is not None:
            _agree(source, req.fs, f"--fs says {req.fs:.9g} Hz", declared)
        return fs, ""
    if summary.rows < 2:
        raise ImportProblem(f"{source.path}: the time column needs at least two values")
    slope = summary.fit.slope
    if not (math.isfinite(slope) and slope > 0):
        raise ImportProblem(f"{source.path}: the time column does not increase")
    fitted = float(f"{1 / slope:.9g}")  # 1/Δt's rounding noise off
    if req.fs is not None and not math.isclose(fitted, req.fs, rel_tol=1e-3):
        raise ImportProblem(
            f"{source.path}: the time column gives fs = {fitted:g} Hz, --fs says {req.fs:g} Hz"
        )
    if declared is not None:
        _agree(source, fitted, f"the time column gives fs = {fitted:.9g} Hz", declared)
    note = (
        f"time axis started at {summary.t0:.9g} s in the source; shifted to 0"
        if summary.t0 != 0
        else ""
    )
    return (float(req.fs) if req.fs is not None else fitted), note


def _agree(source: Source, value: float, given: str, declared: tuple[float, str]) -> None:
    """fs given (``value``, as ``given`` says it) and fs the file declares are one clock."""
    fs, where = declared
    if not math.isclose(value, fs, rel_tol=DECLARED_FS_RTOL):
        raise ImportProblem(
            f"{source.path}: {given}, {where} gives fs = {fs:.9g} Hz: one clock; leave out or "
            "correct the one that is wrong"
        )


def _check_time_residuals(source: Source, summary: _Summary, start: int, t: np.ndarray) -> None:
    fit = summary.fit
    k = np.arange(start, start + len(t), dtype=np.float64)
    off = np.abs(t - summary.t0 - (fit.intercept + fit.slope * k))
    if off.max(initial=0.0) > TIME_TOLERANCE * fit.slope:
        i = int(np.argmax(off))
        expected = summary.t0 + fit.intercept + fit.slope * k[i]
        raise ImportProblem(
            f"{source.path}: the time column is not sampled at a fixed rate: sample "
            f"{start + i} is at {t[i]:.9g} s, {off[i] / fit.slope:.2g} samples from "
            f"{expected:.9g} s on the least-squares line (fs = {1 / fit.slope:g} Hz; "
            f"{TIME_TOLERANCE:g} sample allowed): a gap or a restart: split the file, or "
            "export at a fixed rate"
        )


def derived_range(lo: float, hi: float) -> tuple[float, float]:
    """An ADC range for data spanning [lo, hi] without one: the span with RANGE_MARGIN free on
    each side, rounded outward to three significant digits."""
    span = max(hi - lo, MIN_RELATIVE_SPAN * max(abs(lo), abs(hi)), 1e-15)
    lo, hi = lo - RANGE_MARGIN * span, hi + RANGE_MARGIN * span
    e = math.floor(math.log10(hi - lo)) - 2
    return float(f"{math.floor(lo / 10.0**e)}e{e}"), float(
        f"{math.ceil(hi / 10.0**e)}e{e}"
    )  # exact decimals


# -- the import ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Request:
    """One import: the source file and how to read it, where the capture goes."""

    source: Path
    dataset: str
    experiment: str
    channels: tuple[Column, ...]
    time: Column | None = None
    fs: float | None = None
    ranges: Mapping[str, tuple[float, float]] | None = None
    attrs: Mapping[str, Any] | None = None
    sep: str | None = None
    header: bool = True
    model: str | None = None
    raw_dir: Path = Path("raw")
    lock_timeout: float = LOCK_TIMEOUT_S
    #: {channel: (factor, "gain" or "sensitivity")}: the recorded column times factor is the
    #: channel in its --channel unit (:func:`scalings`)
    scales: Mapping[str, tuple[float, str]] | None = None


def _check_request(req: Request) -> None:
    """Everything that needs no file: names, fs, channels, ranges, attributes."""
    check_dataset_name(req.dataset, "--dataset")
    check_experiment_name(req.experiment, "--experiment")
    for option, name in (("--dataset", req.dataset), ("--experiment", req.experiment)):
        if len(name) > MAX_NAME:
            raise ImportProblem(
                f"{option}: a name of {len(name)} characters: at most {MAX_NAME} (it becomes a "
                "file name)"
            )
    if req.fs is not None and not (isinstance(req.fs, (int, float)) and 0 < req.fs < math.inf):
        raise ImportProblem(f"--fs {req.fs}: the sampling rate must be a finite number > 0 Hz")
    if req.time is None and req.fs is None and req.source.suffix.lower() != ".tdms":
        raise ImportProblem(
            f"{req.source}: give the time column (--time) or the sampling rate (--fs)"
        )
    if not req.channels or len({c.name for c in req.channels}) != len(req.channels):
        raise ImportProblem(f"{req.source}: name each channel once (--channel)")
    slow = [c.name for c in req.channels if c.name in SLOW_CHANNELS]
    if slow:  # they run at their own rate on their own time axis (the contract's time_slow)
        raise ImportProblem(
            f"{req.source}: {slow[0]} is a slow (thermometer) channel, which the import "
            "does not take yet; leave it out"
        )
    for channel, given in (req.ranges or {}).items():
        lo, hi = (float(v) for v in given)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ImportProblem(f"--range {channel}={lo:g},{hi:g}: finite LOW < HIGH")
    channels = {c.name for c in req.channels}
    for channel, (factor, kind) in (req.scales or {}).items():
        options = [o for o, k in SCALE_KINDS.items() if k == kind]
        if not options:
            raise ImportProblem(
                f"{channel}: scale kind {kind!r}: one of {', '.join(SCALE_KINDS.values())}"
            )
        option = options[0]
        if channel not in channels:
            raise ImportProblem(
                f"{option} {channel}={factor:g}: no --channel {channel} to apply it to"
            )
        if not (math.isfinite(factor) and factor != 0):
            raise ImportProblem(f"{option} {channel}={factor:g}: a finite, nonzero factor")
    for key, value in (req.attrs or {}).items():
        if key in OWN_ATTRS or key.startswith(SCALE_ATTR_PREFIX):
            raise ImportProblem(
                f"--attr {key}: set by the import itself"
                + (" (--scale or --gain)" if key.startswith(SCALE_ATTR_PREFIX) else "")
            )
        if isinstance(value, float) and not math.isfinite(value):
            raise ImportProblem(f"--attr {key}={value}: not a finite number")


def run_import(req: Request) -> tuple[Path, Path]:
    """Write the capture and the manifest of one import; returns their paths. Every refusal is
    an ImportProblem (a file system error too: one line naming the file)."""
    try:
        return _run_import(req)
    except OSError as err:
        where = err.filename or req.source
        if err.errno == errno.ENAMETOOLONG:
            raise ImportProblem(f"{where}: file name too long") from None
        raise ImportProblem(f"{where}: {err.strerror or err}") from None


def _run_import(req: Request) -> tuple[Path, Path]:
    folder = Path(req.raw_dir) / req.dataset
    manifest_path, capture_path = folder / "dataset.yaml", folder / f"{req.experiment}.nc"
    _check_request(req)
    if capture_path.exists():
        raise _exists(capture_path)
    if not req.source.is_file():
        raise ImportProblem(
            f"{req.source}: {'not a file' if req.source.exists() else 'no such file'}"
        )
    source = open_source(req)
    before = req.source.stat()
    with dataset_lock(folder, req.lock_timeout):
        if capture_path.exists():  # made by an import that held the lock before us
            raise _exists(capture_path)
        manifest = _existing_manifest(manifest_path, req)
        known = _known_ranges(manifest, manifest_path, req)
        _check_scales(manifest, manifest_path, req)
        if manifest is not None and req.fs is not None:
            _check_fs(manifest, manifest_path, req, req.fs)
        summary = _first_pass(source, req, known)
        if summary.rows < MIN_SAMPLES:
            raise ImportProblem(
                f"{req.source}: {summary.rows} data row: a capture needs at least {MIN_SAMPLES} "
                "samples"
            )
        notes = _judge_channels(source, summary)
        fs, time_note = _judge_time(source, req, summary)
        if manifest is not None:
            _check_fs(manifest, manifest_path, req, fs)
        for c in req.channels:
            if known[c.name] is None:  # declared by neither --range nor the manifest
                _plausibility(source, req, c, summary.channels[c.name])
        ranges = {
            c: known[c] or derived_range(summary.channels[c].lo, summary.channels[c].hi)
            for c in summary.channels
        }
        origins = {c: _range_origin(manifest, manifest_path, req, c) for c in summary.channels}
        for channel, s in summary.channels.items():
            problem = clipping_problem(
                channel,
                s.outside,
                s.n,
                *ranges[channel],
                manifest_path,
                origins[channel],
                _flag(req, channel),
            )
            if problem:
                raise ImportProblem(f"{req.source}: {problem}")
        for c in req.channels:
            _resolution(source, req, c, summary.channels[c.name], ranges[c.name], origins[c.name])
        doc = _manifest_document(manifest, manifest_path, req, fs, ranges)
        note = "; ".join(filter(None, [source.note, time_note, *notes]))
        attrs = {
            "dataset": req.dataset,
            "experiment": req.experiment,
            "fs": fs,
            "source": "measured",
            "software_version": __version__,
            "imported_from": req.source.name,
            **({"import_note": note} if note else {}),
            **{
                f"{SCALE_ATTR_PREFIX}{attr}{channel}": value
                for channel, (factor, kind) in (req.scales or {}).items()
                for attr, value in (("", float(factor)), ("kind_", kind))
            },
            **dict(req.attrs or {}),
        }
        _write_capture(source, req, summary, capture_path, attrs, ranges, before)
        try:
            with atomic_path(manifest_path) as tmp:
                tmp.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
        except BaseException:
            capture_path.unlink(missing_ok=True)  # a capture its manifest does not list: none
            raise
    for line in (source.note, time_note, *notes):
        if line:
            LOG.warning("%s: %s", req.source, line)
    return capture_path, manifest_path


def open_source(req: Request) -> Source:
    """The reader of the request's file, by its suffix (a .mat file by its content: v7.3 is
    HDF5): every column located and its type checked, nothing read yet (but a v4–v7 .mat)."""
    columns = [*req.channels, *([req.time] if req.time else [])]
    suffix = req.source.suffix.lower()
    if suffix == ".tdms":
        source = TdmsSource(req.source, columns)
        if req.time is None and req.fs is None and source.declared_fs is None:
            raise ImportProblem(
                f"{req.source}: give the time column (--time) or the sampling rate (--fs): "
                "its channels declare no wf_increment"
            )
        return source
    if suffix == ".mat":
        if is_hdf5(req.source):
            return Mat73Source(req.source, columns)
        return MatSource(req.source, columns)
    return CsvSource(req.source, columns, req.sep, req.header)


def _exists(capture_path: Path) -> ImportProblem:
    return ImportProblem(
        f"{capture_path} exists: measured captures are never overwritten "
        "(remove it to import again)"
    )


def _write_capture(
    source: Source,
    req: Request,
    summary: _Summary,
    capture_path: Path,
    attrs: Mapping[str, Any],
    ranges: Mapping[str, tuple[float, float]],
    before: os.stat_result,
) -> None:
    """The second pass: each chunk (time checked against the line, overloads to NaN, units
    converted) into a hidden temporary, read back by CaptureWriter, then linked to its name if no
    file has it."""
    specs = [channel_spec(c, *ranges[c]) for c in summary.channels]
    factors = channel_factors(req)
    tmp = temporary_path(capture_path, hidden=True)
    try:
        rows = 0
        try:
            with CaptureWriter(tmp, attrs, specs, summary.rows) as writer:
                for start, chunk in source.chunks():
                    if req.time is not None:
                        _check_time_residuals(
                            source, summary, start, chunk["time"] * req.time.factor
                        )
                    n = len(next(iter(chunk.values())))
                    if start + n > summary.rows:
                        raise _changed(req.source)
                    writer.write(
                        {
                            c: np.where(np.abs(chunk[c]) < OVERLOAD, chunk[c], np.nan) * factors[c]
                            for c in summary.channels
                        }
                    )
                    rows = start + n
                after = req.source.stat()
                if rows != summary.rows or (after.st_size, after.st_mtime_ns) != (
                    before.st_size,
                    before.st_mtime_ns,
                ):
                    raise _changed(req.source)
        except ValueError as err:  # CaptureError and the writer's own: name the capture
            if isinstance(err, ImportProblem):
                raise
            raise ImportProblem(str(err).replace(str(tmp), str(capture_path))) from None
        try:  # the contract's own checks on open (packing bounds, the folding plan of --attr)
            open_capture(tmp).close()
        except CaptureError as err:
            problem = str(err).replace(str(tmp), str(capture_path))
            raise ImportProblem(
                f"{req.source}: the capture would break the contract: {problem}"
            ) from None
        _link(tmp, capture_path)
    finally:
        tmp.unlink(missing_ok=True)


def _changed(source: Path) -> ImportProblem:
    return ImportProblem(f"{source}: changed while it was imported: import it again when complete")


def _link(tmp: Path, path: Path) -> None:
    """``tmp`` under the name ``path`` only if no file has it (a hard link fails on an existing
    name, where a rename would replace it); where the file system has no hard links, a rename
    after a check, safe under the dataset's lock."""
    try:
        os.link(tmp, path)
    except FileExistsError:
        raise _exists(path) from None
    except OSError as err:
        if err.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EMLINK):
            raise
        if path.exists():
            raise _exists(path) from None
        os.replace(tmp, path)


def _existing_manifest(path: Path, req: Request) -> dict | None:
    """The dataset's manifest if it has one (a measured dataset without this experiment)."""
    if not path.exists():
        return None
    manifest = load_dataset(path.parent.parent, path.parent.name)
    if manifest["source"] != "measured":
        raise ImportProblem(
            f"{path}: source is {manifest['source']}: import into a measured dataset"
        )
    if req.experiment in manifest.get("experiments", []):
        raise ImportProblem(
            f"{path}: experiment {req.experiment} is listed already, without its capture"
        )
    return manifest


def _known_ranges(
    manifest: Mapping[str, Any] | None, path: Path, req: Request
) -> dict[str, tuple[float, float] | None]:
    """Each channel's range before the data are read: --range or the manifest's (they must
    agree), None where it is derived from the data."""
    have = manifest["daq"]["ranges"] if manifest else {}
    known: dict[str, tuple[float, float] | None] = {}
    for c in req.channels:
        given = (req.ranges or {}).get(c.name)
        if c.name in have and given and tuple(given) != tuple(have[c.name]):
            raise ImportProblem(
                f"--range {c.name}={given[0]:g},{given[1]:g} differs from daq.ranges.{c.name} "
                f"= {have[c.name]} in {path}"
            )
        value = have.get(c.name) or given
        known[c.name] = (float(value[0]), float(value[1])) if value else None
    return known


def declared_scale(manifest: Mapping[str, Any] | None, channel: str) -> tuple[float, str] | None:
    """A channel's (scale, scale_kind) as the manifest's sensors.<channel> declares it."""
    sensor = ((manifest or {}).get("sensors") or {}).get(channel) or {}
    return (float(sensor["scale"]), sensor["scale_kind"]) if "scale" in sensor else None


def _check_scales(manifest: Mapping[str, Any] | None, path: Path, req: Request) -> None:
    """A channel the dataset declares already keeps its scaling: the dataset's captures share
    one declaration (as they share a range); what to type to match it."""
    if manifest is None:
        return
    given = req.scales or {}
    for c in req.channels:
        declared = declared_scale(manifest, c.name)
        if c.name not in manifest["daq"]["channels"] and declared is None:
            continue  # new to the dataset: this import declares it
        mine = given.get(c.name)
        if (
            mine is not None
            and declared is not None
            and math.isclose(mine[0], declared[0], rel_tol=1e-12)
            and mine[1] == declared[1]
        ):
            continue
        if mine is None and declared is None:
            continue
        option = {k: o for o, k in SCALE_KINDS.items()}
        if declared is None:
            raise ImportProblem(
                f"{option[mine[1]]} {c.name}={mine[0]:g}: {path} declares {c.name} unscaled (no "
                f"sensors.{c.name}.scale), and the dataset's captures share one declaration: "
                "leave it out, or import into a new dataset"
            )
        typed = f"{option[declared[1]]} {c.name}={declared[0]:g}"
        what = f"{option[mine[1]]} {c.name}={mine[0]:g}" if mine else f"{c.name} unscaled"
        raise ImportProblem(
            f"{path}: sensors.{c.name} declares scale {declared[0]:g} ({declared[1]}), this "
            f"import {what}: the dataset's captures share one declaration: type {typed}, or "
            "import into a new dataset"
        )


def _check_fs(manifest: Mapping[str, Any], path: Path, req: Request, fs: float) -> None:
    if not math.isclose(manifest["daq"]["fs"], fs, rel_tol=1e-6):
        raise ImportProblem(
            f"{req.source}: fs = {fs:g} Hz, {path} declares daq.fs = {manifest['daq']['fs']:g} Hz"
        )


def _manifest_document(
    manifest: Mapping[str, Any] | None,
    path: Path,
    req: Request,
    fs: float,
    ranges: Mapping[str, tuple[float, float]],
) -> dict:
    """The dataset's manifest with this import in it (scaffolded, or the existing one updated: a
    channel it already has keeps its range; a scaled channel's factor and kind in
    sensors.<channel>), validated: nothing invalid is written."""
    if manifest is None:
        manifest = {
            "name": req.dataset,
            "description": f"Imported from {req.source.name} by selfsense import: "
            "describe the actuator here.",
            "source": "measured",
            **({"model": req.model} if req.model else {}),
            "daq": {"fs": fs, "channels": [], "ranges": {}},
            "protocols": [],
            "experiments": [],
        }
    manifest = dict(manifest)
    daq = manifest["daq"]
    for channel, (lo, hi) in ranges.items():
        daq["ranges"].setdefault(channel, [lo, hi])
        if channel not in daq["channels"]:
            daq["channels"].append(channel)
    for channel, (factor, kind) in (req.scales or {}).items():  # equal to any declared already
        sensors = manifest.setdefault("sensors", {})
        sensors[channel] = {**sensors.get(channel, {}), "scale": float(factor), "scale_kind": kind}
    manifest["experiments"] = [*manifest.get("experiments", []), req.experiment]
    doc = yaml.safe_load(yaml.safe_dump(manifest, sort_keys=False))  # as a reader will see it
    try:
        validate_document(doc, "dataset.schema.yaml", path)
    except ManifestError as err:
        raise ImportProblem(str(err)) from None
    return doc
