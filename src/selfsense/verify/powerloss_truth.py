"""Ronkanen's Section 7 results on the twin's truth: how much of each is the sensor's.

A verification step, like :mod:`selfsense.verify.error_budget`: it reads a simulated capture's
``/truth`` group, so it runs on the twin's datasets only. The bender's displacement is a·Q (Eq 2;
docs/twin.md), so under current control everything the true displacement drifts is the charge's —
the leakage compensation's error, the drive's, the creep's — and what the sensor adds (its noise,
slow drift and resolution) is the measured value less the true one.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from selfsense.chapters.ronkanen import Record, performance
from selfsense.io.capture import open_capture
from selfsense.verify.truth import Truth

SENSOR = "sensor (measured − true x)"


def true_displacement(path: str | Path) -> np.ndarray:
    """The twin's displacement a·Q [m] at every sample of a simulated capture, from its stored truth
    (the 4-point cubic of :meth:`selfsense.verify.truth.Truth.at`)."""
    with open_capture(path) as cap:
        truth = Truth.from_capture(cap, names=("x",))
    return truth.at(np.arange(truth.n_samples))["x"]


def performance_truth(
    kind: Mapping[str, Mapping[str, Record]],
    true_x: Mapping[str, np.ndarray],
    a_cmd: float,
    drift_start: float,
    drift_duration: float,
) -> pd.DataFrame:
    """:func:`~selfsense.chapters.ronkanen.performance` from the sensor ("measured") and from the
    twin's true displacement (``true_x``: {record name: x}, "true x"), and their difference, the
    sensor's share; ``kind`` as :func:`~selfsense.chapters.ronkanen.by_kind` gives it."""
    runs = [kind[k] for k in ("decay", "repeat", "drift")]
    measured = performance(*runs, a_cmd, drift_start, drift_duration)
    true = performance(
        *({c: replace(r, x=true_x[r.name]) for c, r in recs.items()} for recs in runs),
        a_cmd,
        drift_start,
        drift_duration,
    )
    out = measured[["measure", "control"]].assign(
        measured=measured["value"], **{"true x": true["value"]}
    )
    return out.assign(**{SENSOR: out["measured"] - out["true x"]})
