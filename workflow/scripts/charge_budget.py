"""Rule `charge_budget`: Fig 5.2's charge–position error (the max errors of the charge-sensing
table) split into the current path, the q–x map and the laser with the twin's truth → one row per
drive frequency.
"""

import pandas as pd

from selfsense.io.provenance import script_logging, write_table
from selfsense.verify.error_budget import capture_charge_budget


def main(runs, table, n_periods, log=None):
    """runs: {drive frequency [Hz]: (ripple series, capture)}."""
    logger = script_logging(log)
    rows = [
        {"frequency [Hz]": float(f)} | capture_charge_budget(s, c, n_periods)
        for f, (s, c) in sorted(runs.items())
    ]
    result = pd.DataFrame(rows)
    write_table(
        result,
        table,
        inputs=[p for pair in runs.values() for p in pair],
        config={"n_periods": n_periods},
    )
    logger.info("\n%s", result.T.to_string())


if "snakemake" in globals():
    i = snakemake.input
    main(
        dict(zip(snakemake.params.frequencies, zip(i.series, i.capture))),
        snakemake.output.table,
        snakemake.params.n_periods,
        snakemake.log[0],
    )
