"""Rule `coupled`: the temperature-compensated observer coupled with the thermal model (Fig 7.9)
over one heating run: T_SH(HPO), T_SH(PS) and the observer's error (ch7.coupled_run)."""

import json
from pathlib import Path

from selfsense.chapters.ch7 import COUPLED_UNITS, coupled_run
from selfsense.io.capture import SeriesWriter, read_series
from selfsense.io.provenance import provenance, run, script_logging, write_json
from selfsense.methods.electromech import load_k_over_alpha
from selfsense.methods.gamma import load_gamma
from selfsense.methods.observer import load_gains


def main(
    capture, power, gamma_t, observer, thermal_model, model, traces, stats, n_periods, inputs, log
):
    logger = script_logging(log)
    th = json.loads(Path(thermal_model).read_text())
    if not th["identified"]:  # nothing to couple with: skip, and say why
        with SeriesWriter(traces, COUPLED_UNITS, inputs=[thermal_model]) as w:
            w.write({k: [] for k in COUPLED_UNITS})
        note = f"skipped: {th['reason']}"
        write_json({"note": note, "provenance": provenance(inputs)}, stats)
        logger.warning("%s: skipped, %s", capture, th["reason"])
        return
    g, gains, k_alpha = load_gamma(gamma_t), load_gains(observer), load_k_over_alpha(model)
    measured = read_series(power, ["time", "T_mid"])
    out, result = coupled_run(capture, measured, g, gains, th, k_alpha, n_periods)
    with SeriesWriter(traces, COUPLED_UNITS, inputs=inputs, config={"n_periods": n_periods}) as w:
        w.write(out)
    write_json(result | {"provenance": provenance(inputs)}, stats)
    logger.info("%s: %s", capture, result)


if "snakemake" in globals():
    run(main, snakemake)
