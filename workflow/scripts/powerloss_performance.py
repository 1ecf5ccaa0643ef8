"""Rule `powerloss_performance`: hysteresis, drift, repeatability and max error, current vs
voltage control.
"""

from pathlib import Path

import pandas as pd

from selfsense.chapters import ronkanen
from selfsense.io.provenance import run, script_logging, write_table


def main(
    captures,
    pairs,
    identified,
    performance,
    repeatability,
    drift_start,
    drift_duration,
    inputs,
    log,
):
    """pairs: {"<decay|repeat|drift>_<current|voltage>": experiment} of the captures."""
    logger = script_logging(log)
    a_cmd = ronkanen.load_identified(identified, "a_cmd")
    capture_of = {Path(c).stem: c for c in captures}
    paths = {pair: capture_of[e] for pair, e in pairs.items()}
    kind = ronkanen.by_kind(ronkanen.read_records(paths.values()), paths)
    table = ronkanen.performance(
        kind["decay"], kind["repeat"], kind["drift"], a_cmd, drift_start, drift_duration
    )
    cycles = pd.concat(
        [ronkanen.cycles(rec, a_cmd).assign(control=c) for c, rec in kind["repeat"].items()]
    )
    config = {"drift_start": drift_start, "drift_duration": drift_duration}
    write_table(table, performance, inputs=inputs, config=config)
    write_table(cycles, repeatability, inputs=inputs, config=config)
    logger.info("a_cmd = %g m/C\n%s", a_cmd, table.to_string())


if "snakemake" in globals():
    run(main, snakemake)
