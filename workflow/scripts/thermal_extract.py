"""Rule `thermal_extract`: loss power per 0.1 s (Eq 7.4) with the IR temperatures, and C_e/x samples
for Γ_T, from one Chapter 7 capture (streamed; selfsense.chapters.ch7.extract_capture).
"""

import numpy as np

from selfsense.chapters.ch7 import SERIES_UNITS, extract_capture
from selfsense.io.capture import SeriesWriter
from selfsense.io.provenance import run, script_logging
from selfsense.methods.electromech import load_k_over_alpha


def main(capture, model, power, samples, n_periods, interval, every, log=None):
    logger = script_logging(log)
    P, peaks, G = extract_capture(capture, load_k_over_alpha(model), n_periods, interval, every)
    made = {
        "inputs": [capture, model],
        "config": {"n_periods": n_periods, "interval": interval, "every": every},
    }
    attrs = {"capture": capture}
    with SeriesWriter(power, {k: SERIES_UNITS[k] for k in P}, attrs | peaks, **made) as w:
        w.write(P)
    with SeriesWriter(samples, {k: SERIES_UNITS[k] for k in G}, attrs, **made) as w:
        w.write(G)
    logger.info(
        "%s: %d power intervals, %d Γ_T samples, mean power %.3f W",
        capture,
        len(P["time"]),
        len(G["time"]),
        float(np.mean(P["P_PS"])),
    )


if "snakemake" in globals():
    run(main, snakemake)
