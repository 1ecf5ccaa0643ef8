"""Rule `powerloss_figures`: Figures 2–11 of Ronkanen 2002 from the captures and the identified constants.

Alone: python workflow/scripts/powerloss_figures.py raw/tokin_nb40/rk_static_hold.nc table_1.csv table_2.csv \
    identified.csv figures/tokin_nb40 --ramps <10 GΩ> <1 GΩ> <2 GΩ> --captures decay_current=... --drift-start 40
"""

import argparse
from pathlib import Path

import pandas as pd

from selfsense.chapters import ronkanen
from selfsense.io.provenance import save_figure, script_logging


def main(
    hold,
    ramps,
    captures,
    table_1,
    table_2,
    identified,
    out,
    drift_start,
    velocity_window=2.0,
    log=None,
):
    """ramps: the ±300 nA ramps compensated for too large, too small and ideal X (Figs 3, 4, 5–6);
    captures: {"<decay|repeat|drift>_<current|voltage>": path}; out: {figure name: path}."""
    logger = script_logging(log)
    records = ronkanen.read_records([hold, *ramps, *captures.values()])
    built = ronkanen.figures_paper(
        records[Path(hold).stem],
        [records[Path(r).stem] for r in ramps],
        ronkanen.by_kind(records, captures),
        pd.read_csv(table_1),
        pd.read_csv(table_2),
        ronkanen.load_identified(identified, "a_cmd"),
        drift_start,
        velocity_window,
    )
    inputs = [hold, *ramps, *captures.values(), table_1, table_2, identified]
    config = {"velocity_window": velocity_window, "drift_start": drift_start}
    for name, fig in built.items():
        save_figure(fig, out[name], inputs=inputs, config=config)
        ronkanen.plt.close(fig)
    logger.info("wrote %s", ", ".join(out[name] for name in built))


if "snakemake" in globals():
    i, p = snakemake.input, snakemake.params
    main(
        i.hold,
        list(i.ramps),
        {k: i[k] for k in ronkanen.PAIRS},
        i.table_1,
        i.table_2,
        i.identified,
        dict(snakemake.output.items()),
        p.drift_start,
        p.velocity_window,
        snakemake.log[0],
    )
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    for name in ("hold", "table_1", "table_2", "identified", "out_dir"):
        cli.add_argument(name)
    cli.add_argument("--ramps", nargs=3, required=True)
    cli.add_argument("--captures", nargs="+", required=True, help="<kind>_<control>=path")
    cli.add_argument("--drift-start", dest="drift_start", type=float, required=True, help="[s]")
    cli.add_argument(
        "--velocity-window", dest="velocity_window", type=float, default=2.0, help="[s]"
    )
    args = cli.parse_args()
    main(
        args.hold,
        args.ramps,
        dict(c.split("=", 1) for c in args.captures),
        args.table_1,
        args.table_2,
        args.identified,
        {name: str(Path(args.out_dir) / f"{name}.png") for name in ronkanen.FIGURES.values()},
        args.drift_start,
        args.velocity_window,
    )
