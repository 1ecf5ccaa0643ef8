"""Rule `characterise`: the rows of a dataset's loop pages (rule `characterise_page`) → the
characterisation table, one row per capture in catalogue order, each capture's hysteresis model's
parameters, and the manifest's actuator and sensors.
"""

import pandas as pd

from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import read_records, script_logging, write_table
from selfsense.methods.characterise import MODEL_COLUMNS, instruments, table_columns


def main(manifest, pages, table, instruments_table, model_table, log=None):
    script_logging(log)
    read = read_records(pages)
    rows = [row for page in read for row in page["rows"]]
    write_table(pd.DataFrame(rows, columns=table_columns(rows)), table, inputs=pages)
    model = [p for page in read for p in page["model"]]
    write_table(pd.DataFrame(model, columns=MODEL_COLUMNS), model_table, inputs=pages)
    write_table(
        pd.DataFrame(instruments(load_manifest(manifest)), columns=["item", "property", "value"]),
        instruments_table,
        inputs=[manifest],
    )


if "snakemake" in globals():
    i, o = snakemake.input, snakemake.output
    main(i.manifest, list(i.pages), o.table, o.instruments, o.model, snakemake.log[0])
