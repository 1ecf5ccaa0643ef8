"""Rule `characterise`: the rows of a dataset's loop pages (rule `characterise_page`) → the
characterisation table, one row per capture in catalogue order, each capture's hysteresis model's
parameters, and the manifest's actuator and sensors.
"""

import pandas as pd

from selfsense.chapters import characterise as ch
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import read_records, run, script_logging, write_table


def main(manifest, pages, table, instruments, model, inputs, log=None):
    script_logging(log)
    read = read_records(pages)
    rows = [row for page in read for row in page["rows"]]
    write_table(pd.DataFrame(rows, columns=ch.table_columns(rows)), table, inputs=inputs)
    fitted = [p for page in read for p in page["model"]]
    write_table(pd.DataFrame(fitted, columns=ch.MODEL_COLUMNS), model, inputs=inputs)
    described = ch.instruments(load_manifest(manifest))
    columns = ["item", "property", "value"]
    write_table(pd.DataFrame(described, columns=columns), instruments, inputs=inputs)


if "snakemake" in globals():
    run(main, snakemake)
