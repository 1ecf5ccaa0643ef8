"""Rule `error_budget`: the observer's Table 5.4 error (and Chapter 6's ε_OCL) split into its
sources with the twin's truth (selfsense.verify.error_budget.budget_table).
"""

from selfsense.io import figures
from selfsense.io.provenance import save_figure, script_logging, write_table
from selfsense.methods.gamma import load_gamma
from selfsense.methods.observer import load_gains
from selfsense.verify.error_budget import SOURCES, budget_table


def main(runs, gamma, observer, table, figure, n_periods, log=None, pdf=True):
    """runs: {capture path: (Table 5.4 frequency [Hz] or None, the loop's ω_C for a Chapter 6
    closed-loop run or None, the protocol of a P1 run or None, the creep run's transient [s] or
    None)}."""
    logger = script_logging(log)
    result = budget_table(runs, n_periods, load_gamma(gamma), load_gains(observer))
    config = {
        "n_periods": n_periods,
        "omega_c": [r[1] for r in runs.values()],
        "transient_s": [r[3] for r in runs.values()],
    }
    provenance = {"inputs": [*runs, gamma, observer], "config": config}
    write_table(result, table, **provenance)
    save_figure(figures.error_budget(result, SOURCES), figure, **provenance, pdf=pdf)
    logger.info("\n%s", result.T.to_string())


if "snakemake" in globals():
    i = snakemake.input
    p = snakemake.params
    main(
        dict(zip(i.captures, zip(p.frequencies, p.loop_omega_c, p.p1_protocols, p.transient_s))),
        i.gamma,
        i.observer,
        snakemake.output.table,
        snakemake.output.figure,
        p.n_periods,
        snakemake.log[0],
        pdf=p.pdf,
    )
