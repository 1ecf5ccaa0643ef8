"""Rule `capture_summary`: one row per capture of a dataset from its QC reports."""

import json
from pathlib import Path

import pandas as pd

from selfsense.io.provenance import run, script_logging, write_table


def summary(reports):
    rows = []
    for path in reports:
        r = json.loads(Path(path).read_text())
        rows.append(
            {
                "experiment": Path(r["path"]).stem,
                "duration [s]": r["duration_s"],
                "fs [Hz]": r["fs"],
                "samples": r["n_samples"],
                "channels": " ".join(r["channels"]),
                "NaN samples": sum(r["nan"].values()),
                "clipped samples": sum(r["clipped"].values()),
            }
        )
    columns = [
        "experiment",
        "duration [s]",
        "fs [Hz]",
        "samples",
        "channels",
        "NaN samples",
        "clipped samples",
    ]
    return pd.DataFrame(rows, columns=columns)


def main(reports, table, inputs, log=None):
    logger = script_logging(log)
    df = summary(reports)
    write_table(df, table, inputs=inputs)
    logger.info("%d captures", len(df))


if "snakemake" in globals():
    run(main, snakemake)
