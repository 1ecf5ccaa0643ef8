"""Rule `twin_calibration`: the twin's calibration signatures read from the pipeline's own tables,
beside the thesis's values and their bands (workflow/twin_calibration.yaml).
"""

from pathlib import Path

import pandas as pd

from selfsense.io.provenance import run, script_logging, write_table
from selfsense.scorecard.calibration import calibration_table, load_targets


def main(targets, results_dir, table, tables=None, log=None):
    logger = script_logging(log)
    calibration = load_targets(targets)
    if tables is None:  # run alone: the targets' tables that exist
        tables = [p for t in calibration.tables() if (p := Path(results_dir) / t).exists()]
    read = {Path(t).relative_to(results_dir).as_posix(): pd.read_csv(t) for t in tables}
    result = calibration_table(calibration.targets, read)
    write_table(result, table, inputs=[targets, *map(str, tables)])
    logger.info(
        "\n%s", result[["signature", "thesis value", "twin value", "within", "note"]].to_string()
    )


if "snakemake" in globals():
    run(main, snakemake)
