"""Rule `characterise_table`: the rows of every capture of a dataset → characterise/summary.csv.

Alone: python workflow/scripts/characterise_table.py out.csv results/<dataset>/characterise/*.json
"""

import argparse
import json
from pathlib import Path

import pandas as pd

from selfsense.provenance import script_logging, write_table


def main(rows, table, log=None):
    logger = script_logging(log)
    records = [json.loads(Path(p).read_text()) for p in rows]
    df = pd.DataFrame([{k: v for k, v in r.items() if k != "provenance"} for r in records])
    write_table(df, table, inputs=rows)
    logger.info("\n%s", df.to_string())


if "snakemake" in globals():
    main(list(snakemake.input.rows), snakemake.output.table, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("table")
    cli.add_argument("rows", nargs="+")
    main(**vars(cli.parse_args()))
