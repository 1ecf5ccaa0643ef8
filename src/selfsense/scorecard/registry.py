"""The scorecard's registry: every published number once (workflow/scorecard.yaml, schema
selfsense/io/schemas/scorecard.schema.yaml), the band it must land in and the reason for that band,
where its reproduction is read from (one cell of a results table), and its kind.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from selfsense.io.manifest import ManifestError, validate_document

WITHIN = "within band"
OUT = "out of band"
NOT_YET = "not reproduced yet"
MISSING = "missing from table"
INFORMATION = "information (no verdict)"
VERDICTS = (WITHIN, OUT, NOT_YET, MISSING, INFORMATION)

PUBLISHED = "published"
RECOVERY = "twin recovery"

#: what kind of number a row is (docs/scorecard.md); only `emergent` ones count as reproduced.
#: `check`: holds by construction (the twin's model is the analysis's own, or the band cannot fail)
KINDS = ("emergent", "closed form", "recovery", "calibration", "check")
EMERGENT = "emergent"
CHECK = "check"
#: the summary's line (its `kind` column) that counts the model's bias of the recovery rows centred
#: on the model on the twin's truth, by their bias verdict (docs/scorecard.md, "The model's bias")
BIAS = "model's bias"

#: the columns of a recovery row's second verdict: the model on the twin's truth (the band's
#: centre) against the value the twin is built with, held to the band's bias rule
BIAS_COLUMNS = [
    "model on truth",
    "bias",
    "bias [%]",
    "bias band",
    "bias band low",
    "bias band high",
    "bias verdict",
]

COLUMNS = [
    "section",
    "kind",
    "chapter",
    "source",
    "quantity",
    "unit",
    "published",
    "reproduced",
    "deviation",
    "deviation [%]",
    "band low",
    "band high",
    "band",
    "tolerance",
    "justification",
    "verdict",
    *BIAS_COLUMNS,
    "read from",
    "note",
]

#: a value this close to a band edge (relative) counts as on it: CSV round trips are not exact
EDGE_RTOL = 1e-9
#: how a scorecard note starts when the stage made the table but left the number out
LEFT_OUT = "left out by its stage: "
#: the observer's error budget (rule error_budget, twin datasets only): what an entry's `cause`
#: reads unless it names another of CAUSE_TABLES
BUDGET_TABLE = "twin/error_budget.csv"
#: the error budgets a `cause` can read (twin datasets only), and the error each splits
#: how a measured cause's part of a note starts (Cause.note), which the summary counts by
CAUSE_MARK = "Measured"

CAUSE_TABLES = {
    BUDGET_TABLE: "the observer error",
    "twin/tracking_budget.csv": "the tracking error",
    "twin/charge_budget.csv": "the charge–position error",
    "twin/controller_budget.csv": "the controller error",
}


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
        factor = (
            self.factor if self.factor is not None else 1.0 + self.half_width(ref, printed) / ref
        )
        if self.scale == "log":
            return ref / factor, ref * factor
        return 1.0 - ref * factor, 1.0 - ref / factor

    def describe(self, unit: str) -> str:
        unit = f" {unit}" if unit else ""
        text = (
            f"±{self.abs:g}{unit}"
            if self.abs is not None
            else f"±{self.rel:g} %"
            if self.rel is not None
            else f"±{self.digit:g} of the last printed digit"
            if self.digit is not None
            else f"×/÷ {self.factor:g}"
        )
        if self.scale == "log" and self.factor is None:
            text = f"+{text.removeprefix('±')}, same factor below"
        return text + {"linear": "", "log": "", "log1m": " on 1 − value"}[self.scale]


def last_digit(printed: str) -> float:
    """The value of one unit of the last digit of a number as printed:
    '0.637' → 0.001, '400' → 1."""
    mantissa, _, exponent = printed.lower().partition("e")
    decimals = len(mantissa.partition(".")[2].rstrip()) if "." in mantissa else 0
    return 10.0 ** (int(exponent or 0) - decimals)


@dataclass(frozen=True)
class Band:
    """The rule for one kind of quantity: its tolerance (None: information, no verdict), the side
    it bounds when the source states a bound, and the reason, written once in the registry.

    ``bias``: for a band centred on the model on the twin's truth, the rule that centre is held to
    about the value the twin is built with (the model's bias, a second verdict of its own)."""

    name: str
    justification: str
    tolerance: Tolerance | None = None
    bound: str | None = None  # "upper" | "lower" when the rule itself is a bound (a scatter)
    bias: Band | None = None


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
    the spread over P1's tests of each test's max
    (:func:`selfsense.verify.error_budget.spread_over_spans`); any other table is quoted: its
    ``quote`` columns, which the entry's note interprets. The ``located`` columns are selected by
    their values in the entry's own located row: a number stated at the segment its table names
    (P1's worst) is explained at that segment.
    """

    table: str = BUDGET_TABLE
    where: tuple[tuple[str, Any], ...] = ()
    statistic: str = "max"
    quote: tuple[str, ...] = ()
    located: tuple[str, ...] = ()

    def at(self, row: pd.Series, name: str) -> Cause:
        """The cause with its ``located`` columns selected at their values in ``row`` (of table
        ``name``)."""
        absent = [c for c in self.located if c not in row.index]
        if absent:
            raise LookupError(f"{name} has no column {absent[0]!r} to select the cause's row by")
        return replace(
            self, where=self.where + tuple((c, row[c]) for c in self.located), located=()
        )

    def note(self, table: pd.DataFrame, largest: int = 3) -> str:
        """The scorecard's note from the table this cause names."""
        row = one_row(table, self.where, self.table)
        selector = ", ".join(f"{k} = {v}" for k, v in self.where)
        if self.quote:
            absent = [c for c in self.quote if c not in table.columns]
            if absent:
                raise LookupError(f"{self.table} has no column {absent[0]!r}")
            return f"{CAUSE_MARK} ({self.table}, {selector}): " + ", ".join(
                f"{c} = {_quoted(row[c])}" for c in self.quote
            )
        # imported here: the workflow reads the registry when it is parsed, and the budget's module
        # brings numba with it
        from selfsense.verify.error_budget import AT_MAX, AT_MAX_SPREAD

        if self.statistic == "σ":
            suffix, style = AT_MAX_SPREAD, ".3f"
            head = (
                f"σ over the tests of {CAUSE_TABLES[self.table]}'s max, "
                f"{float(row['total max σ over tests [µm]']):.3f} µm; "
                "the σ of its largest sources at each test's max are "
            )
        else:
            suffix, style = AT_MAX, "+.2f"
            head = (
                f"at {CAUSE_TABLES[self.table]}'s max, {float(row['total at max [µm]']):+.2f} µm, "
                "its largest sources are "
            )
        sources = {
            c.removesuffix(suffix): float(row[c])
            for c in table.columns
            if c.endswith(suffix) and pd.notna(row[c])
        }
        top = sorted(sources.items(), key=lambda kv: -abs(kv[1]))[:largest]
        return (
            f"{CAUSE_MARK} cause ({self.table}, {selector}): {head}"
            + ", ".join(f"{name} {value:{style}}" for name, value in top)
            + " µm"
        )


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
    centre: Locator | None = (
        None  # the model on the twin's truth the band is centred on, if not the published
    )
    built: str | None = None  # twin recovery against the model on truth: the built value's column
    #: the quantity of the same source's entry this one is an algebraic function of (a % of
    #: stroke beside its µm row): one finding with it wherever findings are counted
    twin: str | None = None

    @property
    def key(self) -> tuple[str, str, str]:
        return self.model, self.source, self.quantity

    @property
    def tolerance(self) -> Tolerance | None:
        return self.band.tolerance


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
                raise RegistryError(
                    f"{where}: its band is named {named.name!r} like a rule of `bands:` "
                    "but differs from it: name the rule by its alias, "
                    "or give the band a name of its own"
                )
    seen: set[tuple[str, str, str]] = set()
    for entry in entries:
        if entry.key in seen:
            raise RegistryError(
                f"{source}: {entry.source}, {entry.quantity!r} is listed twice for "
                f"model {entry.model}"
            )
        seen.add(entry.key)
    _check_twins(entries, source)
    return entries


def _check_twins(entries: Sequence[Entry], source: str) -> None:
    """Every ``twin`` names an entry of the same model and source, of the same kind, that is no
    twin itself (a pair, not a chain: the pair is counted by the named entry's verdict)."""
    by_key = {e.key: e for e in entries}
    for entry in entries:
        if entry.twin is None:
            continue
        where = f"{source}: {entry.source}, {entry.quantity!r}: twin {entry.twin!r}"
        other = by_key.get((entry.model, entry.source, entry.twin))
        if other is None:
            raise RegistryError(f"{where} is no entry of the same source and model")
        if other.twin is not None or other.kind != entry.kind or other is entry:
            raise RegistryError(
                f"{where} must be another entry of the same kind that names no twin itself"
            )


def _band(doc: Mapping[str, Any], where: str) -> Band:
    tolerance = Tolerance(**doc["tolerance"]) if "tolerance" in doc else None
    if tolerance is not None and tolerance.factor is not None and tolerance.scale == "linear":
        raise RegistryError(f"{where}: a factor needs scale: log or log1m")
    bias = _band(doc["bias"], f"{where} (its bias)") if "bias" in doc else None
    if bias is not None and (bias.tolerance is None or bias.bound or bias.bias):
        raise RegistryError(
            f"{where}: the bias rule {bias.name!r} needs a tolerance, two-sided, "
            "and no bias of its own"
        )
    return Band(doc["name"], doc["justification"], tolerance, doc.get("bound"), bias)


def _entry(group: Mapping[str, Any], item: Mapping[str, Any], where: str) -> Entry:
    value = {**group, **item}
    published = value["published"]
    truth = published.get("truth") if isinstance(published, Mapping) else None
    built = published.get("built") if isinstance(published, Mapping) else None
    section = group.get("section", PUBLISHED)
    locate = _locator({**group.get("locate", {}), **item.get("locate", {})}, where)
    if truth is not None and (section != RECOVERY or locate is None):
        raise RegistryError(
            f"{where}: published: {{truth: <column>}} needs section: {RECOVERY} and a "
            "locate (the truth is read from the located row)"
        )
    band = _band(value["band"], where)
    bound = value.get("bound", band.bound)
    if (
        truth is None
        and band.tolerance is not None
        and band.tolerance.scale != "linear"
        and not bound
    ):
        ref = published if band.tolerance.scale == "log" else 1 - published
        if ref <= 0:
            raise RegistryError(
                f"{where}: band {band.name!r} is on a log scale, which needs "
                f"{'a positive value' if band.tolerance.scale == 'log' else 'a value below 1'}"
            )
    cause = _cause(group.get("cause", {}), item.get("cause", {}), where)
    centre = _locator(item.get("centre", {}), where)
    if centre is not None and (value["kind"] != "recovery" or truth is not None):
        raise RegistryError(
            f"{where}: a centre is for a published recovery number (the twin's truth as "
            "the source's model reads it); "
            "a twin recovery row reads its truth with published: {truth: ...}"
        )
    on_truth = centre is not None or built is not None
    if on_truth and band.bias is None:
        raise RegistryError(
            f"{where}: band {band.name!r} is centred on the model on the twin's truth, so it "
            "needs a bias rule (bias:) to hold that centre to the built value"
        )
    if band.bias is not None and not on_truth:
        raise RegistryError(
            f"{where}: band {band.name!r} judges the model's bias, which needs the model on "
            "truth: a centre, or published: {truth: <its column>, built: <the built value's>}"
        )
    return Entry(
        section=section,
        kind=value["kind"],
        chapter=group["chapter"],
        source=group["source"],
        model=group["model"],
        quantity=item["quantity"],
        unit=value["unit"],
        published=None if truth else float(published),
        band=band,
        bound=bound,
        note=value.get("note", ""),
        locate=locate,
        truth=truth,
        printed=item.get("printed"),
        cause=cause,
        centre=centre,
        built=built,
        twin=item.get("twin"),
    )


def _cause(group: Mapping[str, Any], item: Mapping[str, Any], where: str) -> Cause | None:
    """The group's cause merged with the entry's (entry wins, ``where`` merged key by key)."""
    if not group and not item:
        return None
    merged = {**group, **item, "where": {**group.get("where", {}), **item.get("where", {})}}
    cause = Cause(
        merged.get("table", BUDGET_TABLE),
        tuple(merged["where"].items()),
        merged.get("statistic", "max"),
        tuple(merged.get("quote", ())),
        tuple(merged.get("located", ())),
    )
    if not cause.quote and cause.table not in CAUSE_TABLES:
        raise RegistryError(
            f"{where}: cause table {cause.table!r} is none of {', '.join(CAUSE_TABLES)}: "
            "another table's cause names the columns it quotes"
        )
    if cause.quote and cause.statistic != "max":
        raise RegistryError(f"{where}: a cause that quotes columns has no statistic")
    return cause


def _locator(locate: Mapping[str, Any], where: str) -> Locator | None:
    if not locate:
        return None
    if "table" not in locate or "column" not in locate:
        raise RegistryError(
            f"{where}: locate needs both table and column (or neither, while no "
            "stage makes the table)"
        )
    return Locator(
        locate["table"],
        locate["column"],
        tuple(locate.get("where", {}).items()),
        float(locate.get("scale", 1.0)),
    )


def applicable(entries: Sequence[Entry], manifest: Mapping[str, Any]) -> list[Entry]:
    """Entries for this dataset's actuator (none for a model absent or ``other``: a foreign
    actuator has no published numbers here); twin recovery only where the twin made the
    captures; no published rows where the dataset gives its own reference values (they replace
    the source's: :mod:`selfsense.scorecard.reference_values`)."""
    return [
        e
        for e in entries
        if e.model == manifest.get("model")
        and (e.section != RECOVERY or ("twin" in manifest and manifest.get("source") != "measured"))
        and (e.section != PUBLISHED or "reference" not in manifest)
    ]


def tables_read(entries: Sequence[Entry]) -> list[str]:
    """Tables (relative to results/<dataset>/) the entries read, in registry order."""
    return list(
        dict.fromkeys(
            [e.locate.table for e in entries if e.locate]
            + [e.cause.table for e in entries if e.cause]
            + [e.centre.table for e in entries if e.centre]
        )
    )


def printed(entries: Sequence[Entry], model: str, source: str, quantity: str) -> float:
    """A published number as the registry lists it (for an analysis that needs the source's own
    values, say to compare a fitted curve with the printed one)."""
    for e in entries:
        if (e.model, e.source, e.quantity) == (model, source, quantity) and e.published is not None:
            return e.published
    raise RegistryError(f"the registry lists no {source}, {quantity!r} for model {model}")


#: the stroke the printed Γ and Γ_T run over (their fits' position range)
THESIS_STROKE = ("Table 5.4", "max stroke, 0.1 Hz")


def printed_gamma(
    entries: Sequence[Entry], source: str, coefficients: Sequence[str], g: str | None = None
):
    """The Γ (Table 5.2) or Γ_T (Table 7.3) ``source`` prints, from the registry's ``coefficients``
    (b0…b5) and ``g``, and the stroke [µm] its C range spans
    (:func:`selfsense.methods.gamma.printed_range`)."""
    from selfsense.methods.gamma import GammaPolynomial

    gamma = GammaPolynomial(
        tuple(printed(entries, "stack", source, q) for q in coefficients),
        printed(entries, "stack", source, g) if g else 0.0,
    )
    return gamma, printed(entries, "stack", *THESIS_STROKE)


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
    value = pd.to_numeric(one_row(table, locator.where, locator.table)[column], errors="coerce")
    if pd.isna(value):
        raise NotComputed(f"{locator.describe()} is empty")
    return float(value) * locator.scale


def one_row(table: pd.DataFrame, where: Sequence[tuple[str, Any]], name: str) -> pd.Series:
    """The one row of ``table`` (called ``name`` in errors) that ``where`` selects; LookupError
    else."""
    absent = [k for k, _ in where if k not in table.columns]
    if absent:
        raise LookupError(f"{name} has no column {absent[0]!r}")
    match = np.ones(len(table), dtype=bool)
    for key, wanted in where:
        match &= _matches(table[key], wanted)
    if match.sum() != 1:
        raise LookupError(
            f"{int(match.sum())} rows of {name} match "
            f"{', '.join(f'{k} = {v}' for k, v in where) or '(no selector)'}"
        )
    return table.loc[match].iloc[0]


def _matches(column: pd.Series, wanted: Any) -> np.ndarray:
    if isinstance(wanted, (int, float)) and not isinstance(wanted, bool):
        numbers = pd.to_numeric(column, errors="coerce").to_numpy(dtype=float)
        return np.isclose(numbers, wanted, rtol=1e-9, atol=0.0)
    return (column.astype(str) == str(wanted)).to_numpy()
