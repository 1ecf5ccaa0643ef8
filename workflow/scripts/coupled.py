"""Rule `coupled`: the temperature-compensated observer coupled with the thermal model (Fig 7.9)
over one heating run: T_SH(HPO), T_SH(PS) and the observer's error.
"""

import json
from pathlib import Path

from selfsense.chapters.ch7 import against_measured, coupled_estimation
from selfsense.io.capture import SeriesWriter, open_capture, read_series
from selfsense.io.provenance import provenance, script_logging, write_json
from selfsense.methods.electromech import load_k_over_alpha
from selfsense.methods.gamma import load_gamma
from selfsense.methods.observer import load_gains
from selfsense.methods.ripple import plan_from_capture
from selfsense.methods.thermal import ThermalModel

CHANNELS = ("U", "I", "x_laser", "Ur", "Ir")
UNITS = {"time": "s", "T_SH_HPO": "degC", "T_SH_PS": "degC", "T_mid": "degC"}


def main(
    capture, power, gamma_t, observer, thermal_model, model, traces, stats, n_periods, log=None
):
    logger = script_logging(log)
    th = json.loads(Path(thermal_model).read_text())
    if not th["identified"]:  # nothing to couple with: skip, and say why
        with SeriesWriter(traces, UNITS) as w:
            w.write({k: [] for k in UNITS})
        write_json(
            {"note": f"skipped: {th['reason']}", "provenance": provenance([thermal_model])}, stats
        )
        logger.warning("%s: skipped, %s", capture, th["reason"])
        return
    with open_capture(capture, require=CHANNELS) as cap:
        out, result = coupled_estimation(
            cap.iter_chunks(CHANNELS),
            cap.fs,
            plan_from_capture(cap, n_periods),
            load_gamma(gamma_t),
            load_gains(observer),
            ThermalModel(th["tau"], th["gamma"]),
            load_k_over_alpha(model),
            th["T_amb"],
            float(cap.attribute("warmup_s")),
        )
    out, result = against_measured(out, result, read_series(power, ["time", "T_mid"]))
    with SeriesWriter(traces, UNITS) as w:
        w.write(out)
    write_json(
        result
        | {"provenance": provenance([capture, power, gamma_t, observer, thermal_model, model])},
        stats,
    )
    logger.info("%s: %s", capture, result)


if "snakemake" in globals():
    i, o = snakemake.input, snakemake.output
    main(
        i.capture,
        i.power,
        i.gamma_t,
        i.observer,
        i.thermal_model,
        i.model,
        o.traces,
        o.stats,
        snakemake.params.n_periods,
        snakemake.log[0],
    )
