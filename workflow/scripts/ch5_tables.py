"""Rule `ch5_tables`: Table 5.4 (open-loop observer error per frequency) and the creep run."""

import json
from pathlib import Path

from selfsense.chapters.ch5 import creep_errors, table_5_4
from selfsense.io.capture import read_series
from selfsense.io.provenance import script_logging, write_table


def main(stats, creep_stats, creep_traces, table, creep_table, log=None):
    """stats: {frequency [Hz]: observe-stats json path}; the creep run's stats come with its phases'
    maxima and its warm-up, which its step ends (rule observe)."""
    logger = script_logging(log)
    by_f = {float(f): json.loads(Path(p).read_text()) for f, p in stats.items()}
    t54 = table_5_4(by_f)
    write_table(t54, table, inputs=list(stats.values()))
    creep_run = json.loads(Path(creep_stats).read_text())
    creep = creep_errors(creep_run, read_series(creep_traces), creep_run["warmup [s]"])
    write_table(creep, creep_table, inputs=[creep_stats, creep_traces])
    logger.info("\n%s\n%s", t54.to_string(), creep.to_string())


if "snakemake" in globals():
    p = snakemake.params
    main(
        dict(zip(p.frequencies, snakemake.input.stats)),
        snakemake.input.creep_stats,
        snakemake.input.creep,
        snakemake.output.table,
        snakemake.output.creep,
        snakemake.log[0],
    )
