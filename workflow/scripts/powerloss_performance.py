"""Rule `powerloss_performance`: hysteresis, drift, repeatability and max error, current vs
voltage control.
"""

import pandas as pd

from selfsense.chapters import ronkanen
from selfsense.io.provenance import script_logging, write_table


def main(
    captures, identified, performance, repeatability, drift_start, drift_duration=120.0, log=None
):
    """captures: {"<decay|repeat|drift>_<current|voltage>": path}."""
    logger = script_logging(log)
    a_cmd = ronkanen.load_identified(identified, "a_cmd")
    kind = ronkanen.by_kind(ronkanen.read_records(captures.values()), captures)
    table = ronkanen.performance(
        kind["decay"], kind["repeat"], kind["drift"], a_cmd, drift_start, drift_duration
    )
    cycles = pd.concat(
        [ronkanen.cycles(rec, a_cmd).assign(control=c) for c, rec in kind["repeat"].items()]
    )
    config = {"drift_start": drift_start, "drift_duration": drift_duration}
    inputs = [*captures.values(), identified]
    write_table(table, performance, inputs=inputs, config=config)
    write_table(cycles, repeatability, inputs=inputs, config=config)
    logger.info("a_cmd = %g m/C\n%s", a_cmd, table.to_string())


if "snakemake" in globals():
    i, p = snakemake.input, snakemake.params
    main(
        {k: i[k] for k in ronkanen.PAIRS},
        i.identified,
        snakemake.output.performance,
        snakemake.output.repeatability,
        p.drift_start,
        p.drift_duration,
        snakemake.log[0],
    )
