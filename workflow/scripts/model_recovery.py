"""Rule `model_recovery`: identified Case 1 / Case 2 parameters, and Fig 4.8's U_H share at the
capture's frequency, against the twin's truth.

Alone: python workflow/scripts/model_recovery.py results/pi_p885/ch4/sets.csv \
    results/pi_p885/ch4/hysteresis_voltage.csv raw/pi_p885/ch4_sine_10hz_s1.nc out.csv --frequency 10
"""

import argparse

import pandas as pd

from selfsense.capture import open_capture
from selfsense.provenance import script_logging, write_table
from selfsense.recovery import hysteresis_share_recovery, model_recovery


def main(per_set, hysteresis, capture, table, frequency, log=None):
    """frequency: the capture's [Hz]."""
    logger = script_logging(log)
    with open_capture(capture) as cap:
        truth, states = cap.read_truth()
    result = pd.concat([model_recovery(pd.read_csv(per_set), truth),
                        hysteresis_share_recovery(pd.read_csv(hysteresis), states, frequency)], ignore_index=True)
    write_table(result, table, inputs=[per_set, hysteresis, capture], config={"frequency": frequency})
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    i = snakemake.input
    main(i.per_set, i.hysteresis, i.capture, snakemake.output.table, snakemake.params.frequency, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    for name in ("per_set", "hysteresis", "capture", "table"):
        cli.add_argument(name)
    cli.add_argument("--frequency", type=float, required=True, help="the capture's frequency [Hz]")
    main(**vars(cli.parse_args()))
