"""Parameter recovery: what the analysis identified against the twin's ground truth.

Only this module and the tests read a capture's /truth group; the analyses never do.

Two truths stand beside an identified parameter. The twin's *built* value is the one its
manifest gives (C_P's slope for ΔCx, Table 4.2). The *model on truth* is what the same
identification gives on the twin's noiseless states over the same windows: where the source's
model describes the twin exactly the two agree; where it does not (Eq 4.4 has C_e a function of x
alone, the twin's small-signal C_e also carries the domain state, docs/twin.md) it is the value
the model's parameter converges to on perfect data, its pseudo-true value, and the difference
between the two is the model's bias on this bench, not an error of the measurement chain.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from selfsense.chapters.ch4 import identify_sets
from selfsense.io.capture import open_capture, read_series
from selfsense.methods.electromech import geometry_from_actuator
from selfsense.methods.ripple import plan_from_capture
from selfsense.verify.gamma_truth import window_truth
from selfsense.verify.truth import Truth


def ce_tracking(series: Mapping[str, np.ndarray], truth: Truth, fs: float) -> dict[str, float]:
    """How closely the estimated C_e follows the twin's true small-signal C_e (rms and max, % of
    it), the truth read at each window's time [s]."""
    c_true = truth.at(np.asarray(series["time"], dtype=float) * fs)["C_e"]
    err = 100 * (np.asarray(series["C_e"]) / c_true - 1)
    err = err[np.isfinite(err)]
    return {
        "rms error [%]": float(np.sqrt(np.mean(err**2))),
        "max error [%]": float(np.max(np.abs(err))),
        "mean error [%]": float(np.mean(err)),
        "windows": int(err.size),
    }


#: identified parameter (per-set table column) → twin truth attribute
MODEL_TRUTH = {
    "k": "stack_k",
    "alpha": "stack_alpha",
    "C_P0": "stack_C_P0",
    "dC_x": "stack_dC_x",
    "b": "stack_b",
}
#: the column of the identification on the twin's noiseless states
ON_TRUTH = "model on truth"


def truth_series(
    series: Mapping[str, np.ndarray], truth: Truth, fs: float, block_len: int
) -> dict[str, np.ndarray]:
    """A Chapter 4 set's ripple ``series`` with what the identification reads of it (Eq 4.15–4.19)
    replaced by the twin's noiseless states over the same windows: the small-signal C_e for the
    ripple's, x for the laser's, the stack's charge q for the integrated current (whose offset and
    drift the charge fit absorbs either way) and I = dq/dt. ``truth`` holds C_e, x and q; windows
    the ripple stage rejected stay rejected."""
    true = window_truth(truth, series["time"], fs, block_len, ("C_e", "x", "q"))
    return dict(series) | {
        "C_e": np.where(np.isfinite(series["C_e"]), true["C_e"], np.nan),
        "x_laser": true["x"],
        "q": true["q"],
        "I": np.gradient(true["q"], series["time"]),
    }


def identified_on_truth(
    series: Sequence[str | Path],
    captures: Sequence[str | Path],
    n_periods: int,
    k_static: float,
    m: float,
    geometry,
):
    """The per-set table of :func:`selfsense.chapters.ch4.identify_sets` for the sets whose ripple
    series are ``series``, each on :func:`truth_series` from its capture (same order)."""
    sets = {}
    for path, capture in zip(series, captures, strict=True):
        with open_capture(capture) as cap:
            truth = Truth.from_capture(cap, names=("C_e", "x", "q"))
            fs, block_len = cap.fs, plan_from_capture(cap, n_periods).block_len
        sets[Path(path).stem] = truth_series(read_series(path), truth, fs, block_len)
    return identify_sets(sets, k_static, m, geometry)[0]


def model_recovery(per_set, truth_params: Mapping[str, float], on_truth=None):
    """Identified model parameters (mean over sets, per case) against the twin's built value and,
    given ``on_truth`` (:func:`identified_on_truth`), against the same identification on its
    noiseless states (mean over the same sets, column :data:`ON_TRUTH`)."""
    rows = []
    for case, sets in per_set.groupby("case"):
        for key, attr in MODEL_TRUTH.items():
            truth = float(truth_params[attr])
            mean = float(sets[key].mean())
            row = {
                "case": int(case),
                "parameter": key,
                "truth": truth,
                "identified mean": mean,
                "identified std": float(sets[key].std(ddof=1)) if len(sets) > 1 else float("nan"),
                "error [%]": 100 * (mean / truth - 1) if truth else float("nan"),
            }
            if on_truth is not None:
                model = float(on_truth.loc[on_truth["case"] == case, key].mean())
                row |= {
                    ON_TRUTH: model,
                    f"error vs {ON_TRUTH} [%]": 100 * (mean / model - 1) if model else float("nan"),
                }
            rows.append(row)
    return pd.DataFrame(rows)


def hysteresis_share_recovery(identified, truth_states: Mapping[str, np.ndarray], frequency: float):
    """Fig 4.8's U_H share of max U (``identified``: rule identify's hysteresis_voltage table, per
    case) against the twin's own at ``frequency``: the peak of its hysteresis operator's voltage
    U_H over the peak drive U (Eq 1.6), from the truth of a capture at that frequency."""
    truth = 100 * float(np.max(np.abs(truth_states["U_H"])) / np.max(truth_states["U_drive"]))
    rows = identified[np.isclose(identified["frequency [Hz]"], frequency)]
    return pd.DataFrame(
        [
            {
                "case": int(r["case"]),
                "parameter": f"U_H share of max U at {frequency:g} Hz [%]",
                "truth": truth,
                "identified mean": float(r["U_H share of max U [%]"]),
                "identified std": float("nan"),
                "error [%]": 100 * (r["U_H share of max U [%]"] / truth - 1),
            }
            for _, r in rows.iterrows()
        ]
    )


def recovery_table(
    per_set: pd.DataFrame,
    hysteresis: pd.DataFrame,
    capture: str | Path,
    frequency: float,
    sets: Sequence[str | Path],
    series: Sequence[str | Path],
    n_periods: int,
    k_static: float,
    actuator: Mapping,
    where: str = "manifest",
) -> pd.DataFrame:
    """Rule model_recovery's table: the Case 1 / Case 2 parameters rule identify found (Table 4.2,
    its per-set table ``per_set``) against the twin's built values and the model on truth
    (:func:`model_recovery`), then Fig 4.8's U_H share (``hysteresis``, rule identify's
    hysteresis_voltage table) against the twin's own (:func:`hysteresis_share_recovery`).

    The built values and the U_H share are read from the /truth of ``capture``, a capture at
    ``frequency`` [Hz]; the model on truth is :func:`identified_on_truth` of every Chapter 4 set
    (its capture in ``sets``, its ripple series in ``series``, same order) with the static
    stiffness ``k_static`` [N/m] (Eq 4.16) and the manifest's ``actuator`` (its moving mass and
    geometry; ``where`` names the manifest in errors)."""
    on_truth = identified_on_truth(
        series,
        sets,
        n_periods,
        k_static,
        float(actuator["moving_mass_kg"]),
        geometry_from_actuator(actuator, f"{where}: actuator"),
    )
    with open_capture(capture) as cap:
        truth, states = cap.read_truth()
    return pd.concat(
        [
            model_recovery(per_set, truth, on_truth),
            hysteresis_share_recovery(hysteresis, states, frequency),
        ],
        ignore_index=True,
    )
