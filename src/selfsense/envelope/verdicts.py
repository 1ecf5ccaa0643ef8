"""The envelope's verdicts: every emergent number of the nominal scorecard against the spread of
the same number over the envelope's members (:mod:`selfsense.envelope.design`), and the Morris
screening of what drives each.

A published number is ``consistent`` when it lies inside the members' 2.5–97.5 percentile
envelope (a Morris design's Latin hypercube members when it draws them: ``Design.spread``), the
envelope widened by half a unit of the number's last printed digit (the source's own precision;
no source prints a spread of these numbers); a published bound ("< 1 µm") is consistent when
some of the envelope meets it. Else ``inconsistent``, with the distance from the envelope's
nearer edge in envelope widths. A consistent number whose envelope's half-width exceeds
``INFORMATIVE`` % of the published value says little (any bench would do) and is ``consistent
(uninformative)``, counted apart. With fewer than ``MIN_MEMBERS`` members giving the number it
has ``no envelope``. ``driven by``: the Morris groups with the largest μ* for the row.

``on the edge``: the verdict changes when either edge of the envelope moves, in or out, by the gap
between the two members its percentile lies between (with fewer than 41 members, the outermost
two on its side). One member more beyond that edge, or one fewer, moves it by up to that gap, so
such a verdict rests on one member's draw.

Pure: frames in, frames out.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from selfsense.envelope.design import (
    Design,
    held_unknowns,
    member_roles,
    problem,
    trajectories,
    varied_unknowns,
)
from selfsense.envelope.unknowns import Unknown
from selfsense.scorecard.registry import EMERGENT, Entry, last_digit

#: an envelope wider than ± this % of the published value makes a consistent verdict uninformative
INFORMATIVE = 25.0
#: a row needs this many members' values for percentiles
MIN_MEMBERS = 3
#: the percentiles of the envelope
PERCENTILES = (2.5, 50.0, 97.5)
#: the verdicts, in the order they are counted
VERDICTS = ("consistent", "consistent (uninformative)", "inconsistent", "no envelope")
#: drivers named per row
DRIVERS = 3
#: the column that says whether a verdict rests on one member's draw (see module)
EDGE = "on the edge"

#: the nominal scorecard's columns an envelope scorecard keeps, before its own (:data:`COLUMNS`)
NOMINAL_COLUMNS = ["chapter", "source", "quantity", "unit", "published", "reproduced", "verdict"]

COLUMNS = [
    "members",
    "p2.5",
    "p50",
    "p97.5",
    "half-width [%]",
    "envelope verdict",
    "distance [widths]",
    EDGE,
    "driven by",
]


def row_key(source: str, quantity: str) -> str:
    """How a scorecard row is named across the nominal card, the members' and the screening."""
    return f"{source} · {quantity}"


@dataclass(frozen=True)
class Judged:
    verdict: str
    distance: float


def judge(published: float, low: float, high: float, precision: float, bound: str | None) -> Judged:
    """The verdict of one published number against the envelope [low, high] (see module)."""
    lo, hi = published - precision, published + precision
    width = high - low
    if bound == "upper":
        inside, gap = low <= hi, low - hi
    elif bound == "lower":
        inside, gap = high >= lo, lo - high
    else:
        inside = low <= hi and high >= lo
        gap = max(low - hi, lo - high)
    if inside:
        return Judged("consistent", float("nan"))
    return Judged("inconsistent", gap / width if width > 0 else float("inf"))


def on_the_edge(published: float, values: np.ndarray, precision: float, bound: str | None) -> bool:
    """Whether the verdict of ``published`` against the percentile envelope of ``values`` (the
    members', finite, at least two) changes when an edge moves, inwards or outwards, by the gap
    between the two members its percentile lies between (see module)."""
    x = np.sort(values)
    low, high = np.percentile(x, (PERCENTILES[0], PERCENTILES[-1]))
    verdict = judge(published, low, high, precision, bound).verdict
    # np.percentile's linear rule: the p-th percentile lies between x[i] and x[i + 1]
    i = min(int(PERCENTILES[0] / 100 * (len(x) - 1)), len(x) - 2)
    below, above = x[i + 1] - x[i], x[-1 - i] - x[-2 - i]
    moved = [
        (low - below, high),
        (min(low + below, high), high),
        (low, high + above),
        (low, max(high - above, low)),
    ]
    return any(judge(published, lo, hi, precision, bound).verdict != verdict for lo, hi in moved)


def precision(entry: Entry | None, published: float) -> float:
    """Half a unit of the published number's last printed digit."""
    printed = entry.printed if entry is not None and entry.printed else f"{published:g}"
    return last_digit(printed) / 2


def member_values(cards: Mapping[str, pd.DataFrame], keys: Sequence[str]) -> pd.DataFrame:
    """members × rows: each member's reproduced value of every row (NaN where it gave none)."""
    frame = {}
    for member, card in cards.items():
        emergent = card[card["kind"] == EMERGENT]
        values = pd.to_numeric(emergent["reproduced"], errors="coerce")
        named = pd.Series(
            values.to_numpy(),
            index=[row_key(s, q) for s, q in zip(emergent["source"], emergent["quantity"])],
        )
        frame[member] = named.reindex(list(keys))
    return pd.DataFrame(frame).T.reindex(columns=list(keys))


def drivers(screening: pd.DataFrame, published: Mapping[str, float]) -> dict[str, str]:
    """{row: its largest-μ* groups, "creep 41 %, P1 levels 12 %"} (μ* in % of |published|, per
    a whole declared range)."""
    named = {}
    for key, rows in screening.groupby("output", sort=False):
        scale = abs(published.get(key, float("nan")))
        top = rows.sort_values("mu_star", ascending=False).head(DRIVERS)
        top = top[top["mu_star"] > 0]
        if scale > 0:
            named[key] = ", ".join(
                f"{f} {100 * m / scale:.3g} %" for f, m in zip(top["factor"], top["mu_star"])
            )
        else:
            named[key] = ", ".join(f"{f} {m:.3g}" for f, m in zip(top["factor"], top["mu_star"]))
    return named


def envelope_scorecard(
    nominal: pd.DataFrame,
    values: pd.DataFrame,
    screening: pd.DataFrame,
    entries: Sequence[Entry],
) -> pd.DataFrame:
    """The nominal scorecard's emergent rows with the envelope's columns (:data:`COLUMNS`), from
    the members' ``values`` (:func:`member_values`) and the Morris ``screening``."""
    card = nominal[nominal["kind"] == EMERGENT].copy()
    keys = [row_key(s, q) for s, q in zip(card["source"], card["quantity"])]
    by_key = {row_key(e.source, e.quantity): e for e in entries}
    published = dict(zip(keys, pd.to_numeric(card["published"], errors="coerce")))
    named = drivers(screening, published) if len(screening) else {}
    out = []
    for key in keys:
        column = values[key].to_numpy(dtype=float) if key in values else np.array([])
        finite = column[np.isfinite(column)]
        pub = published[key]
        row = dict.fromkeys(COLUMNS, float("nan")) | {"members": len(finite)}
        row["driven by"] = named.get(key, "")
        if len(finite) < MIN_MEMBERS or not np.isfinite(pub):
            row["envelope verdict"] = "no envelope"
            out.append(row)
            continue
        low, mid, high = np.percentile(finite, PERCENTILES)
        entry = by_key.get(key)
        printed, bound = precision(entry, pub), entry.bound if entry else None
        judged = judge(pub, low, high, printed, bound)
        half = 100 * (high - low) / 2 / abs(pub) if pub != 0 else float("inf")
        verdict = judged.verdict
        if verdict == "consistent" and not half <= INFORMATIVE:
            verdict = "consistent (uninformative)"
        row |= {
            "p2.5": low,
            "p50": mid,
            "p97.5": high,
            "half-width [%]": half,
            "envelope verdict": verdict,
            "distance [widths]": judged.distance,
            EDGE: on_the_edge(pub, finite, printed, bound),
        }
        out.append(row)
    extra = pd.DataFrame(out, index=card.index, columns=COLUMNS)
    return pd.concat([card[NOMINAL_COLUMNS], extra], axis=1).reset_index(drop=True)


def morris_screening(
    varied: Sequence[Unknown],
    design: Design,
    unit: pd.DataFrame,
    outputs: pd.DataFrame,
) -> pd.DataFrame:
    """Morris's μ* and σ of every output (a column of ``outputs``, members × outputs) for every
    group: rows (output, factor, mu_star, sigma), in the outputs' units per unit of the
    group's declared range. An output a member did not give (NaN) is screened on none: its
    trajectories would be broken."""
    # here, not at the top: SALib's analysis imports scipy.stats, a second of every workflow parse
    from SALib.analyze import morris as morris_analysis

    spec = problem(varied, design)
    rows = []
    x = unit.loc[outputs.index].to_numpy()
    for column in outputs.columns:
        y = outputs[column].to_numpy(dtype=float)
        if not np.isfinite(y).all():
            continue
        result = morris_analysis.analyze(
            spec, x, y, num_levels=design.levels, seed=design.seed, print_to_console=False
        )
        for factor, mu_star, sigma in zip(
            result["names"], result["mu_star"], result["sigma"], strict=True
        ):
            rows.append((column, str(factor), float(mu_star), float(sigma)))
    return pd.DataFrame(rows, columns=["output", "factor", "mu_star", "sigma"])


def sensitivity_table(screening: pd.DataFrame, card: pd.DataFrame) -> pd.DataFrame:
    """The Morris screening as rows × groups: source, quantity, factor, μ*, σ, and μ* in % of
    |published| (per a whole declared range of the group)."""
    columns = ["source", "quantity", "factor", "mu_star", "sigma", "mu_star [%]"]
    if not len(screening):
        return pd.DataFrame(columns=columns)
    rows = {
        row_key(s, q): (s, q, p)
        for s, q, p in zip(card["source"], card["quantity"], card["published"])
    }
    out = []
    for output, factor, mu_star, sigma in screening[
        ["output", "factor", "mu_star", "sigma"]
    ].itertuples(index=False):
        source, quantity, pub = rows[output]
        scale = abs(float(pub))
        share = 100 * mu_star / scale if scale > 0 else float("nan")
        out.append((source, quantity, factor, mu_star, sigma, share))
    return pd.DataFrame(out, columns=columns)


def judge_envelope(
    nominal: pd.DataFrame,
    members: Mapping[str, pd.DataFrame],
    unit: pd.DataFrame,
    varied: Sequence[Unknown],
    design: Design,
    entries: Sequence[Entry],
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(envelope scorecard, sensitivity table) of a nominal scorecard and its members' cards
    ({member: card}; ``unit``: the members' draws in the unit hypercube, as SALib drew them).
    Only the design's chapters are judged: a chapter whose unknowns it holds would get an
    envelope of the noise alone."""
    nominal = nominal[nominal["chapter"].map(design.judges)]
    emergent = nominal[nominal["kind"] == EMERGENT]
    keys = [row_key(s, q) for s, q in zip(emergent["source"], emergent["quantity"])]
    values = member_values(members, keys)
    screened, spread = member_roles(design, [m for m in unit.index if m in members])
    screening = (
        morris_screening(varied, design, unit, values.loc[screened])
        if screened
        else pd.DataFrame(columns=["output", "factor", "mu_star", "sigma"])
    )
    card = envelope_scorecard(nominal, values.loc[spread], screening, entries)
    return card, sensitivity_table(screening, card)


def nominal_outside(card: pd.DataFrame) -> pd.DataFrame:
    """The rows whose nominal twin's value lies outside its own envelope: the nominal is one
    bench of the declared ranges, so many such rows say the members do not cover them."""
    reproduced = pd.to_numeric(card["reproduced"], errors="coerce")
    return card[(reproduced < card["p2.5"]) | (reproduced > card["p97.5"])]


def envelope_counts(card: pd.DataFrame) -> dict[str, int]:
    """{verdict: rows}, every verdict of :data:`VERDICTS` (zero too), and "rows"."""
    counted = card["envelope verdict"].value_counts()
    return {v: int(counted.get(v, 0)) for v in VERDICTS} | {"rows": len(card)}


def edge_rows(card: pd.DataFrame) -> pd.Series:
    """Whether each row of ``card`` is ``on the edge``: false where it has no envelope, and for
    every row of a card made before the column existed (a card read back from its CSV too)."""
    if EDGE not in card:
        return pd.Series(False, index=card.index)
    return card[EDGE].eq(True)


def edge_counts(card: pd.DataFrame) -> str:
    """The judged rows ``on the edge``, by verdict: "k of n rows (consistent a, consistent
    (uninformative) b, inconsistent c)"."""
    edge = card[edge_rows(card)]
    tally = edge["envelope verdict"].value_counts()
    parts = ", ".join(f"{v} {int(tally.get(v, 0))}" for v in VERDICTS[:3])
    return f"{len(edge)} of {len(card)} rows ({parts})"


def edge_note(row: pd.Series) -> str:
    """The note ", on the edge" for a row whose verdict rests on one member's draw, else "" (a
    card read back from its CSV too; a card made before the column existed has none)."""
    value = row.get(EDGE)
    return ", on the edge" if isinstance(value, bool | np.bool_) and value else ""


def calibration_misses(members: Mapping[str, pd.DataFrame]) -> dict[str, int]:
    """{member: its calibration rows out of band}, members with at least one: drawn jointly,
    the calibrated parameters' one-at-a-time spans can leave a signature's band (reported, not
    rejected: docs/envelope.md)."""
    misses = {}
    for member, card in members.items():
        calibration = card[card["kind"] == "calibration"]
        out = int((calibration["verdict"] == "out of band").sum())
        if out:
            misses[member] = out
    return misses


def envelope_summary(
    card: pd.DataFrame,
    design: Design,
    held: Sequence[Unknown],
    varied: Sequence[Unknown],
    misses: Mapping[str, int],
    unknowns_sha256: str,
    members: int,
) -> str:
    """The envelope's opening (reStructuredText): the verdicts' counts with the nominal band's
    beside them, what was varied and held, every row some members gave no value for (its
    envelope is over the others: a reviewer reads why in those members' tables), and every
    inconsistent row with its drivers."""
    counts = envelope_counts(card)
    n = counts["rows"]
    band = card["verdict"].value_counts()

    def share(k: int) -> str:
        return f"{k} ({100 * k / n:.0f} %)" if n else str(k)

    method = (
        f"Morris, {trajectories(design)} trajectories of {len(design.groups)} groups"
        if design.method == "morris"
        else "Latin hypercube"
    )
    if design.spread:
        method += f", the drivers; a Latin hypercube of {design.spread}, the percentiles"
    spread = design.spread or members
    judged = card[card["envelope verdict"] != "no envelope"]
    lines = [
        f"Envelope of {design.dataset}: {members} members "
        f"({method}; seed {design.seed}); {len(varied)} unknowns varied, {len(held)} held at "
        f"their nominal; workflow/unknowns.yaml sha256 {unknowns_sha256[:12]}.",
        "",
        f"Emergent rows: {n}. Consistent (informative): {share(counts['consistent'])}; "
        f"consistent (uninformative, half-width > {INFORMATIVE:g} %): "
        f"{share(counts['consistent (uninformative)'])}; inconsistent: "
        f"{share(counts['inconsistent'])}; no envelope: {share(counts['no envelope'])}. "
        f"The nominal twin's bands beside them: {int(band.get('within band', 0))} within, "
        f"{int(band.get('out of band', 0))} out of band.",
        "",
        f"On the edge (the verdict changes when an edge moves by the gap between the two "
        f"members its percentile lies between): {edge_counts(judged)}.",
        "",
        f"The nominal twin's own value lies outside its envelope in "
        f"{len(nominal_outside(judged))} of the {len(judged)} rows with an envelope.",
        "",
        f"Members with a calibration row out of its band: {len(misses)} of {members}.",
        "",
        "Held at their nominal: " + (", ".join(u.id for u in held) or "none") + ".",
    ]
    short = card[card["members"] < spread]
    if len(short):
        lines += [
            "",
            f"Rows fewer than the {spread} members behind the percentiles gave a value for:",
            "",
        ]
        lines += [
            f"- {row['source']}, {row['quantity']}: {int(row['members'])} of {spread}"
            for _, row in short.iterrows()
        ]
    out = card[card["envelope verdict"] == "inconsistent"]
    if len(out):
        lines += ["", "Inconsistent rows (distance in envelope widths; driven by):", ""]
        for _, row in out.iterrows():
            lines.append(
                f"- {row['source']}, {row['quantity']}: published {row['published']:.4g}, "
                f"envelope {row['p2.5']:.4g} … {row['p97.5']:.4g} "
                f"({row['distance [widths]']:.2g} widths{edge_note(row)}; "
                f"{row['driven by'] or 'no screening'})"
            )
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class EnvelopeResult:
    """What rule `envelope` writes: the envelope scorecard, the sensitivity table, the summary."""

    card: pd.DataFrame
    sensitivity: pd.DataFrame
    summary: str


def envelope_result(
    design: Design,
    nominal: pd.DataFrame,
    members: Mapping[str, pd.DataFrame],
    unit: pd.DataFrame,
    unknowns: Sequence[Unknown],
    entries: Sequence[Entry],
    unknowns_sha256: str,
) -> EnvelopeResult:
    """The envelope of ``design`` (the unknowns it varies and holds) over the members'
    scorecards, against the nominal scorecard."""
    varied, held = varied_unknowns(unknowns, design), held_unknowns(unknowns, design)
    card, sensitivity = judge_envelope(nominal, members, unit, varied, design, entries)
    misses = calibration_misses(members)
    text = envelope_summary(card, design, held, varied, misses, unknowns_sha256, len(members))
    return EnvelopeResult(card, sensitivity, text)
