"""Rule `gamma_t_fit`: Γ_T with temperature (Eq 7.13) on the 50 Hz heating run — Tables 7.2, 7.3
(at the thesis's n = 5) and Γ_T of the order validated on the hotter 100 Hz run.

Alone: python workflow/scripts/gamma_t_fit.py samples.nc power.nc val_samples.nc val_power.nc out_dir
"""

import argparse
from pathlib import Path

from selfsense.chapters.ch7 import GAMMA_T_FIGURE, figure_7_7, gamma_t, gamma_t_data
from selfsense.io.capture import read_series
from selfsense.io.provenance import provenance, save_figure, script_logging, write_json, write_table
from selfsense.methods.gamma import GammaPolynomial

NAMES = {
    "table_7_2": "table_7_2.csv",
    "anova": "table_7_3_anova.csv",
    "coefficients": "table_7_3_coefficients.csv",
    "order": "gamma_t_order.csv",
    "gamma_t": "gamma_t.json",
    "gamma_t_n5": "gamma_t_n5.json",
}


def main(
    samples,
    power,
    val_samples,
    val_power,
    out,
    figure,
    orders=(4, 5, 6),
    order=5,
    candidates=(1, 2, 3, 4, 5, 6),
    log=None,
):
    logger = script_logging(log)
    s, p, vs, vp = (read_series(f) for f in (samples, power, val_samples, val_power))
    tables, fits = gamma_t(
        gamma_t_data(s, p["time"], p["T_mid"]),
        gamma_t_data(vs, vp["time"], vp["T_mid"]),
        orders,
        order,
        candidates,
    )
    inputs, cfg = (
        [samples, power, val_samples, val_power],
        {"orders": list(orders), "order": order, "candidates": list(candidates)},
    )
    for name, table in tables.items():
        write_table(table, out[name], inputs=inputs, config=cfg)
    for name, fit in fits.items():
        write_json(
            GammaPolynomial.from_fit(fit).record() | {"provenance": provenance(inputs, cfg)},
            out[name],
        )
    save_figure(figure_7_7(s), figure, inputs=inputs)
    logger.info("\n%s\n%s", tables["table_7_2"].to_string(), tables["order"].to_string())


if "snakemake" in globals():
    i, p = snakemake.input, snakemake.params
    main(
        i.samples,
        i.power,
        i.val_samples,
        i.val_power,
        dict(snakemake.output.items()),
        snakemake.output.figure,
        p.orders,
        p.order,
        p.candidates,
        snakemake.log[0],
    )
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    for name in ("samples", "power", "val_samples", "val_power", "out_dir"):
        cli.add_argument(name)
    a = cli.parse_args()
    d = Path(a.out_dir)
    main(
        a.samples,
        a.power,
        a.val_samples,
        a.val_power,
        {k: d / v for k, v in NAMES.items()},
        d / f"{GAMMA_T_FIGURE}.png",
    )
