"""What any recording of drive voltage and displacement gives, whatever protocol made it.

Stroke, the gain x/U (least squares and through the end points), the x–U loop's width and the
nonlinearity against the end-point chord, both in % of stroke, the creep after a step where the
capture holds one; with the current, the charge q = ∫I dt (thesis Eq 5.1's integrator), the
charge–position slope dx/dq (the inverse of Eq 5.3's a0) and the q–U slope and loop (the
capacitance seen by the drive). No thesis experiment names: a capture qualifies by its channels.

Measured on cycles, not samples (:mod:`selfsense.methods.cycles`): a capture with a periodic
drive is cut into the drive's cycles, the warm-up (the capture's ``warmup_s``, else detected from
x), minor loops (amplitude ramps), pauses and the unfinished cycle at the end are dropped, and the
stroke and loop width are those of each steady full-amplitude cycle, reported as the median over
them with their least and largest; the gains, nonlinearity and the charge measures are taken on
those cycles together. A capture without a periodic drive (steps, an arbitrary waveform) is
measured over all its samples after the warm-up, and its note says so. The creep after a step is
taken on the whole capture.

A capture is streamed once and reduced to block means, at most :data:`MAX_POINTS` of them, so
memory does not grow with its length: 10 min at 48 kHz keeps 1.7 kHz, where a 150 Hz loop
loses 1.3 % of its stroke to the averaging (the table states the rate each capture kept). A cycle
of fewer than :data:`MIN_CYCLE_SAMPLES` block means is too coarse to be measured alone: the
stroke and loop width are then those of the used cycles together (said in the note).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from selfsense.chapters.figures import (  # plt: after figures has chosen the Agg backend
    UF,
    UM,
    loop_grid,
    placeholder,
)
from selfsense.io.capture import CHARACTERISE_MIN_SAMPLES, DISPLACEMENT, open_capture
from selfsense.methods.cycles import (
    MIN_CYCLE_SAMPLES,
    REASONS,
    RULES,
    CycleRules,
    Cycles,
    cycle_loops,
    find_cycles,
    loop_bins,
    rising_with_period,
)
from selfsense.methods.cycles import filled as filled_drive
from selfsense.methods.hysteresis import MAX_ORDER, ORDER_TOLERANCE, fit_maxwell_slip
from selfsense.methods.metrics import branch_gap, branch_means

#: a capture is reduced to at most this many block means
MAX_POINTS = 1 << 20
#: end points of the chord and of the end-point gain: samples within this fraction of the
#: voltage range from its extremes
END_FRACTION = 0.02
#: a drive counts as held within this fraction of its range of the final value
HOLD_FRACTION = 0.02
#: the minor loops' amplitudes listed in the table: at most this many
MAX_LISTED = 24


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
    return rising_with_period(u, len(u) / k)


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


def loop_measures(
    u: np.ndarray, x: np.ndarray, up: np.ndarray, width: bool = True
) -> dict[str, float]:
    """Stroke [m], gains [m/V], loop width and nonlinearity [% of stroke] of an x–U record (the
    loop width left NaN unless ``width``: the cycles' own replace it)."""
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
        out["loop_width"] = 100 * branch_gap(u, x, up) / stroke if width else np.nan
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


def steady_cycles(
    reduced: Reduced,
    x_channel: str,
    period_s: float | None = None,
    warmup_s: float | None = None,
    rules: CycleRules = RULES,
) -> Cycles:
    """The cycles of a reduced capture (:func:`reduce_capture`): ``.used`` the steady
    full-amplitude ones as slices of ``reduced.data[...]``, in time order, ``.dropped`` the rest
    with their reasons, ``.period_s`` and its ``.source`` ("drive" or "protocol"). ``period_s``:
    the drive's period if the protocol gives it (else found from U); ``warmup_s``: the capture's
    attribute (None: detected from x). See :mod:`selfsense.methods.cycles`."""
    d = reduced.data
    return find_cycles(d["U"], reduced.fs, d[x_channel], period_s, warmup_s, rules)


def _listed(values: Sequence[float]) -> str:
    shown = ", ".join(f"{v:.3g}" for v in values[:MAX_LISTED])
    more = len(values) - MAX_LISTED
    return shown + (f", … ({more} more)" if more > 0 else "")


def cycle_measures(
    u: np.ndarray, x: np.ndarray, up: np.ndarray, cycles: Cycles
) -> tuple[dict[str, float], str]:
    """The stroke [m] and loop width [% of stroke] of each used cycle: their median, least and
    largest; and a note when the cycles are too coarse to be measured alone (then pooled)."""
    lengths = [c.stop - c.start for c in cycles.used]
    per_cycle = float(np.median(lengths))
    if per_cycle < MIN_CYCLE_SAMPLES:
        used = cycles.mask() & np.isfinite(x) & np.isfinite(u)
        uu, xx, rise = u[used], x[used], up[used]
        out = {"stroke": float(np.ptp(xx))}
        if _has_loop(rise):
            # the chord taken off sample by sample first (as cycle_loops does): same gap, and the
            # bins' samples, off their centres, differ by the loop's curvature only
            u_lo, x_lo, u_hi, x_hi = _ends(uu, xx)
            chord = x_lo + (x_hi - x_lo) / (u_hi - u_lo) * (uu - u_lo)
            out["loop_width"] = 100 * branch_gap(uu, xx - chord, rise) / out["stroke"]
        note = f"{per_cycle:.0f} samples a cycle: stroke and loop width of the used cycles together"
        return out, note
    bins = loop_bins(per_cycle)
    strokes, gaps = cycle_loops(u, x, up, cycles.used, bins)
    widths = 100 * gaps / strokes
    out = {}
    for key, values in (("stroke", strokes), ("loop_width", widths)):
        finite = values[np.isfinite(values)]
        if finite.size:
            out |= {
                key: float(np.median(finite)),
                f"{key}_min": float(finite.min()),
                f"{key}_max": float(finite.max()),
            }
    return out, ""


def cycle_facts(cycles: Cycles) -> dict:
    """The cycle analysis's columns: period, warm-up, cycles used and dropped per reason, the
    used ones flagged as outliers, x's drift through the used cycles [m], the full and minor
    cycles' drive amplitudes."""
    counts = cycles.counts()
    source = cycles.warmup_source or (
        "none detected" if cycles.periodic else "none (no cycles to detect one on)"
    )
    out = {"warmup_s": cycles.warmup_s, "warmup_from": source}
    if not cycles.periodic:
        return out | {"period_from": "no periodic drive"}
    return out | {
        "period_s": cycles.period_s,
        "period_from": cycles.source,
        "amplitude": cycles.amplitude,
        "cycles_used": counts["used"],
        **{f"dropped_{r}": counts[r] for r in REASONS},
        "cycles_flagged": len(cycles.outliers),
        "drift": cycles.drift,
        "minor_amplitudes": _listed(cycles.minor_amplitudes),
    }


def characterise(
    reduced: Reduced,
    x_channel: str,
    settle_s: float,
    min_hold_s: float,
    cycles: Cycles | None = None,
) -> dict:
    """Every measure of one reduced capture, in SI units (see :data:`COLUMNS`), measured on its
    steady full-amplitude cycles (``cycles``: :func:`steady_cycles`, found here when not given),
    and a ``note``: the cycles used and dropped and why, or what was measured instead."""
    d = reduced.data
    if cycles is None:
        cycles = steady_cycles(reduced, x_channel)
    ok = np.isfinite(d["U"]) & np.isfinite(d[x_channel])
    t = np.arange(len(ok))[ok] / reduced.fs
    u_all, x_all = d["U"], d[x_channel]
    out: dict = creep_after_step(t, u_all[ok], x_all[ok], settle_s, min_hold_s)
    notes = [cycles.summary(UM, "µm")] if cycles.periodic else []  # the table's units
    if cycles.periodic and cycles.used:
        u = filled_drive(u_all)
        up = rising_with_period(u, cycles.period_s * reduced.fs)
        used = cycles.mask() & ok
        measured, note = cycle_measures(u, x_all, up, cycles)
        out |= loop_measures(u[used], x_all[used], up[used], width=False) | measured
        notes += [note] if note else []
        if cycles.minor_amplitudes:
            notes.append(
                f"{len(cycles.minor_amplitudes)} minor loops (drive amplitude "
                f"{min(cycles.minor_amplitudes):.3g}–{max(cycles.minor_amplitudes):.3g})"
            )
    else:
        used = ok.copy()
        used[: cycles.after_warmup().start] = False
        up = np.zeros(len(ok), int)
        if np.count_nonzero(used) >= CHARACTERISE_MIN_SAMPLES:
            up[used] = rising(u_all[used])
            out |= loop_measures(u_all[used], x_all[used], up[used])
        notes.append(
            (cycles.note or "no steady full-amplitude cycle")
            + ": stroke, gains and loop over all samples"
            + (f" after the {cycles.warmup_s:g} s warm-up" if cycles.warmup_s else "")
        )
    out |= cycle_facts(cycles)
    if "I" in d and np.count_nonzero(used) >= CHARACTERISE_MIN_SAMPLES:
        q = charge(np.nan_to_num(d["I"]), reduced.fs)
        out |= charge_measures(u_all[used], x_all[used], q[used], up[used])
    out["note"] = "; ".join(n for n in notes if n)
    return out


#: the table's columns: (heading, key of the measures, scale from SI or None for a text, the
#: channels whose declared scaling the heading shows: "x" the capture's displacement channel)
COLUMNS = (
    ("stroke [µm]", "stroke", UM, ("x",)),
    ("gain (least squares) [µm/V]", "gain_ls", UM, ("x", "U")),
    ("gain (end points) [µm/V]", "gain_end", UM, ("x", "U")),
    ("x–U loop width [% of stroke]", "loop_width", 1.0, ()),
    ("nonlinearity vs end-point chord [% of stroke]", "nonlinearity", 1.0, ()),
    ("creep after step [µm]", "creep", UM, ("x",)),
    ("creep [% of step]", "creep_percent", 1.0, ()),
    ("hold [s]", "hold_s", 1.0, ()),
    ("dx/dq [µm/µC]", "dx_dq", 1.0, ("x", "I")),
    ("q–U slope [µF]", "capacitance", UF, ("I", "U")),
    ("q–U loop width [% of charge range]", "q_loop_width", 1.0, ()),
    ("stroke, least cycle [µm]", "stroke_min", UM, ("x",)),
    ("stroke, largest cycle [µm]", "stroke_max", UM, ("x",)),
    ("x–U loop width, least cycle [% of stroke]", "loop_width_min", 1.0, ()),
    ("x–U loop width, largest cycle [% of stroke]", "loop_width_max", 1.0, ()),
    ("drive period [s]", "period_s", 1.0, ()),
    ("period from", "period_from", None, ()),
    ("drive amplitude, used cycles [V]", "amplitude", 1.0, ("U",)),
    ("warm-up [s]", "warmup_s", 1.0, ()),
    ("warm-up from", "warmup_from", None, ()),
    ("cycles used", "cycles_used", 1.0, ()),
    *((f"cycles dropped: {r}", f"dropped_{r}", 1.0, ()) for r in REASONS),
    ("cycles flagged: far outside the others (not in the model's fit)", "cycles_flagged", 1.0, ()),
    ("x drift through the used cycles [µm]", "drift", UM, ("x",)),
    ("minor loops' drive amplitudes [V]", "minor_amplitudes", None, ("U",)),
    ("hysteresis model: elements", "model_order", 1.0, ()),
    ("hysteresis model: cycles fit / chose the order / tested", "model_cycles", None, ()),
    ("hysteresis model: x from U, tested cycles, rms [% of stroke]", "forward_rms", 1.0, ()),
    ("hysteresis model: x from U, tested cycles, max [% of stroke]", "forward_max", 1.0, ()),
    ("feedforward (model inverse), tested cycles, rms [% of stroke]", "feedforward_rms", 1.0, ()),
    ("feedforward (model inverse), tested cycles, max [% of stroke]", "feedforward_max", 1.0, ()),
)

#: the dataset table's columns, in order (without the channels' declared scalings)
TABLE_COLUMNS = [
    "experiment",
    "displacement channel",
    "rate used [Hz]",
    *(c[0] for c in COLUMNS),
    "note",
]

#: the dataset's hysteresis-model table: a row per parameter of each capture's model
MODEL_COLUMNS = ["experiment", "parameter", "value", "unit"]


def heading(
    base: str,
    channels: Sequence[str],
    x_channel: str | None,
    scalings: Mapping[str, str] | None,
) -> str:
    """A column's heading with the declared scaling of the channels it depends on, inside its unit
    bracket: "gain (least squares) [µm/V; U = 20 × logged (gain)]"."""
    names = [x_channel if c == "x" else c for c in channels]
    parts = [f"{c} = {scalings[c]}" for c in names if c and scalings and c in scalings]
    if not parts or not base.endswith("]"):
        return base
    return f"{base[:-1]}; {'; '.join(parts)}]"


def plain_heading(text: str) -> str:
    """A heading without the channels' scalings :func:`heading` put in (the heading of
    :data:`TABLE_COLUMNS`)."""
    if text.endswith("]") and "; " in text and " [" in text:
        unit_start = text.rindex(" [")
        return text[: text.index("; ", unit_start)] + "]"
    return text


def axis_label(label: str, channel: str | None, scalings: Mapping[str, str] | None) -> str:
    """An axis label with the channel's declared scaling after it: "U [V] (20 × logged)"."""
    if channel and scalings and channel in scalings:
        return f"{label} ({scalings[channel]})"
    return label


def table_columns(rows: Sequence[Mapping]) -> list[str]:
    """The table's columns for its rows: :data:`TABLE_COLUMNS`, each as the rows head it (with
    their channels' scalings; a column twice when captures declare different ones)."""
    present = list(dict.fromkeys(k for r in rows for k in r))
    out = []
    for base in TABLE_COLUMNS:
        out += [k for k in present if plain_heading(k) == base] or [base]
    return out


def row(
    experiment: str,
    measures: Mapping[str, float],
    x_channel: str | None,
    rate: float | None,
    note: str = "",
    scalings: Mapping[str, str] | None = None,
) -> dict:
    """One row of the dataset's table (µm, µF; empty where the capture does not allow it),
    headed with the channels' declared ``scalings`` (channel → label) where given."""
    values = {}
    for base, key, scale, channels in COLUMNS:
        value = measures.get(key, "" if scale is None else np.nan)
        if scale is not None and value is not None:
            value = float(value) * scale
        values[heading(base, channels, x_channel, scalings)] = value
    return (
        {"experiment": experiment, "displacement channel": x_channel or "", "rate used [Hz]": rate}
        | values
        | {"note": "; ".join(n for n in (note, measures.get("note", "")) if n)}
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


#: the loop figure's colour of each kind of cycle; the used ones are drawn first, the others on top
#: of them in this order (a dropped cycle hidden under the used ones cannot show why it was dropped)
GROUP_COLOURS = {
    "used": "C0",
    "minor": "C2",
    "irregular": "C4",
    "pause": "C8",
    "partial": "0.55",
    "warm-up": "C1",
    "flagged": "C3",
}
#: the legend's words for a kind of cycle
GROUP_LABELS = {"flagged": "used, far outside the others (not in the model's fit)"}


def cycle_groups(cycles: Cycles, step: int = 1) -> dict[str, np.ndarray]:
    """The samples (every ``step``-th) of each kind of cycle: "used", each reason a piece was
    dropped for and "flagged" (used, far outside the others), in GROUP_COLOURS's order, only the
    kinds present. Without a periodic drive: "used" every sample after the warm-up, "warm-up"
    the samples before it."""
    n = cycles.n
    if not cycles.periodic:
        used = np.ones(n, bool)
        used[: cycles.after_warmup().start] = False
        out = {"used": used, "warm-up": ~used}
    else:
        kinds = {k: [] for k in GROUP_COLOURS}
        kinds["used"] = cycles.used
        kinds["flagged"] = cycles.outliers
        for piece, reason in cycles.dropped:
            kinds[reason].append(piece)
        out = {}
        for kind, pieces in kinds.items():
            edges = np.zeros(n + 1, np.int64)
            np.add.at(edges, [s.start for s in pieces], 1)
            np.add.at(edges, [s.stop for s in pieces], -1)
            out[kind] = np.cumsum(edges[:-1]) > 0
    return {k: v[::step] for k, v in out.items() if v.any()}


@dataclass(frozen=True)
class LoopPanels:
    """One capture's loops as drawn: (x, y, xlabel, ylabel, groups) per panel, thinned to the
    figure's resolution so that a dataset's worth of them fits in memory; ``groups``: None (all
    samples alike) or {legend: (mask, colour)}, drawn in order, the first (the used cycles) at
    the bottom and each dropped kind on top of it in its own colour."""

    name: str
    panels: tuple[tuple[np.ndarray, np.ndarray, str, str, dict | None], ...]


def loop_panels(
    reduced: Reduced,
    x_channel: str,
    name: str,
    max_points: int = 20000,
    cycles: Cycles | None = None,
    scalings: Mapping[str, str] | None = None,
) -> LoopPanels:
    """x–U loop, and beside it the q–U loop where the capture has the current; with ``cycles``
    the dropped ones drawn on top of the used in their own colours with a legend and the title
    counting them, with ``scalings`` the channels' declared scaling on the axes."""
    d = reduced.data
    step = max(1, len(d["U"]) // max_points)  # the figure needs no more points than pixels
    u = d["U"][::step]
    groups = None
    if cycles is not None:
        counts = cycles.counts() | {"flagged": len(cycles.outliers)}
        groups = {}
        for kind, mask in cycle_groups(cycles, step).items():
            label = GROUP_LABELS.get(kind, kind)
            groups[f"{label} ({counts[kind]})" if cycles.periodic else label] = (
                mask,
                GROUP_COLOURS[kind],
            )
    if cycles is not None and cycles.periodic:
        name = f"{name}: {len(cycles.used)} cycles used, {len(cycles.dropped)} dropped"
    elif cycles is not None:
        name = f"{name}: no periodic drive, all samples" + (
            f" after the {cycles.warmup_s:g} s warm-up" if cycles.warmup_s else ""
        )
    u_label = axis_label("U [V]", "U", scalings)
    x_label = axis_label(f"{x_channel} [µm]", x_channel, scalings)
    panels = [(u, d[x_channel][::step] * UM, u_label, x_label, groups)]
    if "I" in d:
        q = charge(np.nan_to_num(d["I"]), reduced.fs)[::step] * UF
        panels.append((u, q, u_label, axis_label("q = ∫I dt [µC]", "I", scalings), groups))
    return LoopPanels(name, tuple(panels))


def reduce_capture(path) -> tuple[Reduced | None, str | None, float | None]:
    """A capture streamed once into block means (at most :data:`MAX_POINTS`) of U, its
    displacement and the current where recorded: (reduced, displacement channel, the capture's
    ``warmup_s`` or None when it does not give one); reduced is None without U or a
    displacement."""
    with open_capture(path) as cap:
        x = displacement_channel(cap.channels)
        if "U" not in cap.channels or x is None:
            return None, x, None
        cap.require_samples(CHARACTERISE_MIN_SAMPLES, "characterise (one drive cycle)")
        names = ["U", x] + (["I"] if "I" in cap.channels else [])
        factor = reduction_factor(cap.n)
        reduced = block_means(cap.iter_chunks(names, factor * (1 << 14)), cap.fs, factor)
        cap.require_varying(["U"], "characterise (stroke and gain per volt)")
        warmup = cap.attrs.get("warmup_s")
    return reduced, x, None if warmup is None else float(warmup)


def hysteresis_model(
    reduced: Reduced,
    x_channel: str,
    cycles: Cycles,
    max_order: int = MAX_ORDER,
    order_tolerance: float = ORDER_TOLERANCE,
    scalings: Mapping[str, str] | None = None,
) -> tuple[dict, list[dict]]:
    """The capture's own Maxwell model (:func:`selfsense.methods.hysteresis.fit_maxwell_slip`) on
    its steady full-amplitude cycles less those flagged far outside the others (``cycles.fitted``):
    its measures for the table (the errors on the cycles neither
    the fit nor the choice of order saw) and its parameters, one record each (the validation
    cycles' rms voltage error of every order tried among them, the rule's evidence), each unit
    with the declared ``scalings`` of its channels. Nothing without a steady cycle or with a gap (a
    missing sample) in the record."""
    u, x = reduced.data["U"], reduced.data[x_channel]
    if (
        not (cycles.periodic and cycles.fitted)
        or not np.isfinite(u).all()
        or not np.isfinite(x).all()
    ):
        return {}, []
    # the cycles far outside the others' spread are left out (a settling tail, a cycle that starts
    # from the anchors a smaller one left): a model fitted to them would carry their transient
    fit = fit_maxwell_slip(u, x, cycles.fitted, max_order, order_tolerance)
    measures = {
        "model_order": fit.model.order,
        "model_cycles": " / ".join(map(str, fit.cycles)),
        "forward_rms": fit.forward[0],
        "forward_max": fit.forward[1],
        "feedforward_rms": fit.feedforward[0],
        "feedforward_max": fit.feedforward[1],
        "note": fit.note,
    }
    # a unit names the declared scaling of the channels it is of (V: U, µm: x)
    of = {"V": ("U",), "µm": ("x",), "V/µm": ("U", "x")}
    records = [
        {
            "parameter": n,
            "value": v,
            "unit": heading(f"[{unit}]", of[unit], x_channel, scalings)[1:-1],
        }
        for n, v, unit in fit.parameters()
    ]
    records += [
        {
            "parameter": f"validation rms, {n} elements",
            "value": e,
            "unit": heading("[V]", ("U",), x_channel, scalings)[1:-1],
        }
        for n, e in fit.validation_rms.items()
    ]
    return measures, records


def characterise_capture(
    path,
    settle_s: float,
    min_hold_s: float,
    period_s: float | None = None,
    scalings: Mapping[str, str] | None = None,
    rules: CycleRules = RULES,
    model: Mapping[str, float] | None = None,
) -> tuple[dict, LoopPanels | None, list[dict]]:
    """One capture streamed once: its table row, its loops (None without U or a displacement)
    and its hysteresis model's parameters. ``period_s``: the drive's period if the protocol gives
    it; ``scalings``: channel → its declared scaling, shown in the headings and on the axes;
    ``model``: :func:`hysteresis_model`'s max_order and order_tolerance."""
    name = Path(path).stem
    reduced, x, warmup = reduce_capture(path)
    if reduced is None:
        note = "no drive voltage U and displacement in this capture"
        return row(name, {}, x, None, note, scalings), None, []
    cycles = steady_cycles(reduced, x, period_s, warmup, rules)
    measures = characterise(reduced, x, settle_s, min_hold_s, cycles)
    fitted, parameters = hysteresis_model(reduced, x, cycles, **(model or {}), scalings=scalings)
    measures |= fitted | {"note": "; ".join(filter(None, [measures["note"], fitted.get("note")]))}
    panels = loop_panels(reduced, x, name, cycles=cycles, scalings=scalings)
    row_ = row(name, measures, x, reduced.fs, scalings=scalings)
    return row_, panels, [{"experiment": name} | p for p in parameters]


def loop_page(captures: Sequence[LoopPanels], title: str):
    """One page of the dataset's loop figure, a row per capture; a page that says so when none of
    its captures has U and a displacement."""
    if not captures:
        return placeholder(title, "no capture records a drive voltage U and a displacement")
    return loop_grid([(c.name, c.panels) for c in captures], title)
