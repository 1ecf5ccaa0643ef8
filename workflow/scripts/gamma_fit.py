"""Rule `gamma_fit`: Γ (Eq 5.4) on the 0.1 Hz data — Table 5.1, Table 5.2, the chosen order.

Alone: python workflow/scripts/gamma_fit.py results/pi_p885/ripple/ch5_sine_0p1hz.nc out_dir --np 4
"""

import argparse
from pathlib import Path

from selfsense.capture import read_series
from selfsense.chapters.ch5 import basis_table, fit_chosen_gamma, gamma_data
from selfsense.gamma import GammaPolynomial, anova_table, coefficient_table
from selfsense.provenance import provenance, script_logging, write_json, write_table


def main(series, out, n_periods, orders=(3, 4, 5, 6), log=None):
    logger = script_logging(log)
    C, x = gamma_data(read_series(series), n_periods)
    table, order, fit = fit_chosen_gamma(C, x, orders)
    cfg = {"n_periods": n_periods, "orders": list(orders)}
    write_table(table, out["table_5_1"], inputs=[series], config=cfg)
    write_table(anova_table(fit).reset_index(names="source"), out["anova"], inputs=[series], config=cfg)
    write_table(coefficient_table(fit).reset_index(names="coefficient"), out["coefficients"], inputs=[series], config=cfg)
    write_table(basis_table(C, x, order, fit), out["basis"], inputs=[series], config=cfg)
    write_json(GammaPolynomial.from_fit(fit).record() | {"provenance": provenance([series], cfg)},
               out["gamma"])
    logger.info("chosen order %d\n%s", order, table.to_string())


if "snakemake" in globals():
    main(snakemake.input.series, dict(snakemake.output.items()), snakemake.params.n_periods,
         snakemake.params.orders, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("series")
    cli.add_argument("out_dir")
    cli.add_argument("--np", dest="n_periods", type=int, default=4)
    a = cli.parse_args()
    names = {"table_5_1": "table_5_1.csv", "anova": "table_5_2_anova.csv", "coefficients": "table_5_2_coefficients.csv",
             "basis": "gamma_basis.csv", "gamma": "gamma.json"}
    main(a.series, {k: str(Path(a.out_dir) / v) for k, v in names.items()}, a.n_periods)
