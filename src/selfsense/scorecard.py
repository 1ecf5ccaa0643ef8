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
from dataclasses import dataclass, replace
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from selfsense.budget_columns import AT_MAX, AT_MAX_SPREAD
from selfsense.manifest import ManifestError, validate_document

WITHIN = "within band"
OUT = "out of band"
NOT_YET = "not reproduced yet"
MISSING = "missing from table"
INFORMATION = "information (no verdict)"
VERDICTS = (WITHIN, OUT, NOT_YET, MISSING, INFORMATION)

PUBLISHED = "published"
RECOVERY = "twin recovery"

#: what kind of number a row is (docs/scorecard.md); only `emergent` ones count as reproduced
KINDS = ("emergent", "closed form", "recovery", "calibration")
EMERGENT = "emergent"

COLUMNS = ["section", "kind", "chapter", "source", "quantity", "unit", "published", "reproduced", "deviation",
           "deviation [%]", "band low", "band high", "band", "tolerance", "justification", "verdict", "read from",
           "note"]

#: a value this close to a band edge (relative) counts as on it: CSV round trips are not exact
EDGE_RTOL = 1e-9
#: how a scorecard note starts when the stage made the table but left the number out
LEFT_OUT = "left out by its stage: "
#: the observer's error budget (rule error_budget, twin datasets only): what an entry's `cause` reads
#: unless it names another of CAUSE_TABLES
BUDGET_TABLE = "twin/error_budget.csv"
#: the error budgets a `cause` can read (twin datasets only), and the error each splits
#: how a measured cause's part of a note starts (Cause.note), which the summary counts by
CAUSE_MARK = "Measured"

CAUSE_TABLES = {BUDGET_TABLE: "the observer error", "twin/tracking_budget.csv": "the tracking error",
                "twin/charge_budget.csv": "the charge–position error", "twin/controller_budget.csv": "the controller error"}


class RegistryError(ManifestError):
    """A registry that breaks its schema or its own rules; one line naming the file and entry."""


class NotComputed(LookupError):
    """The stage made the table but not this number: the cell is empty, or the stage wrote a
    `note` column saying why instead of the values (say, runs too short to identify)."""


@dataclass(frozen=True)
class Tolerance:
    """How far from the published value a reproduction may land: a half-width (``abs`` in the
    entry's unit, ``rel`` in percent of |published|, ``digit`` in units of the last printed digit)
    or a ``factor``, on a ``scale``: linear (p ± h), log ([p/f, p·f] with f = factor or 1 + h/p,
    for a positive quantity) or log1m (the same for 1 − value, for goodness of fit)."""
    abs: float | None = None
    rel: float | None = None
    digit: float | None = None
    factor: float | None = None
    scale: str = "linear"

    def half_width(self, published: float, printed: str | None = None) -> float:
        if self.abs is not None:
            return self.abs
        if self.rel is not None:
            return abs(published) * self.rel / 100.0
        if self.digit is not None:
            return self.digit * last_digit(printed if printed is not None else repr(published))
        raise ValueError("a factor has no half-width")

    def limits(self, published: float, printed: str | None = None) -> tuple[float, float]:
        """[low, high] around ``published`` on this tolerance's scale."""
        if self.scale == "linear":
            half = self.half_width(published, printed)
            return published - half, published + half
        ref = published if self.scale == "log" else 1.0 - published
        factor = self.factor if self.factor is not None else 1.0 + self.half_width(ref, printed) / ref
        if self.scale == "log":
            return ref / factor, ref * factor
        return 1.0 - ref * factor, 1.0 - ref / factor

    def describe(self, unit: str) -> str:
        unit = f" {unit}" if unit else ""
        text = (f"±{self.abs:g}{unit}" if self.abs is not None else f"±{self.rel:g} %" if self.rel is not None
                else f"±{self.digit:g} of the last printed digit" if self.digit is not None else f"×/÷ {self.factor:g}")
        if self.scale == "log" and self.factor is None:
            text = f"+{text.removeprefix('±')}, same factor below"
        return text + {"linear": "", "log": "", "log1m": " on 1 − value"}[self.scale]


def last_digit(printed: str) -> float:
    """The value of one unit of the last digit of a number as printed: '0.637' → 0.001, '400' → 1."""
    mantissa, _, exponent = printed.lower().partition("e")
    decimals = len(mantissa.partition(".")[2].rstrip()) if "." in mantissa else 0
    return 10.0 ** (int(exponent or 0) - decimals)


@dataclass(frozen=True)
class Band:
    """The rule for one kind of quantity: its tolerance (None: information, no verdict), the side
    it bounds when the source states a bound, and the reason, written once in the registry."""
    name: str
    justification: str
    tolerance: Tolerance | None = None
    bound: str | None = None  # "upper" | "lower" when the rule itself is a bound (a scatter)


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
class Cause:
    """What was measured of a number's error: the row ``where`` of ``table`` (results/<dataset>/).

    An error budget (one of CAUSE_TABLES) is read at the error's max, or with ``statistic`` "σ" at
    the spread over P1's tests of each test's max (:func:`selfsense.error_budget.spread_over_spans`);
    any other table is quoted: its ``quote`` columns, which the entry's note interprets. The
    ``located`` columns are selected by their values in the entry's own located row: a number
    stated at the segment its table names (P1's worst) is explained at that segment.
    """

    table: str = BUDGET_TABLE
    where: tuple[tuple[str, Any], ...] = ()
    statistic: str = "max"
    quote: tuple[str, ...] = ()
    located: tuple[str, ...] = ()

    def at(self, row: pd.Series, name: str) -> "Cause":
        """The cause with its ``located`` columns selected at their values in ``row`` (of table ``name``)."""
        absent = [c for c in self.located if c not in row.index]
        if absent:
            raise LookupError(f"{name} has no column {absent[0]!r} to select the cause's row by")
        return replace(self, where=self.where + tuple((c, row[c]) for c in self.located), located=())

    def note(self, table: pd.DataFrame, largest: int = 3) -> str:
        """The scorecard's note from the table this cause names."""
        row = _one_row(table, self.where, self.table)
        selector = ", ".join(f"{k} = {v}" for k, v in self.where)
        if self.quote:
            absent = [c for c in self.quote if c not in table.columns]
            if absent:
                raise LookupError(f"{self.table} has no column {absent[0]!r}")
            return (f"{CAUSE_MARK} ({self.table}, {selector}): "
                    + ", ".join(f"{c} = {_quoted(row[c])}" for c in self.quote))
        if self.statistic == "σ":
            suffix, style = AT_MAX_SPREAD, ".3f"
            head = (f"σ over the tests of {CAUSE_TABLES[self.table]}'s max, "
                    f"{float(row['total max σ over tests [µm]']):.3f} µm; the σ of its largest sources at each test's max are ")
        else:
            suffix, style = AT_MAX, "+.2f"
            head = (f"at {CAUSE_TABLES[self.table]}'s max, {float(row['total at max [µm]']):+.2f} µm, "
                    "its largest sources are ")
        sources = {c.removesuffix(suffix): float(row[c]) for c in table.columns if c.endswith(suffix) and pd.notna(row[c])}
        top = sorted(sources.items(), key=lambda kv: -abs(kv[1]))[:largest]
        return (f"{CAUSE_MARK} cause ({self.table}, {selector}): {head}"
                + ", ".join(f"{name} {value:{style}}" for name, value in top) + " µm")


def _quoted(value: Any) -> str:
    """A quoted cell to 4 significant digits; a count whole (a df of 19999 is not 2e+04)."""
    number = pd.to_numeric(value, errors="coerce")
    if pd.isna(number):
        return str(value)
    return f"{int(number)}" if float(number).is_integer() else f"{float(number):.4g}"


@dataclass(frozen=True)
class Entry:
    section: str
    kind: str
    chapter: str
    source: str
    model: str
    quantity: str
    unit: str
    published: float | None  # None: the twin's truth, read from column ``truth`` of the located row
    band: Band
    bound: str | None = None  # "upper" | "lower" for a published bound ("< 3 %")
    note: str = ""
    locate: Locator | None = None
    truth: str | None = None
    printed: str | None = None  # the published number as printed, where trailing zeros matter
    cause: Cause | None = None  # the measured table row that explains the number's error
    centre: Locator | None = None  # the model on the twin's truth the band is centred on, if not the published

    @property
    def key(self) -> tuple[str, str, str]:
        return self.model, self.source, self.quantity

    @property
    def tolerance(self) -> Tolerance | None:
        return self.band.tolerance


@dataclass(frozen=True)
class Score:
    """One scored entry: its published value and band, the reproduced one (None when not reproduced)."""
    entry: Entry
    published: float
    band: tuple[float, float]
    reproduced: float | None = None
    verdict: str = NOT_YET
    detail: str = ""
    cause: str = ""  # what was measured of the number's error (Cause.note)


# --- the registry -------------------------------------------------------------------------------

def parse_registry(doc: Any, source: str = "workflow/scorecard.yaml") -> list[Entry]:
    """Validate the registry document against its schema and expand groups into entries."""
    validate_document(doc, "scorecard.schema.yaml", source)
    rules = {name: _band(b, f"{source}: bands.{name}") for name, b in doc.get("bands", {}).items()}
    names = {b.name: b for b in rules.values()}
    entries = []
    for g, group in enumerate(doc["groups"]):
        for e, item in enumerate(group["entries"]):
            where = f"{source}: groups.{g}.entries.{e} ({group['source']}, {item['quantity']})"
            entries.append(_entry(group, item, where))
            named = names.get(entries[-1].band.name)
            if named is not None and named != entries[-1].band:
                raise RegistryError(f"{where}: its band is named {named.name!r} like a rule of `bands:` "
                                    "but differs from it: name the rule by its alias, or give the band a name of its own")
    seen: set[tuple[str, str, str]] = set()
    for entry in entries:
        if entry.key in seen:
            raise RegistryError(f"{source}: {entry.source}, {entry.quantity!r} is listed twice for "
                                f"model {entry.model}")
        seen.add(entry.key)
    return entries


def _band(doc: Mapping[str, Any], where: str) -> Band:
    tolerance = Tolerance(**doc["tolerance"]) if "tolerance" in doc else None
    if tolerance is not None and tolerance.factor is not None and tolerance.scale == "linear":
        raise RegistryError(f"{where}: a factor needs scale: log or log1m")
    return Band(doc["name"], doc["justification"], tolerance, doc.get("bound"))


def _entry(group: Mapping[str, Any], item: Mapping[str, Any], where: str) -> Entry:
    value = {**group, **item}
    published = value["published"]
    truth = published.get("truth") if isinstance(published, Mapping) else None
    section = group.get("section", PUBLISHED)
    locate = _locator({**group.get("locate", {}), **item.get("locate", {})}, where)
    if truth is not None and (section != RECOVERY or locate is None):
        raise RegistryError(f"{where}: published: {{truth: <column>}} needs section: {RECOVERY} and a "
                            "locate (the truth is read from the located row)")
    band = _band(value["band"], where)
    bound = value.get("bound", band.bound)
    if truth is None and band.tolerance is not None and band.tolerance.scale != "linear" and not bound:
        ref = published if band.tolerance.scale == "log" else 1 - published
        if ref <= 0:
            raise RegistryError(f"{where}: band {band.name!r} is on a log scale, which needs "
                                f"{'a positive value' if band.tolerance.scale == 'log' else 'a value below 1'}")
    cause = _cause(group.get("cause", {}), item.get("cause", {}), where)
    centre = _locator(item.get("centre", {}), where)
    if centre is not None and (value["kind"] != "recovery" or truth is not None):
        raise RegistryError(f"{where}: a centre is for a published recovery number (the twin's truth as "
                            "the source's model reads it); a twin recovery row reads its truth with published: {truth: ...}")
    return Entry(section=section, kind=value["kind"], chapter=group["chapter"], source=group["source"],
                 model=group["model"], quantity=item["quantity"], unit=value["unit"],
                 published=None if truth else float(published), band=band, bound=bound,
                 note=value.get("note", ""), locate=locate, truth=truth, printed=item.get("printed"),
                 cause=cause, centre=centre)


def _cause(group: Mapping[str, Any], item: Mapping[str, Any], where: str) -> Cause | None:
    """The group's cause merged with the entry's (entry wins, ``where`` merged key by key)."""
    if not group and not item:
        return None
    merged = {**group, **item, "where": {**group.get("where", {}), **item.get("where", {})}}
    cause = Cause(merged.get("table", BUDGET_TABLE), tuple(merged["where"].items()), merged.get("statistic", "max"),
                  tuple(merged.get("quote", ())), tuple(merged.get("located", ())))
    if not cause.quote and cause.table not in CAUSE_TABLES:
        raise RegistryError(f"{where}: cause table {cause.table!r} is none of {', '.join(CAUSE_TABLES)}: "
                            "another table's cause names the columns it quotes")
    if cause.quote and cause.statistic != "max":
        raise RegistryError(f"{where}: a cause that quotes columns has no statistic")
    return cause


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
    return list(dict.fromkeys([e.locate.table for e in entries if e.locate]
                              + [e.cause.table for e in entries if e.cause]
                              + [e.centre.table for e in entries if e.centre]))


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
    value = pd.to_numeric(_one_row(table, locator.where, locator.table)[column], errors="coerce")
    if pd.isna(value):
        raise NotComputed(f"{locator.describe()} is empty")
    return float(value) * locator.scale


def _one_row(table: pd.DataFrame, where: Sequence[tuple[str, Any]], name: str) -> pd.Series:
    """The one row of ``table`` (called ``name`` in errors) that ``where`` selects; LookupError else."""
    absent = [k for k, _ in where if k not in table.columns]
    if absent:
        raise LookupError(f"{name} has no column {absent[0]!r}")
    match = np.ones(len(table), dtype=bool)
    for key, wanted in where:
        match &= _matches(table[key], wanted)
    if match.sum() != 1:
        raise LookupError(f"{int(match.sum())} rows of {name} match "
                          f"{', '.join(f'{k} = {v}' for k, v in where) or '(no selector)'}")
    return table.loc[match].iloc[0]


def _matches(column: pd.Series, wanted: Any) -> np.ndarray:
    if isinstance(wanted, (int, float)) and not isinstance(wanted, bool):
        numbers = pd.to_numeric(column, errors="coerce").to_numpy(dtype=float)
        return np.isclose(numbers, wanted, rtol=1e-9, atol=0.0)
    return (column.astype(str) == str(wanted)).to_numpy()


def score(entry: Entry, tables: Mapping[str, pd.DataFrame]) -> Score:
    """Score one entry against the tables made for a dataset (relative path → table)."""
    published = math.nan if entry.published is None else entry.published
    if entry.locate is None:
        return Score(entry, published, band(published, entry), detail="no stage makes this number yet")
    if entry.locate.table not in tables:
        return Score(entry, published, band(published, entry),
                     detail=f"{entry.locate.table} is not made for this dataset")
    table = tables[entry.locate.table]
    centre = entry.centre if entry.centre is not None and entry.centre.table in tables else None
    try:
        if entry.truth is not None:
            published = lookup(entry.locate, table, entry.truth)
        reproduced = lookup(entry.locate, table)
        middle = published if centre is None else lookup(centre, tables[centre.table])
    except NotComputed as err:  # the stage's own statement that it has no value (say, a short campaign)
        return Score(entry, published, band(published, entry), detail=f"{LEFT_OUT}{err}")
    except LookupError as err:  # the table no longer has the row or column: a locator to fix
        return Score(entry, published, band(published, entry), verdict=MISSING, detail=str(err))
    detail = "" if centre is None else f"band centred on the model on the twin's truth, {middle:.4g} ({centre.describe()})"
    limits = band(middle, entry)
    verdict = INFORMATION if entry.tolerance is None else judge(reproduced, *limits)
    cause, measured = "", entry.cause
    if measured and measured.located:
        measured = measured.at(_one_row(table, entry.locate.where, entry.locate.table), entry.locate.table)
    if measured and measured.table in tables:
        cause = measured.note(tables[measured.table])
    return Score(entry, published, limits, reproduced, verdict, detail, cause)


def scorecard(entries: Sequence[Entry], tables: Mapping[str, pd.DataFrame], manifest: Mapping[str, Any]) -> pd.DataFrame:
    """One row per registry entry that applies to the dataset, in registry order."""
    return pd.DataFrame([_row(score(e, tables)) for e in applicable(entries, manifest)], columns=COLUMNS)


def _row(s: Score) -> dict[str, Any]:
    e, p, r = s.entry, s.published, s.reproduced
    lo, hi = s.band
    return {
        "section": e.section, "kind": e.kind, "chapter": e.chapter, "source": e.source, "quantity": e.quantity,
        "unit": e.unit, "published": p, "reproduced": r,
        "deviation": None if r is None else r - p,
        "deviation [%]": None if r is None or p == 0 else 100.0 * (r - p) / abs(p),
        "band low": lo if math.isfinite(lo) else None, "band high": hi if math.isfinite(hi) else None,
        "band": e.band.name, "tolerance": _tolerance_text(e, p), "justification": e.band.justification,
        "verdict": s.verdict, "read from": e.locate.describe() if e.locate else "",
        "note": "; ".join(t for t in (s.detail, e.note, s.cause) if t),
    }


def _tolerance_text(e: Entry, published: float) -> str:
    if e.tolerance is None:
        return "no verdict"
    if not e.bound:
        return e.tolerance.describe(e.unit)
    lo, hi = e.tolerance.limits(published, e.printed) if not math.isnan(published) else (published, published)
    sign, widen, edge = ("≤", "+", hi) if e.bound == "upper" else ("≥", "−", lo)
    return f"{sign} published" + (f" {widen} {abs(edge - published):g}" if edge != published else "")


def counts(card: pd.DataFrame) -> dict[str, int]:
    return {v: int((card["verdict"] == v).sum()) for v in VERDICTS}


# --- renderings ---------------------------------------------------------------------------------

def summary(cards: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """Counts per dataset, kind and chapter (and a "total" row per dataset and kind): the numbers
    the report's opening and the README quote. ``reproduced`` = within + out of band."""
    rows = []
    for dataset, card in cards.items():
        for kind in KINDS:
            part = card[card["kind"] == kind]
            if not len(part):
                continue
            groups = [(str(c), g) for c, g in part.groupby("chapter", sort=False)] + [("total", part)]
            for chapter, g in groups:
                n = counts(g)
                rows.append({"dataset": dataset, "kind": kind, "chapter": chapter, "numbers": len(g),
                             "reproduced": n[WITHIN] + n[OUT], **n})
    return pd.DataFrame(rows, columns=["dataset", "kind", "chapter", "numbers", "reproduced", *VERDICTS])


def headline(counts_: pd.DataFrame) -> str:
    """One line per dataset: emergent numbers within band, then the other kinds."""
    lines = []
    for dataset, part in counts_[counts_["chapter"] == "total"].groupby("dataset", sort=False):
        by_kind = part.set_index("kind")
        parts = [f"**{_rst(dataset)}**: " + (_kind_tally(by_kind.loc[EMERGENT], "emergent") if EMERGENT in by_kind.index
                                            else "no emergent numbers")]
        parts += [_kind_tally(by_kind.loc[k], k) for k in KINDS[1:] if k in by_kind.index]
        lines.append("; ".join(parts) + ".")
    return "\n\n".join(lines)


def _kind_tally(row: pd.Series, kind: str) -> str:
    text = f"{kind} {row[WITHIN]} within band of {row['reproduced']}"
    extra = [f"{row[v]} {v}" for v in (NOT_YET, MISSING, INFORMATION) if row[v]]
    return text + (f" ({', '.join(extra)})" if extra else "")


def landing_rst(cards: Mapping[str, pd.DataFrame]) -> str:
    """The short summary that opens the report: the emergent numbers (the reproduction proper) per
    chapter, then the other kinds. The long lists are pages of their own (`out_of_band_rst`,
    `pending_rst`): the report's landing text is centred vertically, so a long one starts above the
    top of the window, out of reach."""
    table = summary(_filled(cards))
    return headline(table) + "\n\n" + "\n".join(_table(table[table["kind"] == EMERGENT], "Emergent numbers by chapter")) \
        + "\n\nClosed-form, recovery and calibration numbers are checks of the method and the twin, not " \
          "reproductions (docs/scorecard.md, \"Kinds of numbers\").\n"


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


def _table(table: pd.DataFrame, title: str) -> list[str]:
    lines = [f".. list-table:: {title}", "   :header-rows: 1", "",
             "   * - dataset", "     - chapter", "     - within band", "     - out of band", "     - not reproduced yet"]
    for _, row in table.iterrows():
        lines += [f"   * - {_rst(row['dataset'])}", f"     - {_chapter(row['chapter'])}",
                  *(f"     - {row[v]}" for v in (WITHIN, OUT, NOT_YET))]
    return lines


def _tally(dataset: str, card: pd.DataFrame) -> str:
    return headline(summary({dataset: card}))


def _out_of_band(card: pd.DataFrame) -> list[str]:
    out = card[card["verdict"] == OUT]
    if not len(out):
        return []
    unexplained = int((out["note"] == "").sum())
    measured = int(out["note"].str.contains(rf"(?:^|; ){CAUSE_MARK} (?:cause )?\(").sum())
    counts = [f"{measured} of {len(out)} with a measured cause"]
    if unexplained:
        counts.append(f"{unexplained} without a note in workflow/scorecard.yaml saying why")
    return [f"- Out of band, by source ({'; '.join(counts)}):",
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
    return f"Chapter {chapter}" if str(chapter).isdigit() else _rst(str(chapter))


def _describe(row: pd.Series) -> str:
    unit = _rst(f" {row['unit']}" if row["unit"] else "")
    lo, hi = row["band low"], row["band high"]
    band_text = (f"≤ {hi:.6g}" if pd.isna(lo) else f"≥ {lo:.6g}" if pd.isna(hi) else f"{lo:.6g} … {hi:.6g}")
    change = "" if pd.isna(row["deviation [%]"]) else f" ({row['deviation [%]']:+.1f} %)"
    kind = "" if row.get("kind", EMERGENT) == EMERGENT else f" ({row['kind']})"
    return (f"{_rst(row['quantity'])}{kind}: published {row['published']:.6g}{unit}, "
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


def printed(entries: Sequence[Entry], model: str, source: str, quantity: str) -> float:
    """A published number as the registry lists it (for an analysis that needs the source's own
    values, say to compare a fitted curve with the printed one)."""
    for e in entries:
        if (e.model, e.source, e.quantity) == (model, source, quantity) and e.published is not None:
            return e.published
    raise RegistryError(f"the registry lists no {source}, {quantity!r} for model {model}")


#: the stroke the printed Γ and Γ_T run over (their fits' position range)
THESIS_STROKE = ("Table 5.4", "max stroke, 0.1 Hz")


def printed_gamma(entries: Sequence[Entry], source: str, coefficients: Sequence[str], g: str | None = None):
    """The Γ (Table 5.2) or Γ_T (Table 7.3) ``source`` prints, from the registry's ``coefficients``
    (b0…b5) and ``g``, and the stroke [µm] its C range spans (:func:`selfsense.gamma.printed_range`)."""
    from .gamma import GammaPolynomial

    gamma = GammaPolynomial(tuple(printed(entries, "stack", source, q) for q in coefficients),
                            printed(entries, "stack", source, g) if g else 0.0)
    return gamma, printed(entries, "stack", *THESIS_STROKE)


# --- the numbers the documentation quotes ---------------------------------------------------------

#: a block of a Markdown page written by scripts/update_docs.py (never by hand) sits between these
BEGIN, END = "<!-- scorecard:{name} begin (scripts/update_docs.py writes this block) -->", "<!-- scorecard:{name} end -->"


def counts_markdown(counts_: pd.DataFrame, campaign: str) -> str:
    """The README's numbers: emergent published numbers within band per dataset and chapter, then
    the other kinds, from the summary the pipeline writes (results/scorecard_counts.csv)."""
    lines = [f"Published numbers within their band on the `{campaign}` campaign (from `results/scorecard_counts.csv`):",
             "", "| dataset | chapter | emergent: within band / reproduced | closed form | recovery | calibration |",
             "|---|---|---|---|---|---|"]
    for (dataset, chapter), part in counts_.groupby(["dataset", "chapter"], sort=False):
        cells = {row["kind"]: f"{row[WITHIN]} / {row['reproduced']}" for _, row in part.iterrows()}
        name = "**total**" if chapter == "total" else _chapter(chapter)
        lines.append(f"| {dataset} | {name} | " + " | ".join(cells.get(k, "–") for k in KINDS) + " |")
    return "\n".join(lines)


def deviations_markdown(cards: Mapping[str, pd.DataFrame]) -> str:
    """docs/deviations.md's list: every emergent number out of band, per dataset and chapter, with
    published and reproduced values and the registry's note."""
    lines = []
    for dataset, card in _filled(cards).items():
        out = card[(card["kind"] == EMERGENT) & (card["verdict"] == OUT)]
        lines += [f"**{dataset}**: {len(out)} emergent numbers out of band.", ""]
        for chapter, part in out.groupby("chapter", sort=False):
            lines.append(f"- {_chapter(chapter)}:")
            for _, row in part.iterrows():
                unit = f" {row['unit']}" if row["unit"] else ""
                lines.append(f"  - {row['source']}, {row['quantity']}: {row['published']:.4g} → {row['reproduced']:.4g}{unit}")
        lines.append("")
    return "\n".join(lines).rstrip()


def replace_block(text: str, name: str, body: str) -> str:
    """``text`` with its generated block ``name`` replaced by ``body``."""
    begin, end = BEGIN.format(name=name), END.format(name=name)
    head, sep, rest = text.partition(begin)
    _, sep2, tail = rest.partition(end)
    if not (sep and sep2):
        raise ValueError(f"no block {name!r} ({begin} … {end})")
    return f"{head}{begin}\n{body}\n{end}{tail}"
