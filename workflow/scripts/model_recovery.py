"""Rule `model_recovery`: identified Case 1 / Case 2 parameters against the twin's built values
and the same identification on its noiseless states, and Fig 4.8's U_H share at the capture's
frequency.
"""

import pandas as pd

from selfsense.chapters.ch4 import load_static_stiffness
from selfsense.io.capture import open_capture
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import script_logging, write_table
from selfsense.methods.electromech import geometry_from_actuator
from selfsense.verify.recovery import hysteresis_share_recovery, identified_on_truth, model_recovery


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
    """frequency: the capture's [Hz]; sets, series: every Chapter 4 set's capture and ripple
    series, in one order."""
    logger = script_logging(log)
    actuator = load_manifest(manifest)["actuator"]
    k_static = load_static_stiffness(static)
    on_truth = identified_on_truth(
        series,
        sets,
        n_periods,
        k_static,
        float(actuator["moving_mass_kg"]),
        geometry_from_actuator(actuator, f"{manifest}: actuator"),
    )
    with open_capture(capture) as cap:
        truth, states = cap.read_truth()
    result = pd.concat(
        [
            model_recovery(pd.read_csv(per_set), truth, on_truth),
            hysteresis_share_recovery(pd.read_csv(hysteresis), states, frequency),
        ],
        ignore_index=True,
    )
    write_table(
        result,
        table,
        inputs=[per_set, hysteresis, capture, static, manifest, *sets, *series],
        config={"frequency": frequency, "n_periods": n_periods},
    )
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
