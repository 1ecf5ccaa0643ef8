"""Error statistics and loop measures used across chapters (max error, % of stroke, hysteresis %)."""

from __future__ import annotations

import numpy as np


def direction(drive: np.ndarray) -> np.ndarray:
    """+1 where the drive rises, −1 where it falls (the branch of a hysteresis loop)."""
    d = np.gradient(np.asarray(drive, dtype=float))
    return np.where(d >= 0, 1, -1)


def branch_gap(horizontal: np.ndarray, vertical: np.ndarray, rising: np.ndarray, bins: int = 40) -> float:
    """Largest vertical distance between the rising and falling branches of a loop.

    The horizontal axis is binned over the range both branches cover; each branch is averaged
    per bin (the estimates are noisy sample by sample) and the largest difference of the
    branch means is returned, in the vertical quantity's units.
    """
    h, v, up = (np.asarray(a) for a in (horizontal, vertical, rising))
    ok = np.isfinite(h) & np.isfinite(v)
    h, v, up = h[ok], v[ok], up[ok]
    lo = max(h[up > 0].min(), h[up < 0].min())
    hi = min(h[up > 0].max(), h[up < 0].max())
    edges = np.linspace(lo, hi, bins + 1)
    which = np.clip(np.digitize(h, edges) - 1, 0, bins - 1)
    inside = (h >= lo) & (h <= hi)

    def branch_means(sel):
        sums = np.bincount(which[sel], weights=v[sel], minlength=bins)
        counts = np.bincount(which[sel], minlength=bins)
        with np.errstate(invalid="ignore", divide="ignore"):
            return sums / counts

    gap = branch_means(inside & (up > 0)) - branch_means(inside & (up < 0))
    return float(np.nanmax(np.abs(gap)))


def hysteresis_percent(horizontal: np.ndarray, vertical: np.ndarray, rising: np.ndarray) -> tuple[float, float]:
    """Loop width in % of range: (along the vertical axis, along the horizontal axis)."""
    vertical_width = branch_gap(horizontal, vertical, rising) / np.ptp(vertical[np.isfinite(vertical)])
    horizontal_width = branch_gap(vertical, horizontal, rising) / np.ptp(horizontal[np.isfinite(horizontal)])
    return 100 * vertical_width, 100 * horizontal_width


def error_stats(estimate: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """Max |error|, rms error, the stroke of the truth and the max error as % of that stroke."""
    err = np.asarray(estimate) - np.asarray(truth)
    stroke = float(np.ptp(truth))
    max_err = float(np.nanmax(np.abs(err)))
    return {"max_error": max_err, "rms_error": float(np.sqrt(np.nanmean(err ** 2))),
            "stroke": stroke, "max_error_percent": 100 * max_err / stroke}
