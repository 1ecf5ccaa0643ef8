"""Rule `characterise`: the rows of a dataset's loop pages (rule `characterise_page`) → the
characterisation table, one row per capture in catalogue order, and the manifest's actuator and
sensors.
"""

import pandas as pd

from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import read_records, script_logging, write_table
from selfsense.methods.characterise import TABLE_COLUMNS, instruments


def main(manifest, pages, table, instruments_table, log=None):
    script_logging(log)
    rows = [row for page in read_records(pages) for row in page["rows"]]
    write_table(pd.DataFrame(rows, columns=TABLE_COLUMNS), table, inputs=pages)
    write_table(
        pd.DataFrame(instruments(load_manifest(manifest)), columns=["item", "property", "value"]),
        instruments_table,
        inputs=[manifest],
    )


if "snakemake" in globals():
    i, o = snakemake.input, snakemake.output
    main(i.manifest, list(i.pages), o.table, o.instruments, snakemake.log[0])
