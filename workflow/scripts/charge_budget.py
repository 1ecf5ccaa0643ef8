"""Rule `charge_budget`: Fig 5.2's charge–position error (the max errors of the charge-sensing
table) split into the current path, the q–x map and the laser with the twin's truth → one row per
drive frequency.
"""

from pathlib import Path

import pandas as pd

from selfsense.io.provenance import run, script_logging, write_table
from selfsense.verify.error_budget import capture_charge_budget


def main(captures, series, frequencies, table, n_periods, inputs, log=None):
    """series: each capture's ripple series, named after its experiment as the capture is;
    frequencies: {experiment: drive frequency [Hz]}."""
    logger = script_logging(log)
    series_of = {Path(s).stem: s for s in series}
    runs = {frequencies[Path(c).stem]: (series_of[Path(c).stem], c) for c in captures}
    rows = [
        {"frequency [Hz]": float(f)} | capture_charge_budget(s, c, n_periods)
        for f, (s, c) in sorted(runs.items())
    ]
    result = pd.DataFrame(rows)
    write_table(
        result,
        table,
        inputs=inputs,
        config={"n_periods": n_periods},
    )
    logger.info("\n%s", result.T.to_string())


if "snakemake" in globals():
    run(main, snakemake)
