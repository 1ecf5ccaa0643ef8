"""Every fold predicted from the others: the region the other folds and the common targets leave,
the held-out rows' posterior predictive there, the implausibility of the published value, a
verdict, and which folds can hold together.

Columns are the common targets and the emergent rows, on their transformed scales; points are
candidate unknowns (prior candidates, or the waves' not-ruled-out region), where the emulators
give E[f(x)] and Var_em(x). For fold k (Vernon, Goldstein & Bower 2010, Section 3; Kennedy &
O'Hagan 2001 for the discrepancy):

- conditioning set C_k: the common targets not measured on fold k's captures, and the rows of the
  other folds that are judged, conditioned on (not an algebraic twin) and emulable;
- NROY_k: the points whose largest (second largest from the declared count) implausibility over
  C_k is within the cutoff (:mod:`selfsense.envelope.history_matching`);
- each held-out row's posterior predictive: the points of NROY_k weighted equally, at each a
  normal of mean E[f(x)] and variance Var_em(x) + Var_ens + Var_obs + Var_md (the published
  number is the bench plus its discrepancy plus its printing), so its CDF is the mixture
  F(t) = mean_x Φ((t − E[f(x)])/σ(x)), its 2.5/50/97.5 % quantiles those of F;
- the published value's implausibility: the least over NROY_k of its own I;
- the verdict: "incompatible" where NROY_k is empty (the other folds leave no bench), "not
  emulable" where the row's emulator failed its diagnostics, "inconsistent" where what the row
  asserts lies outside the predictive 95 % interval (a bound: the interval wholly beyond it),
  "consistent (uninformative)" where it lies inside but the interval is wider than the row's own
  registry band, else "consistent"; a row the registry gives no verdict gets "no verdict".

No row conditions its own prediction, so changing a row's published value changes its verdict
and never its prediction. Arrays in, dataclasses out; nothing is read or written.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from selfsense.envelope.history_matching import implausibility, not_ruled_out

CONSISTENT = "consistent"
UNINFORMATIVE = "consistent (uninformative)"
INCONSISTENT = "inconsistent"
INCOMPATIBLE = "incompatible"
NOT_EMULABLE = "not emulable"
NO_VERDICT = "no verdict"
VERDICTS = (CONSISTENT, UNINFORMATIVE, INCONSISTENT, INCOMPATIBLE, NOT_EMULABLE, NO_VERDICT)

#: the fold label of a common target
COMMON = ""


@dataclass(frozen=True)
class Columns:
    """What every column asserts and how it is held out, as arrays over the columns.

    ``fold`` is COMMON for a common target, else the row's fold; ``z_low``/``z_high`` what it
    asserts (equal for a value, one infinite for a bound); ``var_obs_md`` Var_obs + Var_md;
    ``band_low``/``band_high`` the row's registry band (for "uninformative"); ``judged`` False
    for a no-verdict row; ``condition`` False for a row judged but never conditioned on;
    ``left_out`` the common targets (column indices) each fold's conditioning leaves out."""

    fold: np.ndarray
    z_low: np.ndarray
    z_high: np.ndarray
    var_obs_md: np.ndarray
    band_low: np.ndarray
    band_high: np.ndarray
    judged: np.ndarray
    condition: np.ndarray
    left_out: Mapping[str, Sequence[int]]

    @property
    def folds(self) -> list[str]:
        return list(dict.fromkeys(f for f in self.fold if f != COMMON))

    def with_values(self, z_low: np.ndarray, z_high: np.ndarray) -> Columns:
        """The same columns asserting other values (a pseudo-thesis, a changed published row)."""
        return Columns(
            self.fold,
            np.asarray(z_low, dtype=float),
            np.asarray(z_high, dtype=float),
            self.var_obs_md,
            self.band_low,
            self.band_high,
            self.judged,
            self.condition,
            self.left_out,
        )


@dataclass(frozen=True)
class RowPrediction:
    """One held-out row: its fold, the fraction of the points its fold's NROY keeps, the
    predictive quantiles (transformed scale), the published value's least implausibility and
    PIT (NaN for a bound), and the verdict."""

    column: int
    fold: str
    nroy_fraction: float
    quantiles: tuple[float, float, float]
    implausibility: float
    pit: float
    verdict: str


def conditioning(columns: Columns, fold: str, emulable: np.ndarray) -> np.ndarray:
    """The mask of the columns fold ``fold`` is conditioned on: the common targets it does not
    leave out, and the other folds' judged, conditioned-on, emulable rows."""
    common = columns.fold == COMMON
    common[list(columns.left_out.get(fold, ()))] = False
    others = (columns.fold != COMMON) & (columns.fold != fold) & columns.judged & columns.condition
    return (common | others) & emulable


def region(I: np.ndarray, mask: np.ndarray, cutoff: float, second_maximum_from: int) -> np.ndarray:
    """The points the columns of ``mask`` do not rule out."""
    return not_ruled_out(I[:, mask], cutoff, second_maximum_from)


def mixture_cdf(mean: np.ndarray, sd: np.ndarray, t: float) -> float:
    """F(t) = mean over points of Φ((t − mean)/sd): the posterior predictive's CDF."""
    return float(np.mean(ndtr((t - mean) / sd)))


def mixture_quantiles(mean: np.ndarray, sd: np.ndarray, qs: Sequence[float]) -> np.ndarray:
    """The quantiles of the equal-weight mixture of normals N(mean, sd²), by bisection on its
    CDF (60 halvings of a bracket 10 sd wide: far below any printed digit)."""
    lo = np.full(len(qs), np.min(mean - 10 * sd))
    hi = np.full(len(qs), np.max(mean + 10 * sd))
    qs = np.asarray(qs, dtype=float)
    for _ in range(60):
        mid = (lo + hi) / 2
        below = np.mean(ndtr((mid[:, None] - mean[None, :]) / sd[None, :]), axis=1) < qs
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return (lo + hi) / 2


def predict_folds(
    columns: Columns,
    mean: np.ndarray,
    var_em: np.ndarray,
    var_ens: np.ndarray,
    *,
    cutoff: float,
    second_maximum_from: int,
    quantiles: Sequence[float] = (0.025, 0.5, 0.975),
) -> list[RowPrediction]:
    """Every fold's rows predicted from the others (module docstring), at the points whose
    emulated E[f(x)] and Var_em(x) are ``mean`` and ``var_em`` (points × columns, NaN where a
    column is not emulable), with the ensemble's ``var_ens`` (columns)."""
    mean, var_em = np.atleast_2d(mean), np.atleast_2d(var_em)
    emulable = ~np.any(np.isnan(mean), axis=0)
    var = var_em + var_ens + columns.var_obs_md
    I = implausibility(columns.z_low, columns.z_high, mean, var_em, var_ens + columns.var_obs_md)
    out = []
    for fold in columns.folds:
        keep = region(I, conditioning(columns, fold, emulable), cutoff, second_maximum_from)
        fraction = float(keep.mean())
        for c in np.flatnonzero(columns.fold == fold):
            out.append(_row(columns, c, fold, keep, fraction, mean, var, I, emulable, quantiles))
    return out


def _row(columns, c, fold, keep, fraction, mean, var, I, emulable, quantiles) -> RowPrediction:
    nan3 = (np.nan, np.nan, np.nan)
    if not columns.judged[c]:
        return RowPrediction(c, fold, fraction, nan3, np.nan, np.nan, NO_VERDICT)
    if not emulable[c]:
        return RowPrediction(c, fold, fraction, nan3, np.nan, np.nan, NOT_EMULABLE)
    if not keep.any():
        return RowPrediction(c, fold, 0.0, nan3, np.nan, np.nan, INCOMPATIBLE)
    m, sd = mean[keep, c], np.sqrt(var[keep, c])
    q = mixture_quantiles(m, sd, quantiles)
    low, high = columns.z_low[c], columns.z_high[c]
    point = low == high
    pit = mixture_cdf(m, sd, low) if point else np.nan
    outside = q[0] > high or q[-1] < low  # the 95 % interval misses what the row asserts
    if outside:
        verdict = INCONSISTENT
    elif point and q[-1] - q[0] > columns.band_high[c] - columns.band_low[c]:
        verdict = UNINFORMATIVE
    else:
        verdict = CONSISTENT
    least = float(np.min(I[keep, c]))
    return RowPrediction(c, fold, fraction, tuple(float(v) for v in q), least, pit, verdict)


def compatibility(
    columns: Columns,
    mean: np.ndarray,
    var_em: np.ndarray,
    var_ens: np.ndarray,
    *,
    cutoff: float,
    second_maximum_from: int,
) -> tuple[list[str], np.ndarray]:
    """Which folds can hold together: the fraction of the points that the common targets and the
    conditioned-on rows of folds a and b together leave (folds × folds; the diagonal, one fold
    with the common targets). A zero says no bench reproduces both: a structural finding."""
    mean, var_em = np.atleast_2d(mean), np.atleast_2d(var_em)
    emulable = ~np.any(np.isnan(mean), axis=0)
    I = implausibility(columns.z_low, columns.z_high, mean, var_em, var_ens + columns.var_obs_md)
    folds = columns.folds
    usable = columns.judged & columns.condition & emulable
    common = (columns.fold == COMMON) & emulable
    table = np.zeros((len(folds), len(folds)))
    for i, a in enumerate(folds):
        for j, b in enumerate(folds[i:], start=i):
            mask = common | (usable & np.isin(columns.fold, [a, b]))
            fraction = float(region(I, mask, cutoff, second_maximum_from).mean())
            table[i, j] = table[j, i] = fraction
    return folds, table


def declared_columns(declaration) -> Columns:
    """The columns of a loaded declaration (:class:`selfsense.envelope.validation.Declaration`):
    its common targets first, then every fold's rows in the declaration's order."""
    targets, rows = declaration.targets, declaration.rows
    index = {t.id: i for i, t in enumerate(targets)}
    nan = float("nan")

    def arr(values, dtype=float):
        return np.array(list(values), dtype=dtype)

    return Columns(
        fold=arr([COMMON] * len(targets) + [r.fold for r in rows], dtype=object),
        z_low=arr([t.low for t in targets] + [r.low for r in rows]),
        z_high=arr([t.high for t in targets] + [r.high for r in rows]),
        var_obs_md=arr(
            [t.obs_sd**2 + t.md_sd**2 for t in targets] + [r.obs_sd**2 + r.md_sd**2 for r in rows]
        ),
        band_low=arr([nan] * len(targets) + [r.band[0] for r in rows]),
        band_high=arr([nan] * len(targets) + [r.band[1] for r in rows]),
        judged=arr([True] * len(targets) + [r.judged for r in rows], dtype=bool),
        condition=arr([True] * len(targets) + [r.condition for r in rows], dtype=bool),
        left_out={f.id: [index[t] for t in f.left_out] for f in declaration.folds},
    )
