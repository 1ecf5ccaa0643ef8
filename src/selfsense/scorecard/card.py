"""A dataset's whole scorecard: the registry's rows that apply to it, then its own reference
values' (:mod:`selfsense.scorecard.reference_values`), and the tables that card reads (rule
`scorecard`'s inputs)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

from selfsense.scorecard.reference_values import reference_rows, tables_read
from selfsense.scorecard.registry import Entry, applicable
from selfsense.scorecard.registry import tables_read as registry_tables
from selfsense.scorecard.scoring import scorecard


def dataset_tables(registry: Sequence[Entry], manifest: Mapping[str, Any]) -> list[str]:
    """Every table (relative to results/<dataset>/) a dataset's scorecard reads: those of the
    ``registry``'s entries that apply to it, then those of its own reference values."""
    return registry_tables(applicable(registry, manifest)) + tables_read(manifest)


def dataset_scorecard(
    registry: Sequence[Entry], tables: Mapping[str, pd.DataFrame], manifest: Mapping[str, Any]
) -> pd.DataFrame:
    """A dataset's scorecard: one row per ``registry`` entry that applies to it
    (:func:`selfsense.scorecard.scoring.scorecard`), then its reference values' rows
    (:func:`reference_rows`)."""
    card, own = scorecard(registry, tables, manifest), reference_rows(manifest, tables)
    if own.empty:  # concatenating an empty frame would turn the float columns to object (no %.10g)
        return card
    return own if card.empty else pd.concat([card, own], ignore_index=True)
