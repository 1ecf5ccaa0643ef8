"""Rule `ch5_tables`: Table 5.4 (open-loop observer error per frequency) and the creep run."""

import json
from pathlib import Path

from selfsense.chapters.ch5 import creep_errors, table_5_4
from selfsense.io.capture import read_series
from selfsense.io.provenance import run, script_logging, write_table


def main(stats, frequencies, creep_stats, creep_traces, table, creep, inputs, log=None):
    """stats: observe-stats json paths; frequencies: {experiment: frequency [Hz]}; the creep run's
    stats come with its phases' maxima and its warm-up, which its step ends (rule observe)."""
    logger = script_logging(log)
    by_f = {float(frequencies[Path(p).stem]): json.loads(Path(p).read_text()) for p in stats}
    t54 = table_5_4(by_f)
    write_table(t54, table, inputs=inputs)
    creep_run = json.loads(Path(creep_stats).read_text())
    errors = creep_errors(creep_run, read_series(creep_traces), creep_run["warmup [s]"])
    write_table(errors, creep, inputs=inputs)
    logger.info("\n%s\n%s", t54.to_string(), errors.to_string())


if "snakemake" in globals():
    run(main, snakemake)
