"""Rule `error_budget`: the observer's Table 5.4 error (and Chapter 6's ε_OCL) split into its
sources with the twin's truth (selfsense.verify.error_budget.budget_table).
"""

from pathlib import Path

from selfsense.chapters import figures
from selfsense.io.provenance import run, save_figure, script_logging, write_table
from selfsense.methods.gamma import load_gamma
from selfsense.methods.observer import load_gains
from selfsense.verify.error_budget import SOURCES, budget_table


def main(
    captures,
    frequencies,
    loop_omega_c,
    p1_protocols,
    transient_s,
    gamma,
    observer,
    table,
    figure,
    n_periods,
    inputs,
    log,
    pdf,
):
    """By experiment: frequencies, its Table 5.4 frequency [Hz] or None; loop_omega_c, the loop's
    ω_C for a Chapter 6 closed-loop run or None; p1_protocols, the protocol of a P1 run or None;
    transient_s, the creep run's transient [s] or None."""
    logger = script_logging(log)
    settings = (frequencies, loop_omega_c, p1_protocols, transient_s)
    runs = {c: tuple(s[Path(c).stem] for s in settings) for c in captures}
    result = budget_table(runs, n_periods, load_gamma(gamma), load_gains(observer))
    config = {
        "n_periods": n_periods,
        "omega_c": [r[1] for r in runs.values()],
        "transient_s": [r[3] for r in runs.values()],
    }
    provenance = {"inputs": inputs, "config": config}
    write_table(result, table, **provenance)
    save_figure(figures.error_budget(result, SOURCES), figure, **provenance, pdf=pdf)
    logger.info("\n%s", result.T.to_string())


if "snakemake" in globals():
    run(main, snakemake)
