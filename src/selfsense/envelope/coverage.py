"""The method's own test with known truth: pseudo-theses.

A pseudo-thesis is a member drawn from the prior taken as "the bench": the twin's numbers at its
unknowns (with its own seed), rounded as the thesis prints them, in place of the published
values (version 1's bench, :data:`EXACT`), or those numbers plus a discrepancy drawn from each
column's declared class before the printing (version 2's, :data:`DISCREPANT`: the model the
predictive assumes, so only it can be covered at the nominal rate; the exact twin is covered
more often by as much as the discrepancy widens the intervals). Each goes through the same
leave-one-fold-out as the thesis
(:func:`selfsense.envelope.fold_prediction.predict_folds`), and each held-out row either lies
inside its posterior-predictive 95 % interval or not. Over many pseudo-theses the share inside
is the method's coverage, which must be near the nominal 95 % for the thesis's verdicts to mean
what they say; the PIT values F(z) of the held-out rows are uniform on [0, 1] when the
predictive is calibrated (Dawid 1984; Gneiting, Balabdaoui & Raftery 2007), and the histogram
shows how it fails otherwise (a hump: too wide; a U: too narrow; a slope: biased).

Arrays in, dataclasses out; nothing is read or written.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from selfsense.envelope.fold_prediction import INCOMPATIBLE, Columns, predict_folds
from selfsense.envelope.validation import inverse, transform


@dataclass(frozen=True)
class Coverage:
    """Per pseudo-thesis and held-out row: inside its 95 % interval (NaN where it had none: no
    region, not emulable, no verdict) and its PIT; the coverage over all, the PIT histogram,
    and how many pseudo-theses left some fold with no region."""

    inside: np.ndarray  # pseudo-theses × columns
    pit: np.ndarray  # pseudo-theses × columns
    coverage: float
    judged: int  # the held-out rows counted
    histogram: np.ndarray  # PIT counts in equal bins of [0, 1]
    incompatible: int


#: the pseudo-theses' two benches: a member's numbers alone (version 1's test), and the same
#: with a discrepancy drawn from each column's declared class (version 2's)
EXACT = "the twin exact"
DISCREPANT = "the twin and its discrepancy"


def benches(
    values: np.ndarray, md_sd: np.ndarray, discrepancy: Mapping[str, Any] | None
) -> dict[str, np.ndarray]:
    """The benches of the members' ``values`` (pseudo-theses × columns, transformed scales):
    :data:`EXACT` always; :data:`DISCREPANT` when the declaration draws a discrepancy (its
    ``seed``): each column plus an independent normal draw of its sd ``md_sd``, the model the
    posterior predictive assumes (Kennedy & O'Hagan 2001)."""
    out = {EXACT: np.atleast_2d(values)}
    if discrepancy:
        draw = np.random.default_rng(int(discrepancy["seed"])).standard_normal(out[EXACT].shape)
        out[DISCREPANT] = out[EXACT] + draw * np.asarray(md_sd, dtype=float)
    return out


def printed(values: np.ndarray, transforms: Sequence[str], digits: np.ndarray) -> np.ndarray:
    """Outputs on their transformed scales as the thesis would print them: back to the quantity,
    rounded to each column's last printed digit, and transformed again."""
    values = np.atleast_2d(values)
    out = np.empty_like(values, dtype=float)
    for k, kind in enumerate(transforms):
        natural = inverse(kind, values[:, k])
        if digits[k] > 0:
            natural = np.round(natural / digits[k]) * digits[k]
        with np.errstate(divide="ignore", invalid="ignore"):
            out[:, k] = transform(kind, natural)
    return out


def pseudo_theses(
    columns: Columns,
    mean: np.ndarray,
    var_em: np.ndarray,
    var_ens: np.ndarray,
    truths: np.ndarray,
    *,
    cutoff: float,
    second_maximum_from: int,
    bins: int = 10,
) -> Coverage:
    """Each row of ``truths`` (pseudo-theses × columns, already printed: :func:`printed`) taken
    as the published values through the leave-one-fold-out at the points whose emulated
    ``mean``/``var_em`` are given; the held-out rows' coverage at 95 % and PIT histogram."""
    truths = np.atleast_2d(truths)
    inside = np.full(truths.shape, np.nan)
    pit = np.full(truths.shape, np.nan)
    incompatible = 0
    for j, z in enumerate(truths):
        preds = predict_folds(
            columns.with_values(z, z),
            mean,
            var_em,
            var_ens,
            cutoff=cutoff,
            second_maximum_from=second_maximum_from,
        )
        incompatible += any(p.verdict == INCOMPATIBLE for p in preds)
        for p in preds:
            if np.isnan(p.quantiles[0]) or not np.isfinite(z[p.column]):
                continue
            inside[j, p.column] = p.quantiles[0] <= z[p.column] <= p.quantiles[-1]
            pit[j, p.column] = p.pit
    counted = ~np.isnan(inside)
    histogram, _ = np.histogram(pit[counted], bins=bins, range=(0.0, 1.0))
    return Coverage(
        inside=inside,
        pit=pit,
        coverage=float(np.nanmean(inside)) if counted.any() else np.nan,
        judged=int(counted.sum()),
        histogram=histogram,
        incompatible=incompatible,
    )


def binomial_band(n: int, p: float = 0.95, k: float = 3.0) -> tuple[float, float]:
    """p ± k binomial sd of a share over n independent rows: the spread a count of n held-out
    rows has at its nominal coverage (rows of one fold move together, so the true spread is
    wider)."""
    sd = float(np.sqrt(p * (1 - p) / n))
    return p - k * sd, p + k * sd
