"""Rule `model_recovery`: identified parameters and Fig 4.8's U_H share against the twin's truth."""

import pandas as pd

from selfsense.chapters.ch4 import load_static_stiffness
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import run, script_logging, write_table
from selfsense.verify.recovery import recovery_table


def main(
    per_set,
    hysteresis,
    capture,
    static,
    manifest,
    sets,
    series,
    table,
    frequency,
    n_periods,
    inputs,
    log=None,
):
    logger = script_logging(log)
    cases, share = pd.read_csv(per_set), pd.read_csv(hysteresis)
    k_static, actuator = load_static_stiffness(static), load_manifest(manifest)["actuator"]
    result = recovery_table(
        cases, share, capture, frequency, sets, series, n_periods, k_static, actuator, manifest
    )
    config = {"frequency": frequency, "n_periods": n_periods}
    write_table(result, table, inputs=inputs, config=config)
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    run(main, snakemake)
