"""Rule `error_budget`: the observer's Table 5.4 error split into its sources with the twin's truth.

Alone: python workflow/scripts/error_budget.py gamma.json observer.json out.csv out.png --runs raw/pi_p885/ch5_sine_1hz.nc=1 raw/pi_p885/ch5_creep.nc
"""

import argparse
from pathlib import Path

import pandas as pd

from selfsense import figures
from selfsense.capture import open_capture
from selfsense.error_budget import SOURCES, Truth, run_budget
from selfsense.gamma import load_gamma
from selfsense.observer import load_gains
from selfsense.provenance import save_figure, script_logging, write_table
from selfsense.ripple import plan_from_capture

CHANNELS = ("Ur", "Ir", "I", "x_laser")  # as rule `observe` streams them, so the chunks are the same


def main(runs, gamma, observer, table, figure, n_periods, log=None):
    """runs: {capture path: Table 5.4 frequency [Hz], None for the creep run}."""
    logger, poly, gains, rows = script_logging(log), load_gamma(gamma), load_gains(observer), []
    for capture, frequency in runs.items():
        with open_capture(capture, require=CHANNELS) as cap:
            truth = Truth.from_group(*cap.read_truth(), cap.length(), capture)
            row = run_budget(cap.iter_chunks(CHANNELS), plan_from_capture(cap, n_periods), poly, gains, cap.fs,
                             float(cap.attribute("warmup_s")), truth)
        rows.append({"run": Path(capture).stem, "frequency [Hz]": frequency} | row)
    result = pd.DataFrame(rows).astype({"frequency [Hz]": float})
    provenance = {"inputs": [*runs, gamma, observer], "config": {"n_periods": n_periods}}
    write_table(result, table, **provenance)
    save_figure(figures.error_budget(result, SOURCES), figure, **provenance)
    logger.info("\n%s", result.T.to_string())


if "snakemake" in globals():
    i = snakemake.input
    main(dict(zip(i.captures, snakemake.params.frequencies)), i.gamma, i.observer, snakemake.output.table,
         snakemake.output.figure, snakemake.params.n_periods, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    for name in ("gamma", "observer", "table", "figure"):
        cli.add_argument(name)
    cli.add_argument("--runs", nargs="+", required=True, help="capture[=Table 5.4 frequency in Hz]")
    cli.add_argument("--np", dest="n_periods", type=int, default=4)
    a = cli.parse_args()
    main({c: float(f) if f else None for c, _, f in (r.partition("=") for r in a.runs)}, a.gamma, a.observer, a.table,
         a.figure, a.n_periods)
