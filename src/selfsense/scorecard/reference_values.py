"""A measured dataset's own reference values (its manifest's ``reference:``, e.g. a data sheet's
stroke, capacitance, stiffness) beside what the pipeline measured, as scorecard rows.

They replace the source's published numbers for that dataset
(:func:`selfsense.scorecard.registry.applicable` drops those): a foreign actuator is graded against
its own data sheet, not the PI P-885's. The rows have the scorecard's columns and
``kind: emergent`` (the value comes out of the analysis of the captures, nothing in the pipeline
was set to give it); each band is the manifest's, set by whoever wrote the reference down, before
the result. :func:`selfsense.scorecard.card.dataset_scorecard` puts them after the registry's
rows: a dataset's whole card.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pandas as pd

from selfsense.scorecard.registry import Band, Entry, Locator, Tolerance
from selfsense.scorecard.scoring import scorecard

SECTION = "reference values"
KIND = "emergent"
CHARACTERISE = "characterise/summary.csv"

#: reference key: (quantity, unit, table, column); per-capture quantities are read from the row of
#: the capture the reference names, by default the one with the largest stroke
QUANTITIES = {
    "stroke_um": ("stroke", "µm", CHARACTERISE, "stroke [µm]"),
    "gain_um_per_V": (
        "gain x/U (least squares)",
        "µm/V",
        CHARACTERISE,
        "gain (least squares) [µm/V]",
    ),
    "loop_width_percent": (
        "x–U loop width",
        "% of stroke",
        CHARACTERISE,
        "x–U loop width [% of stroke]",
    ),
    "capacitance_uF": ("capacitance (q–U slope)", "µF", CHARACTERISE, "q–U slope [µF]"),
    "stiffness_N_per_um": (
        "stiffness (blocked force / free stroke)",
        "N/µm",
        "ch4/static_stiffness.csv",
        "k [N/µm]",
    ),
}


def tables_read(manifest: Mapping[str, Any]) -> list[str]:
    """Tables (relative to results/<dataset>/) the dataset's reference values are compared with."""
    return list(dict.fromkeys(QUANTITIES[k][2] for k in manifest.get("reference", {})))


def _capture(reference: Mapping[str, Any], tables: Mapping[str, pd.DataFrame]) -> str | None:
    if "experiment" in reference:
        return reference["experiment"]
    table = tables.get(CHARACTERISE)
    stroke = _heading(table, "stroke [µm]")
    if table is None or table[stroke].isna().all():
        return None
    return str(table.loc[table[stroke].idxmax(), "experiment"])


def _heading(table: pd.DataFrame | None, column: str) -> str:
    """The characterisation table's heading of ``column``, which names the channels' declared
    scalings where the dataset has them (:func:`selfsense.chapters.characterise.heading`)."""
    # imported here: the workflow reads this module when it is parsed, and characterise brings
    # matplotlib with it
    from selfsense.chapters.characterise import plain_heading

    found = [c for c in (table.columns if table is not None else ()) if plain_heading(c) == column]
    return found[0] if found else column


def entries(manifest: Mapping[str, Any], tables: Mapping[str, pd.DataFrame]) -> list[Entry]:
    """One scorecard entry per reference value of the manifest."""
    out = []
    for key, ref in manifest.get("reference", {}).items():
        quantity, unit, table, column = QUANTITIES[key]
        where = ()
        if table == CHARACTERISE:  # no capture with a stroke matches no row: "missing from table"
            column = _heading(tables.get(table), column)
            capture = _capture(ref, tables)
            where = (("experiment", capture or ""),)
            quantity = f"{quantity} ({capture})" if capture else quantity
        band = Band(
            "the dataset's own band",
            f"the manifest's band for its reference value ({ref['source']})",
            Tolerance(rel=float(ref["tolerance_percent"])),
        )
        out.append(
            Entry(
                section=SECTION,
                kind=KIND,
                chapter="reference",
                source=ref["source"],
                model=manifest.get("model"),
                quantity=quantity,
                unit=unit,
                published=float(ref["value"]),
                band=band,
                locate=Locator(table, column, where),
            )
        )
    return out


def reference_rows(manifest: Mapping[str, Any], tables: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """The scorecard rows of the dataset's reference values (empty when it gives none)."""
    return scorecard(entries(manifest, tables), tables, manifest)
