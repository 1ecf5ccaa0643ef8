"""Rule `ch7_summary`: the coupled estimation's errors beside the thesis's (mixed run, Fig 7.12)
and Figures 7.10–7.12.
"""

import json
from pathlib import Path

from selfsense.chapters import ch7
from selfsense.io.capture import read_series
from selfsense.io.provenance import save_figure, script_logging, write_table


def main(stats, traces, figures, out, log=None, pdf=True):
    """stats / traces: {run: path}; figures: {figure name: its run}; out: {"coupled" or figure
    name: path}."""
    logger = script_logging(log)
    records = {run: json.loads(Path(path).read_text()) for run, path in stats.items()}
    coupled = ch7.coupled_table(records, figures[ch7.MIXED_FIGURE])
    write_table(coupled, out["coupled"], inputs=list(stats.values()))
    for name, run in figures.items():
        save_figure(
            ch7.figure_coupled(name, run, read_series(traces[run]), records[run]),
            out[name],
            inputs=[traces[run]],
            pdf=pdf,
        )
    logger.info("\n%s", coupled.to_string())


if "snakemake" in globals():
    i, p = snakemake.input, snakemake.params
    main(
        dict(zip(p.runs, i.stats)),
        dict(zip(p.runs, i.traces)),
        dict(zip(ch7.COUPLED_FIGURES, p.runs)),
        dict(snakemake.output.items()),
        snakemake.log[0],
        pdf=p.pdf,
    )
