"""Rule `audit_realtime`: for every closed-loop capture of a dataset, the self-sensing chain
recomputed offline from the raw channels against the real-time estimate the loop logged (the
published loop used what the pipeline analyses) → one row per run.
"""

from pathlib import Path

import pandas as pd

from selfsense.io.provenance import run, script_logging, write_table
from selfsense.methods.gamma import load_gamma
from selfsense.methods.observer import load_gains
from selfsense.methods.selfsensing import audit_realtime


def main(captures, gamma, observer, table, n_periods, inputs, log=None):
    logger = script_logging(log)
    poly, gains, rows = load_gamma(gamma), load_gains(observer), []
    for k, capture in enumerate(captures, 1):
        audit = audit_realtime(capture, poly, gains, n_periods)
        rows.append(
            {"run": Path(capture).stem}
            | {f"{key} [nm]": value * 1e9 for key, value in audit.items()}
        )
        logger.info(
            "%d/%d %s: offline vs logged HPO differ by at most %.3f nm",
            k,
            len(captures),
            capture,
            rows[-1]["max |offline − logged| [nm]"],
        )
    write_table(
        pd.DataFrame(rows),
        table,
        inputs=inputs,
        config={"n_periods": n_periods},
    )


if "snakemake" in globals():
    run(main, snakemake)
