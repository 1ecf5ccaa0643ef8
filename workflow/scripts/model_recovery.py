"""Rule `model_recovery`: identified Case 1 / Case 2 parameters against the twin's truth.

Alone: python workflow/scripts/model_recovery.py results/pi_p885/ch4/sets.csv raw/pi_p885/ch4_sine_10hz_s1.nc out.csv
"""

import argparse

import pandas as pd

from selfsense.capture import open_capture
from selfsense.provenance import script_logging, write_table
from selfsense.recovery import model_recovery


def main(per_set, capture, table, log=None):
    logger = script_logging(log)
    with open_capture(capture) as cap:
        truth, _ = cap.read_truth()
    result = model_recovery(pd.read_csv(per_set), truth)
    write_table(result, table, inputs=[per_set, capture])
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    main(snakemake.input.per_set, snakemake.input.capture, snakemake.output.table, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    for name in ("per_set", "capture", "table"):
        cli.add_argument(name)
    main(**vars(cli.parse_args()))
