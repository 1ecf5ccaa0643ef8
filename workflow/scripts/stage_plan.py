"""Rule `stage_plan`: one row per analysis stage — runs or skipped, and what it needs."""

import pandas as pd

from selfsense.io.provenance import run, script_logging, write_table


def main(rows, table, inputs, log=None):
    logger = script_logging(log)
    df = pd.DataFrame(rows)
    df["status"] = [
        "runs" if r else "skipped: the dataset lacks what the stage needs" for r in df["runs"]
    ]
    write_table(df[["stage", "status", "needs"]], table, inputs=inputs)
    logger.info("\n%s", df.to_string())


if "snakemake" in globals():
    run(main, snakemake)
