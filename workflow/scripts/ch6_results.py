"""Rule `ch6_results`: Tables 6.1–6.2, P3, the loop's tracking prediction and Figures 6.2–6.8.

All errors are evaluated on means over one folded ripple period (the real-time loop's 4 kHz
rate). Alone: run through Snakemake (`snakemake results/pi_p885/ch6/table_6_1.csv`).
"""

import json
from pathlib import Path

import numpy as np
import pandas as pd

from selfsense.capture import open_capture
from selfsense.chapters import ch6
from selfsense.control import IntegralController, tracking_prediction
from selfsense.provenance import save_figure, script_logging, write_table
from selfsense.ripple import SamplingPlan, WindowMeans
from selfsense.twin.drive import drive_from_protocol


def load_run(path, protocol):
    """4 kHz means of U, x_laser (zeroed at the start), x_R and, in closed loop, the logged x̂."""
    with open_capture(path, require=("U", "x_laser")) as cap:
        names = [c for c in ("U", "x_laser", "x_ref", "x_hpo_rt") if c in cap.channels]
        plan = SamplingPlan(float(cap.attrs["fr_nominal"]), int(cap.attrs["ns"]), int(cap.attrs["nf"]), 1)
        means = WindowMeans(plan, len(names))
        parts = [means.process(*(d[c] for c in names)) for _, d in cap.iter_chunks(names)]
        fs = cap.fs
    index = np.concatenate([p[0] for p in parts])
    values = dict(zip(names, np.concatenate([p[1] for p in parts], axis=1)))
    t = (index - (plan.ns - 1) / 2) / fs
    run = {"t": t, "U": values["U"], "x_laser": values["x_laser"] - values["x_laser"][0]}
    run["x_ref"] = values["x_ref"] if "x_ref" in values else drive_from_protocol(protocol)(t)
    run["x_hat"] = values.get("x_hpo_rt")
    return run


def main(captures, protocols, controls, k_over_alpha, omega_c, out, out_dir, log=None):
    logger = script_logging(log)
    runs = {Path(p).stem: load_run(p, protocols[Path(p).stem]) for p in captures}
    settle = 5 / omega_c
    p1 = {"e_TOL": [], "e_TCL": [], "e_OCL": []}
    rows62 = []
    for name, run in runs.items():
        protocol, closed = protocols[name], controls[name] == "closed_loop"
        warmup = float(protocol.get("warmup", 0.0))
        errs = ch6.errors(run["x_ref"], run["x_laser"], run["x_hat"] if closed else None, closed)
        if name.startswith("ch6_p1_"):
            ends = warmup + np.cumsum([s["duration"] for s in protocol["segments"]])
            starts = np.concatenate([[warmup], ends[:-1]])
            for key, maxima in ch6.segment_maxima(run["t"], errs, starts, ends, settle).items():
                if key in p1:
                    p1[key].append(maxima)
        elif name.startswith("ch6_p2"):
            profile = "P" + name.split("_")[1][1:]
            rows62 += ch6.profile_errors(profile, run["t"], errs, float(np.ptp(run["x_ref"])), warmup + settle)
    inputs = list(captures)
    write_table(ch6.table_6_1(p1), out["table_6_1"], inputs=inputs, config={"omega_c": omega_c})
    write_table(pd.DataFrame(rows62), out["table_6_2"], inputs=inputs, config={"omega_c": omega_c})
    p3o, p3c = runs["ch6_p3_open"], runs["ch6_p3_closed"]
    hold = float(protocols["ch6_p3_closed"].get("warmup", 0.0)) + protocols["ch6_p3_closed"]["segments"][0]["duration"]
    write_table(ch6.p3_summary(p3c["t"], p3o, p3c, hold), out["p3"], inputs=inputs)
    gains = IntegralController(omega_c, k_over_alpha)
    prediction = tracking_prediction(gains, [10.0, 15.0, 40.0, 50.0, 75.0, 100.0, 125.0], 15e-6)
    write_table(prediction, out["tracking"], inputs=inputs, config={"omega_c": omega_c})
    for name, fig in ch6.figures_ch6(runs, prediction).items():
        save_figure(fig, Path(out_dir) / f"{name}.png", inputs=inputs)
    logger.info("%d runs; P1 tests: %d", len(runs), len(p1["e_TCL"]))


if "snakemake" in globals():
    p = snakemake.params
    main(list(snakemake.input.captures), p.protocols, p.controls,
         json.loads(Path(snakemake.input.model).read_text())["k_over_alpha"], p.omega_c,
         dict(snakemake.output.items()), p.out_dir, snakemake.log[0])
