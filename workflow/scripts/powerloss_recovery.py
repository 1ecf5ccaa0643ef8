"""Rule `powerloss_recovery`: identified R, a, X and c against the twin's truth
(twin validation).
"""

import pandas as pd

from selfsense.chapters import ronkanen
from selfsense.io.capture import open_capture
from selfsense.io.provenance import run, script_logging, write_table


def main(capture, identified, table_1, table_2, table, inputs, log=None):
    logger = script_logging(log)
    with open_capture(capture) as cap:
        truth, _ = cap.read_truth()
    result = ronkanen.recovery(
        pd.read_csv(identified), pd.read_csv(table_1), pd.read_csv(table_2), truth
    )
    write_table(result, table, inputs=inputs)
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    run(main, snakemake)
