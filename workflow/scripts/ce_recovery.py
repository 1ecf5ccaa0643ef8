"""Rule `ce_recovery`: C_e against the twin's true clamped capacitance, per capture."""

from pathlib import Path

import pandas as pd

from selfsense.io.capture import open_capture, read_series
from selfsense.io.provenance import script_logging, write_table
from selfsense.verify.recovery import ce_tracking
from selfsense.verify.truth import Truth


def main(pairs, table, n_periods, log=None):
    """pairs: {capture path: ripple series path}."""
    logger = script_logging(log)
    rows = []
    for capture, series in pairs.items():
        with open_capture(capture) as cap:
            truth, fs = Truth.from_capture(cap, names=("C_e",)), cap.fs
        data = read_series(series, ["time", "C_e"])
        rows.append(
            {"experiment": Path(capture).stem, "np": n_periods} | ce_tracking(data, truth, fs)
        )
    result = pd.DataFrame(rows)
    write_table(result, table, inputs=[*pairs, *pairs.values()], config={"n_periods": n_periods})
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    main(
        dict(zip(snakemake.input.captures, snakemake.input.series)),
        snakemake.output.table,
        snakemake.params.n_periods,
        snakemake.log[0],
    )
