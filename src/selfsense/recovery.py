"""Parameter recovery: what the analysis identified against the twin's ground truth.

Only this module and the tests read a capture's /truth group; the analyses never do.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np


def truth_at(times: np.ndarray, truth_states: Mapping[str, np.ndarray], name: str, decimation: int,
             fs: float) -> np.ndarray:
    """A truth state (stored every ``decimation``-th sample) interpolated at ``times`` [s]."""
    values = np.asarray(truth_states[name], dtype=float)
    return np.interp(times, np.arange(len(values)) * decimation / fs, values)


def ce_tracking(series: Mapping[str, np.ndarray], truth_states: Mapping[str, np.ndarray], decimation: int,
                fs: float) -> dict[str, float]:
    """How closely the estimated C_e follows the twin's true small-signal C_e (rms and max, % of it)."""
    c_true = truth_at(series["time"], truth_states, "C_e", decimation, fs)
    err = 100 * (np.asarray(series["C_e"]) / c_true - 1)
    err = err[np.isfinite(err)]
    return {"rms error [%]": float(np.sqrt(np.mean(err ** 2))), "max error [%]": float(np.max(np.abs(err))),
            "mean error [%]": float(np.mean(err)), "windows": int(err.size)}


#: identified parameter (per-set table column) → twin truth attribute
MODEL_TRUTH = {"k": "stack_k", "alpha": "stack_alpha", "C_P0": "stack_C_P0", "dC_x": "stack_dC_x", "b": "stack_b"}


def model_recovery(per_set, truth_params: Mapping[str, float]):
    """Identified model parameters (mean over sets, per case) against the twin's truth."""
    import pandas as pd

    rows = []
    for case, sets in per_set.groupby("case"):
        for key, attr in MODEL_TRUTH.items():
            truth = float(truth_params[attr])
            mean = float(sets[key].mean())
            rows.append({"case": int(case), "parameter": key, "truth": truth, "identified mean": mean,
                         "identified std": float(sets[key].std(ddof=1)) if len(sets) > 1 else float("nan"),
                         "error [%]": 100 * (mean / truth - 1) if truth else float("nan")})
    return pd.DataFrame(rows)


def hysteresis_share_recovery(identified, truth_states: Mapping[str, np.ndarray], frequency: float):
    """Fig 4.8's U_H share of max U (``identified``: rule identify's hysteresis_voltage table, per
    case) against the twin's own at ``frequency``: the peak of its hysteresis operator's voltage
    U_H over the peak drive U (Eq 1.6), from the truth of a capture at that frequency."""
    import pandas as pd

    truth = 100 * float(np.max(np.abs(truth_states["U_H"])) / np.max(truth_states["U_drive"]))
    rows = identified[np.isclose(identified["frequency [Hz]"], frequency)]
    return pd.DataFrame([{"case": int(r["case"]), "parameter": f"U_H share of max U at {frequency:g} Hz [%]",
                          "truth": truth, "identified mean": float(r["U_H share of max U [%]"]),
                          "identified std": float("nan"), "error [%]": 100 * (r["U_H share of max U [%]"] / truth - 1)}
                         for _, r in rows.iterrows()])
