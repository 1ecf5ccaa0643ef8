"""Rule `thermal_extract`: loss power per 0.1 s (Eq 7.4) with the IR temperatures, and C_e/x samples
for Γ_T, from one Chapter 7 capture (streamed).
"""

import numpy as np

from selfsense.chapters.ch7 import extract
from selfsense.io.capture import SeriesWriter, open_capture
from selfsense.io.provenance import script_logging
from selfsense.methods.electromech import load_k_over_alpha
from selfsense.methods.ripple import plan_from_capture

FAST = ("U", "I", "x_laser", "Ur", "Ir")


def main(capture, model, power, samples, n_periods, interval=0.1, every=200, log=None):
    logger = script_logging(log)
    k_over_alpha = load_k_over_alpha(model)
    with open_capture(capture, require=FAST + ("T_mid",)) as cap:
        plan = plan_from_capture(cap, n_periods)
        parts = list(extract(cap.iter_chunks(FAST), cap.fs, plan, k_over_alpha, interval, every))
        slow = [c for c in ("T_top", "T_mid", "T_bot") if c in cap.channels]
        temps = cap.read(slow, dim="time_slow")
    P = {k: np.concatenate([p[0][k] for p in parts]) for k in ("time", "P_PS")}
    n = min(len(P["time"]), len(temps["T_mid"]))
    peaks = {"U_max": max(p[2][0] for p in parts), "x_max": max(p[2][1] for p in parts)}  # Eq 7.11
    with SeriesWriter(
        power, {"time": "s", "P_PS": "W"} | {c: "degC" for c in slow}, {"capture": capture} | peaks
    ) as w:
        w.write({"time": P["time"][:n], "P_PS": P["P_PS"][:n]} | {c: temps[c][:n] for c in slow})
    G = {k: np.concatenate([p[1][k] for p in parts]) for k in ("time", "C_e", "x_laser")}
    with SeriesWriter(
        samples, {"time": "s", "C_e": "F", "x_laser": "m"}, {"capture": capture}
    ) as w:
        w.write(G)
    logger.info(
        "%s: %d power intervals, %d Γ_T samples, mean power %.3f W",
        capture,
        n,
        len(G["time"]),
        float(np.mean(P["P_PS"])),
    )


if "snakemake" in globals():
    p = snakemake.params
    main(
        snakemake.input.capture,
        snakemake.input.model,
        snakemake.output.power,
        snakemake.output.samples,
        p.n_periods,
        p.interval,
        p.every,
        snakemake.log[0],
    )
