"""Rule `ch3_hysteresis`: loop widths of C–U, C–x, R–C, x–U at 100 V, 10 Hz vs the thesis, and the
drive and ripple U–I phases (Figs 3.3–3.4).

Alone: python workflow/scripts/ch3_hysteresis.py results/pi_p885/ripple/ch3_sine_10hz.nc out.csv phases.csv
"""

import argparse

from selfsense.chapters.ch3 import hysteresis_table, phase_table, steady
from selfsense.io.capture import read_series
from selfsense.io.provenance import script_logging, write_table


def main(series, table, phases, skip_s=0.1, frequency=10.0, log=None):
    logger = script_logging(log)
    data = steady(read_series(series), skip_s)
    result, angles = hysteresis_table(data), phase_table(data, frequency)
    write_table(result, table, inputs=[series], config={"skip_s": skip_s})
    write_table(angles, phases, inputs=[series], config={"skip_s": skip_s, "frequency": frequency})
    logger.info("\n%s\n%s", result.to_string(), angles.to_string())


if "snakemake" in globals():
    main(
        snakemake.input.series,
        snakemake.output.table,
        snakemake.output.phases,
        snakemake.params.skip_s,
        snakemake.params.frequency,
        snakemake.log[0],
    )
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("series")
    cli.add_argument("table")
    cli.add_argument("phases")
    main(**vars(cli.parse_args()))
