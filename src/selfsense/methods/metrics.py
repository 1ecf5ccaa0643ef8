"""Error statistics and loop measures used across chapters (max error, % of stroke,
hysteresis %)."""

from __future__ import annotations

import numpy as np


def direction(drive: np.ndarray) -> np.ndarray:
    """+1 where the drive rises, −1 where it falls (the branch of a hysteresis loop)."""
    d = np.gradient(np.asarray(drive, dtype=float))
    return np.where(d >= 0, 1, -1)


def branch_means(
    horizontal: np.ndarray,
    vertical: np.ndarray,
    rising: np.ndarray,
    bins: int = 40,
    min_count: int = 1,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A loop as two curves: the vertical quantity averaged per bin of the horizontal one, per
    branch.

    The horizontal axis is binned over the range both branches cover; each branch is averaged
    per bin (the estimates are noisy sample by sample). Returns the bin centres and the rising
    and falling branches' means (NaN in a bin a branch visits fewer than ``min_count`` times).
    """
    h, v, up = (np.asarray(a) for a in (horizontal, vertical, rising))
    ok = np.isfinite(h) & np.isfinite(v)
    h, v, up = h[ok], v[ok], up[ok]
    lo = max(h[up > 0].min(), h[up < 0].min())
    hi = min(h[up > 0].max(), h[up < 0].max())
    edges = np.linspace(lo, hi, bins + 1)
    which = np.clip(np.digitize(h, edges) - 1, 0, bins - 1)
    inside = (h >= lo) & (h <= hi)

    def means(sel):
        sums = np.bincount(which[sel], weights=v[sel], minlength=bins)
        counts = np.bincount(which[sel], minlength=bins)
        return np.where(counts >= max(min_count, 1), sums / np.maximum(counts, 1), np.nan)

    return 0.5 * (edges[:-1] + edges[1:]), means(inside & (up > 0)), means(inside & (up < 0))


def branch_gap(
    horizontal: np.ndarray, vertical: np.ndarray, rising: np.ndarray, bins: int = 40
) -> float:
    """Largest vertical distance between the rising and falling branches of a loop
    (of their bin means, :func:`branch_means`), in the vertical quantity's units."""
    _, rise, fall = branch_means(horizontal, vertical, rising, bins)
    return float(np.nanmax(np.abs(rise - fall)))


def hysteresis_percent(
    horizontal: np.ndarray, vertical: np.ndarray, rising: np.ndarray
) -> tuple[float, float]:
    """Loop width in % of range: (along the vertical axis, along the horizontal axis)."""
    vertical_width = branch_gap(horizontal, vertical, rising) / np.ptp(
        vertical[np.isfinite(vertical)]
    )
    horizontal_width = branch_gap(vertical, horizontal, rising) / np.ptp(
        horizontal[np.isfinite(horizontal)]
    )
    return 100 * vertical_width, 100 * horizontal_width


def error_stats(estimate: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """Max |error|, rms error, the stroke of the truth and the max error as % of that stroke."""
    err = np.asarray(estimate) - np.asarray(truth)
    stroke = float(np.ptp(truth))
    max_err = float(np.nanmax(np.abs(err)))
    return {
        "max_error": max_err,
        "rms_error": float(np.sqrt(np.nanmean(err**2))),
        "stroke": stroke,
        "max_error_percent": 100 * max_err / stroke,
    }
