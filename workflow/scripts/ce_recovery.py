"""Rule `ce_recovery`: C_e against the twin's true clamped capacitance, per capture."""

from pathlib import Path

import pandas as pd

from selfsense.io.capture import open_capture, read_series
from selfsense.io.provenance import run, script_logging, write_table
from selfsense.verify.recovery import ce_tracking
from selfsense.verify.truth import Truth


def main(captures, series, table, n_periods, inputs, log=None):
    """series: each capture's ripple series, named after its experiment as the capture is."""
    logger = script_logging(log)
    rows, series_of = [], {Path(s).stem: s for s in series}
    for capture in captures:
        with open_capture(capture) as cap:
            truth, fs = Truth.from_capture(cap, names=("C_e",)), cap.fs
        data = read_series(series_of[Path(capture).stem], ["time", "C_e"])
        rows.append(
            {"experiment": Path(capture).stem, "np": n_periods} | ce_tracking(data, truth, fs)
        )
    result = pd.DataFrame(rows)
    write_table(result, table, inputs=inputs, config={"n_periods": n_periods})
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    run(main, snakemake)
