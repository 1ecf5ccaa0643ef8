"""What any recording of drive voltage and displacement gives, whatever protocol made it.

Stroke, the gain x/U (least squares and through the end points), the x–U loop's width and the
nonlinearity against the end-point chord, both in % of stroke, the creep after a step where the
capture holds one; with the current, the charge q = ∫I dt (thesis Eq 5.1's integrator), the
charge–position slope dx/dq (the inverse of Eq 5.3's a0) and the q–U slope and loop (the
capacitance seen by the drive). No thesis experiment names: a capture qualifies by its channels.

A capture is streamed once and reduced to block means, at most :data:`MAX_POINTS` of them, so
memory does not grow with its length: 10 min at 48 kHz keeps 1.7 kHz, where a 150 Hz loop
loses 1.3 % of its stroke to the averaging (the table states the rate each capture kept).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from selfsense.io.capture import CHARACTERISE_MIN_SAMPLES, DISPLACEMENT, open_capture
from selfsense.io.figures import (  # plt: after figures has chosen the Agg backend
    UF,
    UM,
    loop_grid,
    placeholder,
)
from selfsense.methods.metrics import branch_gap, branch_means, direction

#: a capture is reduced to at most this many block means
MAX_POINTS = 1 << 20
#: end points of the chord and of the end-point gain: samples within this fraction of the
#: voltage range from its extremes
END_FRACTION = 0.02
#: a drive counts as held within this fraction of its range of the final value
HOLD_FRACTION = 0.02
#: smoothing of the drive before its direction is taken: this fraction of a drive period
SMOOTH_PERIOD_FRACTION = 1 / 200


def displacement_channel(channels: Iterable[str]) -> str | None:
    """The capture's displacement channel (the laser where both are recorded), or None."""
    present = set(channels)
    return next((c for c in DISPLACEMENT if c in present), None)


@dataclass(frozen=True)
class Reduced:
    """A capture as block means: rate [Hz], and per channel an array in SI units."""

    fs: float
    data: dict[str, np.ndarray]


def block_means(
    chunks: Iterable[tuple[int, Mapping[str, np.ndarray]]], fs: float, factor: int
) -> Reduced:
    """Block means of ``factor`` samples over chunks whose length is a multiple of ``factor``
    (the last one may be shorter: its tail block is the mean of what is left)."""
    parts: dict[str, list[np.ndarray]] = {}
    for _, chunk in chunks:
        for name, values in chunk.items():
            full = len(values) // factor * factor
            means = values[:full].reshape(-1, factor).mean(axis=1)
            if full < len(values):
                means = np.append(means, values[full:].mean())
            parts.setdefault(name, []).append(means)
    return Reduced(fs / factor, {k: np.concatenate(v) for k, v in parts.items()})


def reduction_factor(n: int) -> int:
    """Samples per block so that n samples give at most MAX_POINTS block means."""
    return max(1, -(-int(n) // MAX_POINTS))


def rising(u: np.ndarray) -> np.ndarray:
    """+1 where the drive rises, −1 where it falls, taken on the drive smoothed over
    SMOOTH_PERIOD_FRACTION of its dominant period (noise would flip it sample by sample)."""
    spectrum = np.abs(np.fft.rfft(u - u.mean()))
    k = int(np.argmax(spectrum[1:])) + 1 if len(spectrum) > 1 else 1
    width = max(1, int(round(len(u) / k * SMOOTH_PERIOD_FRACTION)))
    smooth = np.convolve(u, np.ones(width) / width, mode="same") if width > 1 else u
    return direction(smooth)


def _slope(u: np.ndarray, y: np.ndarray) -> float:
    """The least-squares slope of y on u, cov(u, y)/var(u): the straight-line fit's, without
    polyfit's Vandermonde solve (half of a capture's analysis at a million points)."""
    c = np.cov(u, y)
    return float(c[0, 1] / c[0, 0])


def _ends(u: np.ndarray, y: np.ndarray) -> tuple[float, float, float, float]:
    """(u_low, y_low, u_high, y_high): the means near the voltage's two extremes."""
    lo, hi = np.nanmin(u), np.nanmax(u)
    near_lo, near_hi = u <= lo + END_FRACTION * (hi - lo), u >= hi - END_FRACTION * (hi - lo)
    return (
        float(u[near_lo].mean()),
        float(y[near_lo].mean()),
        float(u[near_hi].mean()),
        float(y[near_hi].mean()),
    )


def _has_loop(up: np.ndarray) -> bool:
    return min(np.count_nonzero(up > 0), np.count_nonzero(up < 0)) >= 16


def loop_measures(u: np.ndarray, x: np.ndarray, up: np.ndarray) -> dict[str, float]:
    """Stroke [m], gains [m/V], loop width and nonlinearity [% of stroke] of an x–U record."""
    stroke = float(np.ptp(x))
    u_lo, x_lo, u_hi, x_hi = _ends(u, x)
    end_gain = (x_hi - x_lo) / (u_hi - u_lo)
    out = {
        "stroke": stroke,
        "gain_ls": _slope(u, x),
        "gain_end": end_gain,
        "loop_width": np.nan,
        "nonlinearity": np.nan,
    }
    if _has_loop(up):
        # the chord is taken off sample by sample: a bin's samples do not sit at its centre
        _, rise, fall = branch_means(u, x - (x_lo + end_gain * (u - u_lo)), up)
        out["loop_width"] = 100 * branch_gap(u, x, up) / stroke
        out["nonlinearity"] = 100 * float(np.nanmax(np.abs(0.5 * (rise + fall)))) / stroke
    return out


def creep_after_step(
    t: np.ndarray, u: np.ndarray, x: np.ndarray, settle_s: float, min_hold_s: float
) -> dict[str, float]:
    """Creep of a held step (the thesis's Chapter 5 creep run): x at the end of the final hold
    minus x ``settle_s`` after the step, and as % of the step's displacement. NaN when the
    capture does not end in a hold of at least ``min_hold_s`` after a step of ≥ 20 % of its
    range."""
    none = {"creep": np.nan, "creep_percent": np.nan, "hold_s": np.nan}
    span = float(np.ptp(u))
    tail = max(1, len(u) // 100)
    final = float(np.median(u[-tail:]))
    moving = np.flatnonzero(np.abs(u - final) > HOLD_FRACTION * span)
    if span == 0 or moving.size == 0:
        return none
    start = moving[-1] + 1
    before = float(u[max(0, start - tail) : start].mean())
    hold_s = float(t[-1] - t[start]) if start < len(t) else 0.0
    if hold_s < max(min_hold_s, settle_s) or abs(final - before) < 0.2 * span:
        return none
    settled = int(np.searchsorted(t, t[start] + settle_s))
    x0 = float(x[settled])
    step = x0 - float(x[max(0, start - tail) : start].mean())
    creep = float(x[-tail:].mean()) - x0
    return {
        "creep": creep,
        "creep_percent": 100 * creep / abs(step) if step else np.nan,
        "hold_s": hold_s,
    }


def charge(current: np.ndarray, fs: float) -> np.ndarray:
    """q = ∫(I − Ī) dt [C] (Eq 5.1; the mean removed as the probe's offset, which over a periodic
    drive is what it is)."""
    return np.cumsum(current - current.mean()) / fs


def charge_measures(
    u: np.ndarray, x: np.ndarray, q: np.ndarray, up: np.ndarray
) -> dict[str, float]:
    """dx/dq [m/C] and the q–U slope [F] by least squares, the q–U loop width [% of charge
    range]."""
    out = {"dx_dq": _slope(q, x), "capacitance": _slope(u, q), "q_loop_width": np.nan}
    if _has_loop(up):
        out["q_loop_width"] = 100 * branch_gap(u, q, up) / float(np.ptp(q))
    return out


#: the table's columns: (heading, key of the measures, scale from SI)
COLUMNS = (
    ("stroke [µm]", "stroke", UM),
    ("gain (least squares) [µm/V]", "gain_ls", UM),
    ("gain (end points) [µm/V]", "gain_end", UM),
    ("x–U loop width [% of stroke]", "loop_width", 1.0),
    ("nonlinearity vs end-point chord [% of stroke]", "nonlinearity", 1.0),
    ("creep after step [µm]", "creep", UM),
    ("creep [% of step]", "creep_percent", 1.0),
    ("hold [s]", "hold_s", 1.0),
    ("dx/dq [µm/µC]", "dx_dq", 1.0),
    ("q–U slope [µF]", "capacitance", UF),
    ("q–U loop width [% of charge range]", "q_loop_width", 1.0),
)


def characterise(
    reduced: Reduced, x_channel: str, settle_s: float, min_hold_s: float
) -> dict[str, float]:
    """Every measure of one reduced capture, in SI units (see :data:`COLUMNS`)."""
    d = reduced.data
    ok = np.isfinite(d["U"]) & np.isfinite(d[x_channel])
    t = np.arange(len(ok))[ok] / reduced.fs
    u, x = d["U"][ok], d[x_channel][ok]
    up = rising(u)
    out = loop_measures(u, x, up) | creep_after_step(t, u, x, settle_s, min_hold_s)
    if "I" in d:
        q = charge(np.nan_to_num(d["I"]), reduced.fs)[ok]
        out |= charge_measures(u, x, q, up)
    return out


#: the dataset table's columns, in order
TABLE_COLUMNS = [
    "experiment",
    "displacement channel",
    "rate used [Hz]",
    *(c[0] for c in COLUMNS),
    "note",
]


def row(
    experiment: str,
    measures: Mapping[str, float],
    x_channel: str | None,
    rate: float | None,
    note: str = "",
) -> dict:
    """One row of the dataset's table (µm, µF; empty where the capture does not allow it)."""
    values = {
        heading: measures[key] * scale if key in measures else np.nan
        for heading, key, scale in COLUMNS
    }
    return (
        {"experiment": experiment, "displacement channel": x_channel or "", "rate used [Hz]": rate}
        | values
        | {"note": note}
    )


def instruments(manifest: Mapping) -> list[dict]:
    """The manifest's description of the actuator and of each channel's sensor, one row per
    property, for the report (values as the manifest gives them, units in the key's name)."""
    rows = [
        {"item": "actuator", "property": k, "value": str(v)}
        for k, v in manifest.get("actuator", {}).items()
    ]
    for channel in manifest["daq"]["channels"]:
        sensor = manifest.get("sensors", {}).get(channel, {})
        item = f"channel {channel}"
        rows += [
            {
                "item": item,
                "property": "ADC range",
                "value": str(manifest["daq"]["ranges"][channel]),
            }
        ]
        rows += [{"item": item, "property": k, "value": str(v)} for k, v in sensor.items()]
    return rows


@dataclass(frozen=True)
class LoopPanels:
    """One capture's loops as drawn: (x, y, xlabel, ylabel) per panel, thinned to the figure's
    resolution so that a dataset's worth of them fits in memory."""

    name: str
    panels: tuple[tuple[np.ndarray, np.ndarray, str, str], ...]


def loop_panels(reduced: Reduced, x_channel: str, name: str, max_points: int = 20000) -> LoopPanels:
    """x–U loop, and beside it the q–U loop where the capture has the current."""
    d = reduced.data
    step = max(1, len(d["U"]) // max_points)  # the figure needs no more points than pixels
    u = d["U"][::step]
    panels = [(u, d[x_channel][::step] * UM, "U [V]", f"{x_channel} [µm]")]
    if "I" in d:
        panels.append(
            (u, charge(np.nan_to_num(d["I"]), reduced.fs)[::step] * UF, "U [V]", "q = ∫I dt [µC]")
        )
    return LoopPanels(name, tuple(panels))


def characterise_capture(
    path, settle_s: float, min_hold_s: float
) -> tuple[dict, LoopPanels | None]:
    """One capture streamed once: its table row, and its loops (None without U or a
    displacement)."""
    name = Path(path).stem
    with open_capture(path) as cap:
        x = displacement_channel(cap.channels)
        if "U" not in cap.channels or x is None:
            return row(
                name, {}, x, None, "no drive voltage U and displacement in this capture"
            ), None
        cap.require_samples(CHARACTERISE_MIN_SAMPLES, "characterise (one drive cycle)")
        names = ["U", x] + (["I"] if "I" in cap.channels else [])
        factor = reduction_factor(cap.n)
        reduced = block_means(cap.iter_chunks(names, factor * (1 << 14)), cap.fs, factor)
        cap.require_varying(["U"], "characterise (stroke and gain per volt)")
    return row(name, characterise(reduced, x, settle_s, min_hold_s), x, reduced.fs), loop_panels(
        reduced, x, name
    )


def loop_page(captures: Sequence[LoopPanels], title: str):
    """One page of the dataset's loop figure, a row per capture; a page that says so when none of
    its captures has U and a displacement."""
    if not captures:
        return placeholder(title, "no capture records a drive voltage U and a displacement")
    return loop_grid([(c.name, c.panels) for c in captures], title)
