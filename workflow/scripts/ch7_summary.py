"""Rule `ch7_summary`: the coupled estimation's errors beside the thesis's (mixed run, Fig 7.12),
Figures 7.10–7.12, and τ, γ, k_T and Γ_T's g against the twin's truth.

Alone: run through Snakemake (`snakemake results/pi_p885/ch7/coupled.csv`).
"""

import json
from pathlib import Path

import pandas as pd

from selfsense.capture import open_capture, read_series
from selfsense.chapters import ch7
from selfsense.gamma import load_gamma
from selfsense.provenance import save_figure, script_logging, write_table


def main(stats, traces, table_7_1, gamma_t, truth_capture, out, log=None):
    """stats / traces: {run: path}; out: {"coupled", "recovery" or figure name: path}."""
    logger = script_logging(log)
    records = {run: json.loads(Path(path).read_text()) for run, path in stats.items()}
    coupled = ch7.coupled_table(records)
    write_table(coupled, out["coupled"], inputs=list(stats.values()))
    for name, run in ch7.COUPLED_FIGURES.items():
        save_figure(ch7.figure_coupled(name, run, read_series(traces[run]), records[run]), out[name],
                    inputs=[traces[run]])
    with open_capture(truth_capture) as cap:
        truth, _ = cap.read_truth()
    recovery = ch7.thermal_recovery(pd.read_csv(table_7_1), truth, load_gamma(gamma_t).g)
    write_table(recovery, out["recovery"], inputs=[table_7_1, gamma_t, truth_capture])
    logger.info("\n%s\n%s", coupled.to_string(), recovery.to_string())


if "snakemake" in globals():
    i, p = snakemake.input, snakemake.params
    main(dict(zip(p.runs, i.stats)), dict(zip(p.runs, i.traces)), i.table_7_1, i.gamma_t, i.truth_capture,
         dict(snakemake.output.items()), snakemake.log[0])
