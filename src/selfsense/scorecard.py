"""The scorecard: every published number beside its reproduction, a band and a verdict.

The registry (workflow/scorecard.yaml, schema selfsense/schemas/scorecard.schema.yaml) lists each
published number once, with the band it must land in and the reason for that band, both set
before the result, and where the reproduced value is read from: one cell of a results table. This
module is pure: the registry document, the tables and the dataset manifest in, a DataFrame (and
its text renderings) out. An entry whose table is not made for a dataset is kept as "not
reproduced yet", never dropped, so the scorecard also shows how much is still to come.
"""

from __future__ import annotations

import html
import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from selfsense.manifest import ManifestError, validate_document

WITHIN = "within band"
OUT = "out of band"
NOT_YET = "not reproduced yet"
MISSING = "missing from table"
VERDICTS = (WITHIN, OUT, NOT_YET, MISSING)

PUBLISHED = "published"
RECOVERY = "twin recovery"

COLUMNS = ["section", "chapter", "source", "quantity", "unit", "published", "reproduced", "deviation",
           "deviation [%]", "band low", "band high", "tolerance", "justification", "verdict", "read from",
           "note"]

#: a value this close to a band edge (relative) counts as on it: CSV round trips are not exact
EDGE_RTOL = 1e-9
#: how a scorecard note starts when the stage made the table but left the number out
LEFT_OUT = "left out by its stage: "


class RegistryError(ManifestError):
    """A registry that breaks its schema or its own rules; one line naming the file and entry."""


class NotComputed(LookupError):
    """The stage made the table but not this number: the cell is empty, or the stage wrote a
    `note` column saying why instead of the values (say, runs too short to identify)."""


@dataclass(frozen=True)
class Tolerance:
    abs: float | None = None
    rel: float | None = None  # percent of |published|

    def half_width(self, published: float) -> float:
        return self.abs if self.abs is not None else abs(published) * self.rel / 100.0

    def describe(self, unit: str) -> str:
        if self.abs is not None:
            return f"±{self.abs:g}{' ' + unit if unit else ''}"
        return f"±{self.rel:g} %"


@dataclass(frozen=True)
class Locator:
    table: str
    column: str
    where: tuple[tuple[str, Any], ...] = ()
    scale: float = 1.0

    def describe(self) -> str:
        rows = f" [{', '.join(f'{k} = {v}' for k, v in self.where)}]" if self.where else ""
        scale = f" × {self.scale:g}" if self.scale != 1 else ""
        return f"{self.table}{rows} {self.column}{scale}"


@dataclass(frozen=True)
class Entry:
    section: str
    chapter: str
    source: str
    model: str
    quantity: str
    unit: str
    published: float | None  # None: the twin's truth, read from column ``truth`` of the located row
    tolerance: Tolerance
    justification: str
    bound: str | None = None  # "upper" | "lower" for a published bound ("< 3 %")
    note: str = ""
    locate: Locator | None = None
    truth: str | None = None

    @property
    def key(self) -> tuple[str, str, str]:
        return self.model, self.source, self.quantity


@dataclass(frozen=True)
class Score:
    """One scored entry: its published value and band, the reproduced one (None when not reproduced)."""
    entry: Entry
    published: float
    band: tuple[float, float]
    reproduced: float | None = None
    verdict: str = NOT_YET
    detail: str = ""


# --- the registry -------------------------------------------------------------------------------

def parse_registry(doc: Any, source: str = "workflow/scorecard.yaml") -> list[Entry]:
    """Validate the registry document against its schema and expand groups into entries."""
    validate_document(doc, "scorecard.schema.yaml", source)
    entries = []
    for g, group in enumerate(doc["groups"]):
        for e, item in enumerate(group["entries"]):
            where = f"{source}: groups.{g}.entries.{e} ({group['source']}, {item['quantity']})"
            entries.append(_entry(group, item, where))
    seen: set[tuple[str, str, str]] = set()
    for entry in entries:
        if entry.key in seen:
            raise RegistryError(f"{source}: {entry.source}, {entry.quantity!r} is listed twice for "
                                f"model {entry.model}")
        seen.add(entry.key)
    return entries


def _entry(group: Mapping[str, Any], item: Mapping[str, Any], where: str) -> Entry:
    value = {**group, **item}
    published = value["published"]
    truth = published.get("truth") if isinstance(published, Mapping) else None
    section = group.get("section", PUBLISHED)
    locate = _locator({**group.get("locate", {}), **item.get("locate", {})}, where)
    if truth is not None and (section != RECOVERY or locate is None):
        raise RegistryError(f"{where}: published: {{truth: <column>}} needs section: {RECOVERY} and a "
                            "locate (the truth is read from the located row)")
    return Entry(section=section, chapter=group["chapter"], source=group["source"], model=group["model"],
                 quantity=item["quantity"], unit=value["unit"],
                 published=None if truth else float(published),
                 tolerance=Tolerance(**value["tolerance"]), justification=value["justification"],
                 bound=value.get("bound"), note=value.get("note", ""), locate=locate, truth=truth)


def _locator(locate: Mapping[str, Any], where: str) -> Locator | None:
    if not locate:
        return None
    if "table" not in locate or "column" not in locate:
        raise RegistryError(f"{where}: locate needs both table and column (or neither, while no "
                            "stage makes the table)")
    return Locator(locate["table"], locate["column"], tuple(locate.get("where", {}).items()),
                   float(locate.get("scale", 1.0)))


def applicable(entries: Sequence[Entry], manifest: Mapping[str, Any]) -> list[Entry]:
    """Entries for this dataset's actuator (none for a model absent or ``other``: a foreign
    actuator has no published numbers here); twin recovery only where the twin made the
    captures; no published rows where the dataset gives its own reference values (they replace
    the source's: :mod:`selfsense.reference_values`)."""
    return [e for e in entries if e.model == manifest.get("model")
            and (e.section != RECOVERY or ("twin" in manifest and manifest.get("source") != "measured"))
            and (e.section != PUBLISHED or "reference" not in manifest)]


def tables_read(entries: Sequence[Entry]) -> list[str]:
    """Tables (relative to results/<dataset>/) the entries read, in registry order."""
    return list(dict.fromkeys(e.locate.table for e in entries if e.locate))


# --- scoring ------------------------------------------------------------------------------------

def band(published: float, bound: str | None, tolerance: Tolerance) -> tuple[float, float]:
    half = tolerance.half_width(published)
    if bound == "upper":
        return -math.inf, published + half
    if bound == "lower":
        return published - half, math.inf
    return published - half, published + half


def judge(reproduced: float, lo: float, hi: float) -> str:
    inside = lo <= reproduced <= hi or any(math.isfinite(edge) and math.isclose(reproduced, edge, rel_tol=EDGE_RTOL)
                                           for edge in (lo, hi))
    return WITHIN if inside else OUT


def lookup(locator: Locator, table: pd.DataFrame, column: str | None = None) -> float:
    """The cell the locator names (or another ``column`` of its row), in the entry's unit.

    NotComputed when the stage left the number out; LookupError when the locator does not fit
    the table (a renamed column, a row gone), which is a registry entry to fix.
    """
    column = column or locator.column
    absent = [c for c in (column, *(k for k, _ in locator.where)) if c not in table.columns]
    if absent and "note" in table.columns:  # a stage that skipped the table says why in a note
        notes = [n for n in table["note"].dropna().astype(str) if n]
        raise NotComputed(f"{locator.table}: {notes[0] if notes else 'no values'}")
    if absent:
        raise LookupError(f"{locator.table} has no column {absent[0]!r}")
    match = np.ones(len(table), dtype=bool)
    for key, wanted in locator.where:
        match &= _matches(table[key], wanted)
    if match.sum() != 1:
        raise LookupError(f"{int(match.sum())} rows of {locator.table} match "
                          f"{', '.join(f'{k} = {v}' for k, v in locator.where) or '(no selector)'}")
    value = pd.to_numeric(table.loc[match, column], errors="coerce").iloc[0]
    if pd.isna(value):
        raise NotComputed(f"{locator.describe()} is empty")
    return float(value) * locator.scale


def _matches(column: pd.Series, wanted: Any) -> np.ndarray:
    if isinstance(wanted, (int, float)) and not isinstance(wanted, bool):
        numbers = pd.to_numeric(column, errors="coerce").to_numpy(dtype=float)
        return np.isclose(numbers, wanted, rtol=1e-9, atol=0.0)
    return (column.astype(str) == str(wanted)).to_numpy()


def score(entry: Entry, tables: Mapping[str, pd.DataFrame]) -> Score:
    """Score one entry against the tables made for a dataset (relative path → table)."""
    published = math.nan if entry.published is None else entry.published
    if entry.locate is None:
        return Score(entry, published, band(published, entry.bound, entry.tolerance),
                     detail="no stage makes this number yet")
    if entry.locate.table not in tables:
        return Score(entry, published, band(published, entry.bound, entry.tolerance),
                     detail=f"{entry.locate.table} is not made for this dataset")
    table = tables[entry.locate.table]
    try:
        if entry.truth is not None:
            published = lookup(entry.locate, table, entry.truth)
        reproduced = lookup(entry.locate, table)
    except NotComputed as err:  # the stage's own statement that it has no value (say, a short campaign)
        return Score(entry, published, band(published, entry.bound, entry.tolerance), detail=f"{LEFT_OUT}{err}")
    except LookupError as err:  # the table no longer has the row or column: a locator to fix
        return Score(entry, published, band(published, entry.bound, entry.tolerance), verdict=MISSING,
                     detail=str(err))
    limits = band(published, entry.bound, entry.tolerance)
    return Score(entry, published, limits, reproduced, judge(reproduced, *limits))


def scorecard(entries: Sequence[Entry], tables: Mapping[str, pd.DataFrame], manifest: Mapping[str, Any]) -> pd.DataFrame:
    """One row per registry entry that applies to the dataset, in registry order."""
    return pd.DataFrame([_row(score(e, tables)) for e in applicable(entries, manifest)], columns=COLUMNS)


def _row(s: Score) -> dict[str, Any]:
    e, p, r = s.entry, s.published, s.reproduced
    lo, hi = s.band
    return {
        "section": e.section, "chapter": e.chapter, "source": e.source, "quantity": e.quantity,
        "unit": e.unit, "published": p, "reproduced": r,
        "deviation": None if r is None else r - p,
        "deviation [%]": None if r is None or p == 0 else 100.0 * (r - p) / abs(p),
        "band low": lo if math.isfinite(lo) else None, "band high": hi if math.isfinite(hi) else None,
        "tolerance": _tolerance_text(e, p), "justification": e.justification, "verdict": s.verdict,
        "read from": e.locate.describe() if e.locate else "",
        "note": "; ".join(t for t in (s.detail, e.note) if t),
    }


def _tolerance_text(e: Entry, published: float) -> str:
    if not e.bound:
        return e.tolerance.describe(e.unit)
    half = e.tolerance.half_width(published)
    sign, widen = ("≤", "+") if e.bound == "upper" else ("≥", "−")
    return f"{sign} published" + (f" {widen} {half:g}" if half else "")


def counts(card: pd.DataFrame) -> dict[str, int]:
    return {v: int((card["verdict"] == v).sum()) for v in VERDICTS}


# --- renderings ---------------------------------------------------------------------------------

def landing_rst(cards: Mapping[str, pd.DataFrame]) -> str:
    """The short summary that opens the report: the counts table and one line per dataset. The
    long lists are pages of their own (`out_of_band_rst`, `pending_rst`): the report's landing
    text is centred vertically, so a long one starts above the top of the window, out of reach."""
    cards = _filled(cards)
    lines = _table(cards)
    for dataset, card in cards.items():
        lines += ["", _tally(dataset, card)]
    return "\n".join(lines) + "\n"


def out_of_band_rst(cards: Mapping[str, pd.DataFrame]) -> str:
    """A page: per dataset, every number out of band by source (with the registry's note saying
    why) and every number missing from its table."""
    return _lists_page(cards, "Numbers out of band, and missing from their tables",
                       lambda card: _out_of_band(card) + _missing(card), "None: every reproduced number is within band.")


def pending_rst(cards: Mapping[str, pd.DataFrame]) -> str:
    """A page: per dataset, the numbers no stage reproduces yet, by chapter and source."""
    return _lists_page(cards, "Numbers not reproduced yet", _pending, "None: every number is reproduced.")


def rst_html(text: str) -> str:
    """A self-contained HTML page of reStructuredText; a docutils warning or error raises (so a
    page never shows a "problematic" marker)."""
    from docutils.core import publish_string

    return publish_string(text, writer="html5", settings_overrides={
        "halt_level": 2, "report_level": 2, "output_encoding": "unicode", "embed_stylesheet": True,
        "_disable_config": True})


def _filled(cards: Mapping[str, pd.DataFrame]) -> dict[str, pd.DataFrame]:
    # a scorecard read back from CSV has NaN where a text cell was empty
    return {d: c.fillna({"unit": "", "note": "", "read from": ""}) for d, c in cards.items()}


def _table(cards: Mapping[str, pd.DataFrame]) -> list[str]:
    lines = [".. list-table::", "   :header-rows: 1", "",
             "   * - dataset", "     - section", "     - numbers", *(f"     - {v}" for v in VERDICTS)]
    for dataset, card in cards.items():
        for section, part in card.groupby("section", sort=False):
            lines += [f"   * - {_rst(dataset)}", f"     - {section}", f"     - {len(part)}",
                      *(f"     - {n}" for n in counts(part).values())]
    return lines


def _tally(dataset: str, card: pd.DataFrame) -> str:
    tally = counts(card)
    return (f"**{_rst(dataset)}**: {tally[WITHIN]} of {tally[WITHIN] + tally[OUT]} reproduced numbers "
            f"within band, {tally[OUT]} out of band, {tally[NOT_YET]} not reproduced yet.")


def _out_of_band(card: pd.DataFrame) -> list[str]:
    out = card[card["verdict"] == OUT]
    if not len(out):
        return []
    unexplained = int((out["note"] == "").sum())
    return [f"- Out of band, by source ({unexplained} without a note in workflow/scorecard.yaml "
            "saying why):" if unexplained else "- Out of band, by source:",
            *_by_source(out, lambda row: f"{_describe(row)}." + (f" Why: {_rst(row['note'])}" if row["note"] else ""))]


def _missing(card: pd.DataFrame) -> list[str]:
    missing = card[card["verdict"] == MISSING]
    if not len(missing):
        return []
    return ["- Missing from their tables (a locator to fix):",
            *_by_source(missing, lambda row: f"{_rst(row['quantity'])}: {_rst(row['note'])}")]


def _pending(card: pd.DataFrame) -> list[str]:
    pending = card[card["verdict"] == NOT_YET]
    if not len(pending):
        return []
    lines = [f"- Not reproduced yet, by chapter and source ({len(pending)} numbers):", ""]
    for chapter, part in pending.groupby("chapter", sort=False):
        per_source = part.groupby("source", sort=False).size()
        lines.append(f"  - {_chapter(chapter)}: " + ", ".join(f"{_rst(src)} ({n})" for src, n in per_source.items()))
    return lines + [""]


def _lists_page(cards: Mapping[str, pd.DataFrame], title: str, lists, empty: str) -> str:
    """reStructuredText of a page: its title, then per dataset a section with its tally and lists."""
    lines = [title, "=" * len(title), ""]
    for dataset, card in _filled(cards).items():
        head = _rst(dataset)
        lines += [head, "-" * len(head), "", _tally(dataset, card), ""]
        lines += lists(card) or [empty, ""]
    return "\n".join(lines) + "\n"


def _by_source(rows: pd.DataFrame, describe) -> list[str]:
    """A nested bullet list: one item per source, one sub-item per row."""
    lines = [""]
    for source, part in rows.groupby("source", sort=False):
        lines += [f"  - {_rst(source)}", ""]
        lines += [f"    - {describe(row)}" for _, row in part.iterrows()]
        lines.append("")
    return lines


def _chapter(chapter: Any) -> str:
    return f"Chapter {chapter}" if str(chapter).isdigit() else _rst(chapter)


def _describe(row: pd.Series) -> str:
    unit = _rst(f" {row['unit']}" if row["unit"] else "")
    lo, hi = row["band low"], row["band high"]
    band_text = (f"≤ {hi:.6g}" if pd.isna(lo) else f"≥ {lo:.6g}" if pd.isna(hi) else f"{lo:.6g} … {hi:.6g}")
    change = "" if pd.isna(row["deviation [%]"]) else f" ({row['deviation [%]']:+.1f} %)"
    return (f"{_rst(row['quantity'])}: published {row['published']:.6g}{unit}, "
            f"reproduced {row['reproduced']:.6g}{unit}{change}, band {band_text}{unit}")


def _rst(text: Any) -> str:
    """Plain text safe inside reStructuredText inline markup."""
    return "".join("\\" + c if c in "\\*`|_[]" else c for c in str(text))


def scorecard_html(card: pd.DataFrame, title: str) -> str:
    """A self-contained page of the scorecard (the report shows HTML inline, a CSV only as a download)."""
    tally = ", ".join(f"{n} {v}" for v, n in counts(card).items())
    head = "".join(f"<th>{html.escape(c)}</th>" for c in COLUMNS)
    body = "\n".join(
        f'<tr class="{row["verdict"].replace(" ", "-")}">'
        + "".join(f"<td>{html.escape(_cell(row[c]))}</td>" for c in COLUMNS) + "</tr>"
        for _, row in card.iterrows())
    return (f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{html.escape(title)}</title>\n"
            "<style>body{font-family:sans-serif;font-size:13px} table{border-collapse:collapse}"
            " td,th{border:1px solid #ccc;padding:2px 6px;vertical-align:top}"
            " .within-band{background:#e6f4e6} .out-of-band{background:#fbe3e3}"
            " .not-reproduced-yet{color:#777} .missing-from-table{background:#fff1c2}</style></head>\n"
            f"<body><h1>{html.escape(title)}</h1><p>{html.escape(tally)}</p>\n"
            f"<table><thead><tr>{head}</tr></thead><tbody>\n{body}\n</tbody></table></body></html>\n")


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.6g}"
    return "" if value is None else str(value)
