"""Rule `ch3_hysteresis`: loop widths of C–U, C–x, R–C, x–U at 100 V, 10 Hz vs the thesis, and the
drive and ripple U–I phases (Figs 3.3–3.4).
"""

from selfsense.chapters.ch3 import hysteresis_table, phase_table, steady
from selfsense.io.capture import read_series
from selfsense.io.provenance import run, script_logging, write_table


def main(series, table, phases, skip_s, frequency, inputs, log=None):
    logger = script_logging(log)
    data = steady(read_series(series), skip_s)
    result, angles = hysteresis_table(data), phase_table(data, frequency)
    write_table(result, table, inputs=inputs, config={"skip_s": skip_s})
    write_table(angles, phases, inputs=inputs, config={"skip_s": skip_s, "frequency": frequency})
    logger.info("\n%s\n%s", result.to_string(), angles.to_string())


if "snakemake" in globals():
    run(main, snakemake)
