"""Rule `ch3_tables`: Tables 3.1 and 3.2 from the folding equations for this dataset's ripple."""

from selfsense.io.provenance import run, script_logging, write_table
from selfsense.methods.ripple import table_3_1, table_3_2


def main(fr, ns, fs, table_31, table_32, inputs, log=None):
    logger = script_logging(log)
    config = {"fr": fr, "ns": ns, "fs": fs}
    write_table(table_3_1(fr), table_31, inputs=inputs, config=config)
    write_table(table_3_2(fs, fr, ns), table_32, inputs=inputs, config=config)
    logger.info("Tables 3.1 and 3.2 for fr = %g Hz, ns = %d, fs = %g Hz", fr, ns, fs)


if "snakemake" in globals():
    run(main, snakemake)
