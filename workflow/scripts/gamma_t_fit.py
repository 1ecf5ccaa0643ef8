"""Rule `gamma_t_fit`: Γ_T with temperature (Eq 7.13) on the 50 Hz heating run — Tables 7.2, 7.3.

Alone: python workflow/scripts/gamma_t_fit.py samples.nc power.nc out_dir
"""

import argparse
from pathlib import Path

from selfsense.capture import read_series
from selfsense.chapters.ch7 import GAMMA_T_FIGURE, figure_7_7, gamma_t
from selfsense.gamma import GammaPolynomial
from selfsense.provenance import provenance, save_figure, script_logging, write_json, write_table


def main(samples, power, out, figure, orders=(4, 5, 6), order=5, log=None):
    logger = script_logging(log)
    s, p = read_series(samples), read_series(power)
    t72, anova, coefs, fit = gamma_t(s, p["time"], p["T_mid"], orders, order)
    cfg = {"orders": list(orders), "order": order}
    write_table(t72, out["table_7_2"], inputs=[samples, power], config=cfg)
    write_table(anova, out["anova"], inputs=[samples, power], config=cfg)
    write_table(coefs, out["coefficients"], inputs=[samples, power], config=cfg)
    write_json(GammaPolynomial.from_fit(fit).record() | {"provenance": provenance([samples, power], cfg)},
               out["gamma_t"])
    save_figure(figure_7_7(s), figure, inputs=[samples, power])
    logger.info("\n%s", t72.to_string())


if "snakemake" in globals():
    main(snakemake.input.samples, snakemake.input.power, dict(snakemake.output.items()), snakemake.output.figure,
         snakemake.params.orders, snakemake.params.order, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    for name in ("samples", "power", "out_dir"):
        cli.add_argument(name)
    a = cli.parse_args()
    d = Path(a.out_dir)
    main(a.samples, a.power, {"table_7_2": d / "table_7_2.csv", "anova": d / "table_7_3_anova.csv",
                              "coefficients": d / "table_7_3_coefficients.csv", "gamma_t": d / "gamma_t.json"},
         d / f"{GAMMA_T_FIGURE}.png")
