"""Rule `characterise_table`: the rows of every capture of a dataset → characterise/summary.csv, and
the manifest's actuator and sensors → characterise/instruments.csv.

Alone: python workflow/scripts/characterise_table.py raw/<dataset>/dataset.yaml out.csv instruments.csv \
    results/<dataset>/characterise/*.json
"""

import argparse

import pandas as pd

from selfsense.characterise import TABLE_COLUMNS, instruments
from selfsense.manifest import load_manifest
from selfsense.provenance import read_records, script_logging, write_table


def main(manifest, rows, table, instruments_table, log=None):
    logger = script_logging(log)
    df = pd.DataFrame(read_records(rows), columns=TABLE_COLUMNS)  # the JSON rows come with sorted keys
    write_table(df, table, inputs=rows)
    write_table(pd.DataFrame(instruments(load_manifest(manifest)), columns=["item", "property", "value"]),
                instruments_table, inputs=[manifest])
    logger.info("\n%s", df.to_string())


if "snakemake" in globals():
    i, o = snakemake.input, snakemake.output
    main(i.manifest, list(i.rows), o.table, o.instruments, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("manifest")
    cli.add_argument("table")
    cli.add_argument("instruments_table")
    cli.add_argument("rows", nargs="+")
    main(**vars(cli.parse_args()))
