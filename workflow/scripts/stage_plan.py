"""Rule `stage_plan`: one row per analysis stage — runs or skipped, and what it needs."""

import pandas as pd

from selfsense.io.provenance import script_logging, write_table


def main(rows, manifest, table, log=None):
    logger = script_logging(log)
    df = pd.DataFrame(rows)
    df["status"] = [
        "runs" if r else "skipped: the dataset lacks what the stage needs" for r in df["runs"]
    ]
    write_table(df[["stage", "status", "needs"]], table, inputs=[manifest])
    logger.info("\n%s", df.to_string())


if "snakemake" in globals():
    main(snakemake.params.rows, snakemake.input.manifest, snakemake.output.table, snakemake.log[0])
