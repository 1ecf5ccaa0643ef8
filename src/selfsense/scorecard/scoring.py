"""Scoring: each registry entry's reproduced value read from the tables, its band and verdict.

Pure: the registry's entries, the tables and the dataset manifest in, a DataFrame out. An entry
whose table is not made for a dataset is kept as "not reproduced yet", never dropped, so the
scorecard also shows how much is still to come.

A recovery entry whose band is centred on the model on the twin's truth gets a second verdict,
the model's bias (:class:`Bias`): that centre against the value the twin is built with, held to
the band's bias rule. The first verdict, the chain's, is what the counts go by.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import pandas as pd

from selfsense.scorecard.registry import (
    BIAS_COLUMNS,
    COLUMNS,
    EDGE_RTOL,
    INFORMATION,
    LEFT_OUT,
    MISSING,
    NOT_YET,
    OUT,
    VERDICTS,
    WITHIN,
    Entry,
    NotComputed,
    applicable,
    lookup,
    one_row,
)


@dataclass(frozen=True)
class Bias:
    """The model's bias of a recovery number whose band is centred on the model on the twin's
    truth: that model on truth (``centre``) against the value the twin is built with (``built``,
    the published value, or a twin recovery row's truth), in the band the rule ``rule`` makes
    about ``built``, and the verdict."""

    centre: float
    built: float
    band: tuple[float, float]
    verdict: str
    rule: str  # the bias rule's name and tolerance, as the scorecard shows it


@dataclass(frozen=True)
class Score:
    """One scored entry: its published value and band, the reproduced one (None when not
    reproduced)."""

    entry: Entry
    published: float
    band: tuple[float, float]
    reproduced: float | None = None
    verdict: str = NOT_YET
    detail: str = ""
    cause: str = ""  # what was measured of the number's error (Cause.note)
    bias: Bias | None = None  # the model's bias, for a band centred on the model on truth


# --- scoring ------------------------------------------------------------------------------------


def band(published: float, entry: Entry) -> tuple[float, float]:
    """The band an entry's reproduction must land in; (-inf, inf) for an information row."""
    if entry.tolerance is None or math.isnan(published):
        return -math.inf, math.inf
    lo, hi = entry.tolerance.limits(published, entry.printed)
    if entry.bound == "upper":
        return -math.inf, hi
    if entry.bound == "lower":
        return lo, math.inf
    return lo, hi


def bias(entry: Entry, centre: float, built: float) -> Bias | None:
    """The model's bias: the model on the twin's truth ``centre`` against the ``built`` value,
    held to the entry's band's bias rule about ``built``; None for a band without one."""
    rule = entry.band.bias
    if rule is None or rule.tolerance is None or math.isnan(centre) or math.isnan(built):
        return None
    lo, hi = rule.tolerance.limits(built)
    text = f"{rule.name}, {rule.tolerance.describe(entry.unit)} of the built value"
    return Bias(centre, built, (lo, hi), judge(centre, lo, hi), text)


def judge(reproduced: float, lo: float, hi: float) -> str:
    inside = lo <= reproduced <= hi or any(
        math.isfinite(edge) and math.isclose(reproduced, edge, rel_tol=EDGE_RTOL)
        for edge in (lo, hi)
    )
    return WITHIN if inside else OUT


def score(entry: Entry, tables: Mapping[str, pd.DataFrame]) -> Score:
    """Score one entry against the tables made for a dataset (relative path → table)."""
    published = math.nan if entry.published is None else entry.published
    if entry.locate is None:
        return Score(
            entry, published, band(published, entry), detail="no stage makes this number yet"
        )
    if entry.locate.table not in tables:
        return Score(
            entry,
            published,
            band(published, entry),
            detail=f"{entry.locate.table} is not made for this dataset",
        )
    table = tables[entry.locate.table]
    centre = entry.centre if entry.centre is not None and entry.centre.table in tables else None
    try:
        if entry.truth is not None:
            published = lookup(entry.locate, table, entry.truth)
        reproduced = lookup(entry.locate, table)
        middle = published if centre is None else lookup(centre, tables[centre.table])
        built = None if entry.built is None else lookup(entry.locate, table, entry.built)
    except (
        NotComputed
    ) as err:  # the stage's own statement that it has no value (say, a short campaign)
        return Score(entry, published, band(published, entry), detail=f"{LEFT_OUT}{err}")
    except LookupError as err:  # the table no longer has the row or column: a locator to fix
        return Score(entry, published, band(published, entry), verdict=MISSING, detail=str(err))
    detail = (
        ""
        if centre is None
        else f"band centred on the model on the twin's truth, {middle:.4g} ({centre.describe()})"
    )
    limits = band(middle, entry)
    verdict = INFORMATION if entry.tolerance is None else judge(reproduced, *limits)
    cause, measured = "", entry.cause
    if measured and measured.located:
        measured = measured.at(
            one_row(table, entry.locate.where, entry.locate.table), entry.locate.table
        )
    if measured and measured.table in tables:
        cause = measured.note(tables[measured.table])
    model = (
        bias(entry, middle, published)  # the band's centre against the published (built) value
        if centre is not None
        else bias(entry, published, built)  # a twin recovery row: its truth is the model's
        if built is not None
        else None
    )
    return Score(entry, published, limits, reproduced, verdict, detail, cause, model)


def scorecard(
    entries: Sequence[Entry], tables: Mapping[str, pd.DataFrame], manifest: Mapping[str, Any]
) -> pd.DataFrame:
    """One row per registry entry that applies to the dataset, in registry order."""
    return pd.DataFrame(
        [_row(score(e, tables)) for e in applicable(entries, manifest)], columns=COLUMNS
    )


def _row(s: Score) -> dict[str, Any]:
    e, p, r = s.entry, s.published, s.reproduced
    lo, hi = s.band
    return {
        "section": e.section,
        "kind": e.kind,
        "chapter": e.chapter,
        "source": e.source,
        "quantity": e.quantity,
        "unit": e.unit,
        "published": p,
        "reproduced": r,
        "deviation": None if r is None else r - p,
        "deviation [%]": None if r is None or p == 0 else 100.0 * (r - p) / abs(p),
        "band low": lo if math.isfinite(lo) else None,
        "band high": hi if math.isfinite(hi) else None,
        "band": e.band.name,
        "tolerance": _tolerance_text(e, p),
        "justification": e.band.justification,
        "verdict": s.verdict,
        **_bias_row(s.bias),
        "read from": e.locate.describe() if e.locate else "",
        "note": "; ".join(t for t in (s.detail, e.note, s.cause) if t),
    }


def _bias_row(b: Bias | None) -> dict[str, Any]:
    """The bias columns: empty for a row without a model on truth."""
    if b is None:
        return dict.fromkeys(BIAS_COLUMNS, None) | {"bias band": "", "bias verdict": ""}
    lo, hi = b.band
    return {
        "model on truth": b.centre,
        "bias": b.centre - b.built,
        "bias [%]": None if b.built == 0 else 100.0 * (b.centre - b.built) / abs(b.built),
        "bias band": b.rule,
        "bias band low": lo,
        "bias band high": hi,
        "bias verdict": b.verdict,
    }


def _tolerance_text(e: Entry, published: float) -> str:
    if e.tolerance is None:
        return "no verdict"
    if not e.bound:
        return e.tolerance.describe(e.unit)
    lo, hi = (
        e.tolerance.limits(published, e.printed)
        if not math.isnan(published)
        else (published, published)
    )
    sign, widen, edge = ("≤", "+", hi) if e.bound == "upper" else ("≥", "−", lo)
    return f"{sign} published" + (
        f" {widen} {abs(edge - published):g}" if edge != published else ""
    )


def counts(card: pd.DataFrame, column: str = "verdict") -> dict[str, int]:
    """How many rows have each verdict (of ``column``: "bias verdict" counts the model's bias; a
    card without that column, written before it existed, has none)."""
    verdicts = card[column] if column in card.columns else pd.Series([], dtype=object)
    return {v: int((verdicts == v).sum()) for v in VERDICTS}


def bias_verdicts(card: pd.DataFrame) -> pd.Series:
    """Each row's bias verdict ("" where it has none, as in a card made before the column)."""
    if "bias verdict" not in card.columns:
        return pd.Series("", index=card.index, dtype=object)
    return card["bias verdict"].astype(object).fillna("").astype(str)
