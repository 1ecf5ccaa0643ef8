"""Rule `powerloss_table_2`: models (7)–(11) fitted to the paper's Table 1 and
to the identified X.
"""

import pandas as pd

from selfsense.chapters import ronkanen
from selfsense.io.provenance import run, script_logging, write_table


def main(table_1, identified, table, inputs, log=None):
    logger = script_logging(log)
    result = ronkanen.table_2_both(pd.read_csv(table_1), ronkanen.load_identified(identified, "R"))
    write_table(result, table, inputs=inputs)
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    run(main, snakemake)
