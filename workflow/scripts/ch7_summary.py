"""Rule `ch7_summary`: the coupled estimation's errors beside the thesis's (mixed run, Fig 7.12)
and Figures 7.10–7.12.
"""

import json
from pathlib import Path

from selfsense.chapters import ch7
from selfsense.io.capture import read_series
from selfsense.io.provenance import run, save_figure, script_logging, write_table


def main(stats, traces, figures, coupled, inputs, log, pdf, **out):
    """stats / traces: each run's, named after it; figures: {figure name: its run}; out: {figure
    name: path}."""
    logger = script_logging(log)
    records = {Path(p).stem: json.loads(Path(p).read_text()) for p in stats}
    trace_of = {Path(p).stem: p for p in traces}
    table = ch7.coupled_table(records, figures[ch7.MIXED_FIGURE])
    write_table(table, coupled, inputs=inputs)
    for name, experiment in figures.items():
        save_figure(
            ch7.figure_coupled(
                name, experiment, read_series(trace_of[experiment]), records[experiment]
            ),
            out[name],
            inputs=inputs,
            pdf=pdf,
        )
    logger.info("\n%s", table.to_string())


if "snakemake" in globals():
    run(main, snakemake)
