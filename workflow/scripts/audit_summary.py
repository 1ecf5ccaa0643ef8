"""Rule `audit_summary`: the real-time audit of every closed-loop run in one table.

Alone: python workflow/scripts/audit_summary.py out.csv results/pi_p885/audit/*.json
"""

import argparse
from pathlib import Path

import pandas as pd

from selfsense.provenance import read_records, script_logging, write_table


def main(reports, table, log=None):
    logger = script_logging(log)
    rows = [r | {"run": Path(p).stem} for r, p in zip(read_records(reports), reports)]
    df = pd.DataFrame(rows)[["run", "max |offline − logged| [nm]", "log resolution [nm]"]]
    write_table(df, table, inputs=reports)
    logger.info("\n%s", df.to_string())


if "snakemake" in globals():
    main(list(snakemake.input.reports), snakemake.output.table, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("table")
    cli.add_argument("reports", nargs="+")
    main(**vars(cli.parse_args()))
