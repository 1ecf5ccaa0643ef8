"""The envelope's verdicts: every emergent number of the nominal scorecard against the spread of
the same number over the envelope's members (:mod:`selfsense.envelope.design`), and the Morris
screening of what drives each.

Each row is judged against its registry entry (workflow/scorecard.yaml), the target some of
the members' 2.5–97.5 percentile envelope must meet (the envelope: over a Morris design's Latin
hypercube members when it draws them, ``Design.spread``):

- a value: the published number widened by half a unit of its last printed digit (the source's
  own precision; no source prints a spread of these numbers);
- a bound or threshold (the entry's ``bound``: "< 1 µm", the fitted curves' "≤ 1.5 µm", a p
  "≥ published − 0.28"): the registry's band, the limit the nominal scorecard holds the number to;
- a row whose band has no tolerance (the ill-conditioned coefficients and their t statistics)
  gets ``no verdict``: the registry gives it none, and its percentiles are shown for information.

Met, it is ``consistent``; else ``inconsistent``, with the distance from the envelope's nearer
edge in envelope widths. A consistent value whose envelope is wider than the row's own band
(``width / band`` > 1) says less than the band does (a bench drawn at random lands anywhere the
band allows, and beyond) and is ``consistent (uninformative)``, counted apart; a bound has no such
rule (meeting it is all it asks). With fewer than ``MIN_MEMBERS`` members giving the number it has
``no envelope``. ``driven by``: the Morris groups with the largest μ* for the row.

Algebraic twins (a % of stroke row beside its µm row, an adjusted R² beside its R²: the entry's
``twin``) are one finding: ``twin of`` names the row a twin belongs to, and every count is of
findings, by that row's verdict.

``on the edge``: the verdict changes when either edge of the envelope moves, in or out, by the gap
between the two members its percentile lies between (with fewer than 41 members, the outermost
two on its side). One member more beyond that edge, or one fewer, moves it by up to that gap, so
such a verdict rests on one member's draw.

Pure: frames in, frames out.
"""

from __future__ import annotations

import math
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
from selfsense.scorecard.scoring import band

#: a row needs this many members' values for percentiles
MIN_MEMBERS = 3
#: the percentiles of the envelope
PERCENTILES = (2.5, 50.0, 97.5)
CONSISTENT, UNINFORMATIVE, INCONSISTENT = (
    "consistent",
    "consistent (uninformative)",
    "inconsistent",
)
NO_VERDICT, NO_ENVELOPE = "no verdict", "no envelope"
#: the verdicts, in the order they are counted
VERDICTS = (CONSISTENT, UNINFORMATIVE, INCONSISTENT, NO_VERDICT, NO_ENVELOPE)
#: drivers named per row
DRIVERS = 3
#: the column that says whether a verdict rests on one member's draw (see module)
EDGE = "on the edge"
#: the column naming the row (its quantity, of the same source) a row is an algebraic twin of
TWIN = "twin of"
#: the ensemble tables' first column (members × rows, members × signatures)
MEMBER = "member"

#: the nominal scorecard's columns an envelope scorecard keeps, before its own (:data:`COLUMNS`)
NOMINAL_COLUMNS = ["chapter", "source", "quantity", "unit", "published", "reproduced", "verdict"]

COLUMNS = [
    "members",
    "p2.5",
    "p50",
    "p97.5",
    "half-width [%]",
    "width / band",
    "envelope verdict",
    "distance [widths]",
    EDGE,
    TWIN,
    "driven by",
]


def row_key(source: str, quantity: str) -> str:
    """How a scorecard row is named across the nominal card, the members' and the screening."""
    return f"{source} · {quantity}"


@dataclass(frozen=True)
class Target:
    """What a row's envelope must meet, [low, high], and the width of the row's own band, beyond
    which a consistent envelope is uninformative (NaN for a bound: it has no such rule)."""

    low: float
    high: float
    band: float


def target(entry: Entry | None, published: float) -> Target | None:
    """The row's target (see module): a bound its registry band, a value its printed value with
    its band's width; None when the registry gives the row no verdict. A row the registry does not
    list is judged on its printed value, never uninformative (it has no band)."""
    if entry is not None and entry.tolerance is None:
        return None
    if entry is not None and entry.bound:
        low, high = band(published, entry)
        return Target(low, high, math.nan)
    half = precision(entry, published)
    low, high = band(published, entry) if entry is not None else (math.nan, math.nan)
    return Target(published - half, published + half, high - low)


@dataclass(frozen=True)
class Judged:
    verdict: str
    distance: float
    width_to_band: float = math.nan


def judge(low: float, high: float, aim: Target) -> Judged:
    """The verdict of the envelope [low, high] against a row's target (see module)."""
    width = high - low
    if math.isnan(aim.band) or aim.band > 0:
        ratio = width / aim.band
    else:  # a band of no width (an exact count): any spread is wider
        ratio = math.inf if width > 0 else 0.0
    if low <= aim.high and high >= aim.low:
        return Judged(UNINFORMATIVE if ratio > 1 else CONSISTENT, math.nan, ratio)
    gap = max(low - aim.high, aim.low - high)
    return Judged(INCONSISTENT, gap / width if width > 0 else math.inf, ratio)


def on_the_edge(values: np.ndarray, aim: Target) -> bool:
    """Whether the verdict (met or not) of the percentile envelope of ``values`` (the members',
    finite, at least two) against ``aim`` changes when an edge moves, inwards or outwards, by the
    gap between the two members its percentile lies between (see module)."""
    x = np.sort(values)
    low, high = np.percentile(x, (PERCENTILES[0], PERCENTILES[-1]))
    met = judge(low, high, aim).verdict != INCONSISTENT
    # np.percentile's linear rule: the p-th percentile lies between x[i] and x[i + 1]
    i = min(int(PERCENTILES[0] / 100 * (len(x) - 1)), len(x) - 2)
    below, above = x[i + 1] - x[i], x[-1 - i] - x[-2 - i]
    moved = [
        (low - below, high),
        (min(low + below, high), high),
        (low, high + above),
        (low, max(high - above, low)),
    ]
    return any((judge(lo, hi, aim).verdict != INCONSISTENT) != met for lo, hi in moved)


def precision(entry: Entry | None, published: float) -> float:
    """Half a unit of the published number's last printed digit."""
    printed = entry.printed if entry is not None and entry.printed else f"{published:g}"
    return last_digit(printed) / 2


def verdict_columns(published: float, low: float, high: float, entry: Entry | None) -> dict:
    """A judged row's ``width / band``, ``envelope verdict`` and ``distance [widths]`` from its
    envelope [low, high]."""
    aim = target(entry, published)
    if aim is None:
        return {
            "width / band": math.nan,
            "envelope verdict": NO_VERDICT,
            "distance [widths]": math.nan,
        }
    judged = judge(low, high, aim)
    return {
        "width / band": judged.width_to_band,
        "envelope verdict": judged.verdict,
        "distance [widths]": judged.distance,
    }


def member_values(
    cards: Mapping[str, pd.DataFrame], keys: Sequence[str], kind: str = EMERGENT
) -> pd.DataFrame:
    """members × rows: each member's reproduced value of every row of ``kind`` named in ``keys``
    (NaN where it gave none), indexed by member."""
    frame = {}
    for member, card in cards.items():
        rows = card[card["kind"] == kind]
        values = pd.to_numeric(rows["reproduced"], errors="coerce")
        named = pd.Series(
            values.to_numpy(),
            index=[row_key(s, q) for s, q in zip(rows["source"], rows["quantity"])],
        )
        frame[member] = named.reindex(list(keys))
    table = pd.DataFrame(frame, index=list(keys)).T.reindex(columns=list(keys))
    return table.rename_axis(index=MEMBER)


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
        pub, entry = published[key], by_key.get(key)
        row = dict.fromkeys(COLUMNS, math.nan) | {"members": len(finite)}
        row |= {"driven by": named.get(key, ""), TWIN: twin_of(entry)}
        if len(finite) < MIN_MEMBERS or not np.isfinite(pub):
            row["envelope verdict"] = NO_ENVELOPE
            out.append(row)
            continue
        low, mid, high = np.percentile(finite, PERCENTILES)
        row |= percentile_columns(pub, low, mid, high) | verdict_columns(pub, low, high, entry)
        aim = target(entry, pub)
        row[EDGE] = aim is not None and on_the_edge(finite, aim)
        out.append(row)
    extra = pd.DataFrame(out, index=card.index, columns=COLUMNS)
    return pd.concat([card[NOMINAL_COLUMNS], extra], axis=1).reset_index(drop=True)


def twin_of(entry: Entry | None) -> str:
    """The quantity the row is an algebraic twin of ("" for a row of its own)."""
    return entry.twin if entry is not None and entry.twin else ""


def percentile_columns(published: float, low: float, mid: float, high: float) -> dict:
    """A row's percentiles and the envelope's half-width in % of |published|."""
    half = 100 * (high - low) / 2 / abs(published) if published != 0 else math.inf
    return {"p2.5": low, "p50": mid, "p97.5": high, "half-width [%]": half}


def rejudge(card: pd.DataFrame, entries: Sequence[Entry]) -> pd.DataFrame:
    """An envelope scorecard's verdicts made again from its own percentiles with the registry's
    ``entries`` (only the judge changed: neither the members' runs nor their values are needed).

    ``on the edge`` needs the members' values, which a card alone does not hold: it is kept for a
    row judged on its printed value (a target the judge has always used for values), false for a
    row without a verdict, and left empty for a bound (its target is now the registry's band)."""
    by_key = {row_key(e.source, e.quantity): e for e in entries}
    out = card.copy()
    rows = [by_key.get(row_key(s, q)) for s, q in zip(out["source"], out["quantity"])]
    out[TWIN] = [twin_of(e) for e in rows]
    for column in COLUMNS:
        if column not in out:
            out[column] = math.nan
    out[EDGE] = out[EDGE].astype(object)
    for i, entry in zip(out.index, rows):
        if out.at[i, "envelope verdict"] == NO_ENVELOPE:
            continue
        pub = float(out.at[i, "published"])
        columns = verdict_columns(pub, out.at[i, "p2.5"], out.at[i, "p97.5"], entry)
        for column, value in columns.items():
            out.at[i, column] = value
        if columns["envelope verdict"] == NO_VERDICT:
            out.at[i, EDGE] = False
        elif entry is not None and entry.bound:
            out.at[i, EDGE] = math.nan
    return out[[c for c in NOMINAL_COLUMNS if c in card] + COLUMNS]


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
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """(envelope scorecard, sensitivity table, members × rows) of a nominal scorecard and its
    members' cards ({member: card}; ``unit``: the members' draws in the unit hypercube, as SALib
    drew them). Only the design's chapters are judged: a chapter whose unknowns it holds would
    get an envelope of the noise alone."""
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
    return card, sensitivity_table(screening, card), values


def nominal_outside(card: pd.DataFrame) -> pd.DataFrame:
    """The rows whose nominal twin's value lies outside its own envelope: the nominal is one
    bench of the declared ranges, so many such rows say the members do not cover them."""
    reproduced = pd.to_numeric(card["reproduced"], errors="coerce")
    return card[(reproduced < card["p2.5"]) | (reproduced > card["p97.5"])]


def findings(card: pd.DataFrame) -> pd.Series:
    """Whether each row of ``card`` is a finding of its own: not an algebraic twin of another row
    (every row of a card made before the column existed, a card read back from its CSV too)."""
    if TWIN not in card:
        return pd.Series(True, index=card.index)
    return card[TWIN].isna() | card[TWIN].astype(str).eq("")


def envelope_counts(card: pd.DataFrame) -> dict[str, int]:
    """{verdict: findings}, every verdict of :data:`VERDICTS` (zero too), "findings" and "rows"
    (a row and its twins are one finding, counted by the row's verdict)."""
    own = card[findings(card)]
    counted = own["envelope verdict"].value_counts()
    return {v: int(counted.get(v, 0)) for v in VERDICTS} | {
        "findings": len(own),
        "rows": len(card),
    }


def twin_disagreements(card: pd.DataFrame) -> list[str]:
    """ "<source>, <twin>: <its verdict>, <row>: <the row's>" for every twin whose verdict is not
    the verdict of the row it is counted with (the two differ only by the arithmetic between
    them, say each member's own stroke)."""
    if TWIN not in card:
        return []
    verdict = {
        (s, q): v for s, q, v in zip(card["source"], card["quantity"], card["envelope verdict"])
    }
    lines = []
    for _, row in card[~findings(card)].iterrows():
        own = verdict.get((row["source"], row[TWIN]))
        if own is not None and own != row["envelope verdict"]:
            lines.append(
                f"{row['source']}, {row['quantity']}: {row['envelope verdict']}; {row[TWIN]}: {own}"
            )
    return lines


def edge_rows(card: pd.DataFrame) -> pd.Series:
    """Whether each row of ``card`` is ``on the edge``: false where it has no envelope, and for
    every row of a card made before the column existed (a card read back from its CSV too)."""
    if EDGE not in card:
        return pd.Series(False, index=card.index)
    return card[EDGE].eq(True)


def edge_counts(card: pd.DataFrame) -> str:
    """The judged findings ``on the edge``, by verdict: "k of n findings (consistent a,
    consistent (uninformative) b, inconsistent c)", and how many are not known (a card judged
    again from its percentiles alone, :func:`rejudge`, or made before the column existed)."""
    own = card[findings(card)]
    edge = own[edge_rows(own)]
    tally = edge["envelope verdict"].value_counts()
    parts = ", ".join(f"{v} {int(tally.get(v, 0))}" for v in VERDICTS[:3])
    unknown = int(own[EDGE].isna().sum()) if EDGE in own else len(own)
    if unknown == len(own):
        return f"not known for the {unknown} findings"
    known = f"{len(edge)} of {len(own) - unknown} findings ({parts})"
    return known + (f"; not known for {unknown}" if unknown else "")


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
    held: Sequence[str],
    varied: int,
    misses: int,
    unknowns_sha256: str,
    members: int,
) -> str:
    """The envelope's opening (reStructuredText): the findings' verdicts counted, the nominal
    band's beside them, what was varied (``varied`` unknowns) and ``held`` (their ids), the
    ``misses`` (members with a calibration row out of band), every row some members gave no
    value for (its envelope is over the others: a reviewer reads why in those members' tables),
    every twin whose verdict differs from its row's, and every inconsistent finding with its
    drivers."""
    counts = envelope_counts(card)
    n = counts["findings"]
    own = card[findings(card)]
    band = own["verdict"].value_counts()

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
    judged = own[own["envelope verdict"] != NO_ENVELOPE]
    lines = [
        f"Envelope of {design.dataset}: {members} members "
        f"({method}; seed {design.seed}); {varied} unknowns varied, {len(held)} held at "
        f"their nominal; workflow/unknowns.yaml sha256 {unknowns_sha256[:12]}.",
        "",
        f"Emergent rows: {counts['rows']}, findings: {n} (a % of stroke or adjusted R² row is "
        f"one finding with its µm or R² row). Consistent (informative): "
        f"{share(counts[CONSISTENT])}; consistent (uninformative, the envelope wider than the "
        f"row's band): {share(counts[UNINFORMATIVE])}; inconsistent: "
        f"{share(counts[INCONSISTENT])}; no verdict (none in the registry): "
        f"{share(counts[NO_VERDICT])}; no envelope: {share(counts[NO_ENVELOPE])}. The nominal "
        f"twin's bands beside them: {int(band.get('within band', 0))} within, "
        f"{int(band.get('out of band', 0))} out of band.",
        "",
        f"On the edge (the verdict changes when an edge moves by the gap between the two "
        f"members its percentile lies between): "
        f"{edge_counts(judged[judged['envelope verdict'] != NO_VERDICT])}.",
        "",
        f"The nominal twin's own value lies outside its envelope in "
        f"{len(nominal_outside(judged))} of the {len(judged)} findings with an envelope.",
        "",
        f"Members with a calibration row out of its band: {misses} of {members}.",
        "",
        "Held at their nominal: " + (", ".join(held) or "none") + ".",
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
    differ = twin_disagreements(card)
    if differ:
        lines += ["", "Twins whose verdict is not their row's (counted by the row's):", ""]
        lines += [f"- {line}" for line in differ]
    out = own[own["envelope verdict"] == INCONSISTENT]
    if len(out):
        lines += ["", "Inconsistent findings (distance in envelope widths; driven by):", ""]
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
    """What rule `envelope` writes: the envelope scorecard, the sensitivity table, the summary,
    how many members have a calibration row out of band (its provenance keeps the count), and
    the ensemble's tables a later method re-judges from without running a member again: every
    member's value of every judged emergent row (``values``) and of every calibration signature
    (``signatures``), members × rows (the members × inputs table is the plan's)."""

    card: pd.DataFrame
    sensitivity: pd.DataFrame
    summary: str
    misses: int
    values: pd.DataFrame
    signatures: pd.DataFrame


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
    card, sensitivity, values = judge_envelope(nominal, members, unit, varied, design, entries)
    judged = nominal[nominal["chapter"].map(design.judges)]
    calibration = judged[judged["kind"] == "calibration"]
    keys = [row_key(s, q) for s, q in zip(calibration["source"], calibration["quantity"])]
    signatures = member_values(members, keys, "calibration")
    misses = len(calibration_misses(members))
    held_ids = [u.id for u in held]
    text = envelope_summary(
        card, design, held_ids, len(varied), misses, unknowns_sha256, len(members)
    )
    return EnvelopeResult(card, sensitivity, text, misses, values, signatures)
