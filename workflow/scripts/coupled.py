"""Rule `coupled`: the temperature-compensated observer coupled with the thermal model (Fig 7.9)
over one heating run: T_SH(HPO), T_SH(PS) and the observer's error.

Alone: run through Snakemake (`snakemake results/pi_p885/ch7/coupled/ch7_mixed_ae.json`).
"""

import json
from pathlib import Path

import numpy as np

from selfsense.capture import SeriesWriter, open_capture, read_series
from selfsense.chapters.ch7 import coupled_estimation
from selfsense.gamma import GammaPolynomial
from selfsense.observer import HPOGains
from selfsense.provenance import provenance, script_logging, write_json
from selfsense.ripple import plan_from_fs
from selfsense.thermal import ThermalModel

CHANNELS = ("U", "I", "x_laser", "Ur", "Ir")


def main(capture, power, gamma_t, observer, thermal_model, model, traces, stats, n_periods, log=None):
    logger = script_logging(log)
    g, o = json.loads(Path(gamma_t).read_text()), json.loads(Path(observer).read_text())
    th = json.loads(Path(thermal_model).read_text())
    k_over_alpha = json.loads(Path(model).read_text())["k_over_alpha"]
    units = {"time": "s", "T_SH_HPO": "degC", "T_SH_PS": "degC", "T_mid": "degC"}
    if not th["identified"]:  # nothing to couple with: skip, and say why
        with SeriesWriter(traces, units) as w:
            w.write({k: [] for k in units})
        write_json({"note": f"skipped: {th['reason']}", "provenance": provenance([thermal_model])}, stats)
        logger.warning("%s: skipped, %s", capture, th["reason"])
        return
    with open_capture(capture, require=CHANNELS) as cap:
        plan = plan_from_fs(cap.fs, float(cap.attrs["fr_nominal"]), int(cap.attrs["ns"]), n_periods)
        out, result = coupled_estimation(cap.iter_chunks(CHANNELS), cap.fs, plan,
                                         GammaPolynomial(tuple(g["coefficients"]), g["g"]),
                                         HPOGains(o["a0"], o["omega_s"], o["zeta_s"]),
                                         ThermalModel(th["tau"], th["gamma"]), k_over_alpha, th["T_amb"],
                                         float(cap.attrs.get("warmup_s", 0.0)))
    measured = read_series(power, ["time", "T_mid"])
    n = min(len(out["time"]), len(measured["time"]))
    out = {k: v[:n] for k, v in out.items()} | {"T_mid": measured["T_mid"][:n]}
    for key in ("T_SH_HPO", "T_SH_PS"):
        result[f"max |{key} − T| [K]"] = float(np.max(np.abs(out[key] - out["T_mid"])))
    with SeriesWriter(traces, units) as w:
        w.write(out)
    write_json(result | {"provenance": provenance([capture, power, gamma_t, observer, thermal_model, model])}, stats)
    logger.info("%s: %s", capture, result)


if "snakemake" in globals():
    i, o = snakemake.input, snakemake.output
    main(i.capture, i.power, i.gamma_t, i.observer, i.thermal_model, i.model, o.traces, o.stats,
         snakemake.params.n_periods, snakemake.log[0])
