"""Rule `model_recovery`: identified parameters and Fig 4.8's U_H share against the twin's truth."""

import pandas as pd

from selfsense.chapters.ch4 import load_static_stiffness
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import script_logging, write_table
from selfsense.verify.recovery import recovery_table


def main(
    per_set,
    hysteresis,
    capture,
    static,
    manifest,
    table,
    frequency,
    n_periods,
    sets,
    series,
    log=None,
):
    logger = script_logging(log)
    cases, share = pd.read_csv(per_set), pd.read_csv(hysteresis)
    k_static, actuator = load_static_stiffness(static), load_manifest(manifest)["actuator"]
    result = recovery_table(
        cases, share, capture, frequency, sets, series, n_periods, k_static, actuator, manifest
    )
    inputs = [per_set, hysteresis, capture, static, manifest, *sets, *series]
    config = {"frequency": frequency, "n_periods": n_periods}
    write_table(result, table, inputs=inputs, config=config)
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    i = snakemake.input
    main(
        i.per_set,
        i.hysteresis,
        i.capture,
        i.static,
        i.manifest,
        snakemake.output.table,
        snakemake.params.frequency,
        snakemake.params.n_periods,
        list(i.sets),
        list(i.series),
        snakemake.log[0],
    )
