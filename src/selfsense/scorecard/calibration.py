"""The twin's calibration: the thesis's signatures its free parameters are set to meet, and how far
the twin lands from each (docs/twin.md, "Calibration").

A signature is one published number that a free parameter of the twin (the Maxwell loop, the
ripple's phase and R_e slope, the heat transfer coefficient) sets rather than the physics the
thesis describes: the feedforward error and loop widths of Chapter 3 and Table 6.2, the ripple's
phase (Fig 3.4), the stroke (Table 5.4) and U_P at its top (Table 4.3), the steady temperature and
τ of Chapter 7 (Table 7.1). The targets are data (workflow/twin_calibration.yaml, schema
selfsense/io/schemas/twin_calibration.schema.yaml): the thesis's value, a band with its reason, and
the cell of the pipeline's own tables that holds the twin's value, located as the scorecard locates
its numbers. The same targets judge the campaign's tables (rule twin_calibration) and the short
runs of a calibration search (scripts/calibrate_twin.py). Pure: documents and tables in, a table
out.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from selfsense.io.manifest import ManifestError, load_yaml, validate_document
from selfsense.scorecard.registry import WITHIN, Locator, NotComputed, lookup
from selfsense.scorecard.scoring import judge

#: the columns of results/<dataset>/twin/calibration.csv
COLUMNS = [
    "signature",
    "thesis source",
    "thesis says",
    "thesis value",
    "twin value",
    "unit",
    "band low",
    "band high",
    "within",
    "source table",
    "justification",
    "note",
]


@dataclass(frozen=True)
class Target:
    """One signature: the thesis's value, the band [low, high] the twin's must land in, and where
    the pipeline's tables hold the twin's value."""

    id: str
    signature: str
    source: str
    thesis_says: str
    thesis: float
    unit: str
    low: float
    high: float
    justification: str
    locate: Locator

    def within(self, value: float) -> bool:
        """Inside the band, edges included (as the scorecard judges: a CSV round trip is not
        exact)."""
        return judge(value, self.low, self.high) == WITHIN

    def distance(self, value: float, margin: float = 0.0) -> float:
        """How far outside the band, in band widths: 0 inside, 1 a whole width beyond an edge; with
        a ``margin`` (in band widths) the band is narrowed by it at both edges first."""
        width = self.high - self.low
        low, high = self.low + margin * width, self.high - margin * width
        return max(low - value, value - high, 0.0) / width


@dataclass(frozen=True)
class Calibration:
    """The targets, and the free parameters (<section>.<key> of a twin block) a search may move,
    each within its [low, high]."""

    targets: tuple[Target, ...]
    free: Mapping[str, tuple[float, float]]

    def tables(self) -> list[str]:
        """Tables (relative to results/<dataset>/) the targets read, in order."""
        return list(dict.fromkeys(t.locate.table for t in self.targets))


def parse_targets(doc: Any, source: str | Path = "workflow/twin_calibration.yaml") -> Calibration:
    """The targets document validated against its schema, with the checks a schema cannot make:
    bands in order, ids unique."""
    validate_document(doc, "twin_calibration.schema.yaml", source)
    targets = []
    for i, item in enumerate(doc["signatures"]):
        low, high = item["band"]
        if not low < high:
            raise ManifestError(
                f"{source}: key signatures.{i}.band: [{low:g}, {high:g}] must be [low, high] "
                "with low < high"
            )
        where = item["locate"].get("where", {})
        targets.append(
            Target(
                item["id"],
                item["signature"],
                item["source"],
                item["thesis_says"],
                float(item["thesis"]),
                item["unit"],
                float(low),
                float(high),
                item["justification"],
                Locator(item["locate"]["table"], item["locate"]["column"], tuple(where.items())),
            )
        )
    ids = [t.id for t in targets]
    twice = sorted({i for i in ids if ids.count(i) > 1})
    if twice:
        raise ManifestError(f"{source}: signature id {twice[0]!r} is listed twice")
    free = {}
    for name, (low, high) in doc["free"].items():
        if not low < high:
            raise ManifestError(
                f"{source}: key free.{name}: [{low:g}, {high:g}] "
                "must be [low, high] with low < high"
            )
        free[name] = (float(low), float(high))
    return Calibration(tuple(targets), free)


def load_targets(path: str | Path) -> Calibration:
    return parse_targets(load_yaml(path), path)


def calibration_table(
    targets: tuple[Target, ...] | list[Target], tables: Mapping[str, pd.DataFrame]
) -> pd.DataFrame:
    """One row per target: the twin's value read from ``tables`` (relative path → table, the ones
    made for a dataset) and whether it lands in the band. A table not made for the dataset, or
    one whose stage left the number out (a campaign too short to identify τ), gives a row that
    says "not measured" and why; a locator that no longer fits its table raises LookupError
    (a target to fix, as in the scorecard)."""
    rows = []
    for t in targets:
        row = {
            "signature": t.signature,
            "thesis source": t.source,
            "thesis says": t.thesis_says,
            "thesis value": t.thesis,
            "twin value": None,
            "unit": t.unit,
            "band low": t.low,
            "band high": t.high,
            "within": None,
            "source table": t.locate.describe(),
            "justification": t.justification,
            "note": "",
        }
        if t.locate.table not in tables:
            row["note"] = f"not measured (no {t.locate.table})"
        else:
            try:
                value = lookup(t.locate, tables[t.locate.table])
            except NotComputed as err:
                row["note"] = f"not measured ({err})"
            else:
                row |= {"twin value": value, "within": t.within(value)}
        rows.append(row)
    return pd.DataFrame(rows, columns=COLUMNS)
