"""Method studies on the twin: how an analysis setting trades off, with the truth at hand.

These are not analyses of bench data (they read the twin's truth by design); the report shows
them under "twin validation".
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from selfsense.methods.ripple import RippleExtractor, SamplingPlan, WindowMeans
from selfsense.twin.bench import Bench, DaqPlan, experiment_seed
from selfsense.twin.params import TwinParams
from selfsense.verify.truth import Truth


def ce_error_vs_np_and_wander(
    params: TwinParams,
    daq: DaqPlan,
    n_periods: list[int],
    wanders: list[float],
    drive_hz: float = 10.0,
    duration: float = 0.5,
    seed: int = 0,
) -> pd.DataFrame:
    """C_e error (% of the true small-signal C_e) for each np and ripple wander.

    Each wander value is a fresh bench run of a 100 V sine. C_e from each np is compared with the
    true C_e averaged over the same window (the estimator's own error: noise and wander) and
    with the true C_e at the window's centre (adds the lag of averaging np periods).
    """
    rows = []
    t = np.arange(int(round(duration * daq.fs))) / daq.fs
    U = 50.0 - 50.0 * np.cos(2 * np.pi * drive_hz * t)
    for wander in wanders:
        p = dataclasses.replace(
            params, ripple=dataclasses.replace(params.ripple, wander=float(wander))
        )
        bench = Bench(p, daq, experiment_seed(seed, f"np-study-{wander}"))
        measured, truth = bench.step(t, U)
        for n_p in n_periods:
            plan = SamplingPlan(daq.fr_nominal, daq.ns, daq.nf, int(n_p))
            blocks = RippleExtractor(plan).process(measured["Ur"], measured["Ir"])
            _, (c_window,) = WindowMeans(plan, 1).process(truth["C_e"])
            centre = blocks.sample_index - (plan.block_len - 1) / 2
            c_now = Truth({"C_e": truth["C_e"]}, 1, len(t), names=("C_e",)).at(centre)["C_e"]
            err = 100 * (blocks.C_e / c_window - 1)
            lagged = 100 * (blocks.C_e / c_now - 1)
            rows.append(
                {
                    "np": n_p,
                    "wander [Hz]": wander,
                    "bandwidth [Hz]": plan.bandwidth,
                    "rms error vs window mean [%]": float(np.sqrt(np.mean(err**2))),
                    "max error vs window mean [%]": float(np.max(np.abs(err))),
                    "rms error vs instantaneous [%]": float(np.sqrt(np.mean(lagged**2))),
                }
            )
    return pd.DataFrame(rows)
