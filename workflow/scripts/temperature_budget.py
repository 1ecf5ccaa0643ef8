"""Rule `temperature_budget`: Chapter 7's coupled temperature errors (rule `coupled`'s
max |T_SH(PS) − T| and max |T_SH(HPO) − T| against the middle thermometer) split into their
sources with the twin's truth → one row per estimator.
"""

import json
from pathlib import Path

import pandas as pd

from selfsense.io.capture import read_series
from selfsense.io.provenance import run, script_logging, write_table
from selfsense.methods.thermal import ThermalModel
from selfsense.verify.temperature_budget import SOURCES, capture_temperature_budget


def main(capture, traces, stats, thermal_model, table, inputs, log=None):
    logger = script_logging(log)
    th = json.loads(Path(thermal_model).read_text())
    if not th["identified"]:  # rule coupled skipped the run: no estimate to split, say why
        write_table(pd.DataFrame({"note": [f"skipped: {th['reason']}"]}), table, inputs=inputs)
        logger.warning("%s: skipped, %s", capture, th["reason"])
        return
    stated = json.loads(Path(stats).read_text())
    budget = capture_temperature_budget(
        capture,
        read_series(traces),
        ThermalModel(th["tau"], th["gamma"]),
        th["T_amb"],
        stats=stated,
    )
    write_table(budget, table, inputs=inputs)
    for _, r in budget.iterrows():
        logger.info(
            "%s %s: %+.3f K at %.1f s = %s",
            capture,
            r["estimator"],
            r["total at max [K]"],
            r["time of max [s]"],
            " ".join(f"{s} {r[f'{s} at max [K]']:+.3f}" for s in SOURCES),
        )


if "snakemake" in globals():
    run(main, snakemake)
