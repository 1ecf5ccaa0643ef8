"""Rule `ch3_hysteresis`: loop widths of C–U, C–x, R–C, x–U at 100 V, 10 Hz vs the thesis.

Alone: python workflow/scripts/ch3_hysteresis.py results/pi_p885/ripple/ch3_sine_10hz.nc out.csv
"""

import argparse

from selfsense.capture import read_series
from selfsense.chapters.ch3 import hysteresis_table, steady
from selfsense.provenance import script_logging, write_table


def main(series, table, skip_s=0.1, log=None):
    logger = script_logging(log)
    result = hysteresis_table(steady(read_series(series), skip_s))
    write_table(result, table, inputs=[series], config={"skip_s": skip_s})
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    main(snakemake.input.series, snakemake.output.table, snakemake.params.skip_s, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("series")
    cli.add_argument("table")
    main(**vars(cli.parse_args()))
