"""Rule `powerloss_figures`: Figures 2–11 of Ronkanen 2002 from the captures and the identified
constants (selfsense.chapters.ronkanen.figures_paper)."""

import pandas as pd

from selfsense.chapters import ronkanen
from selfsense.io.provenance import save_figure, script_logging


def main(
    hold, ramps, captures, table_1, table_2, identified, out, drift_start, velocity_window, log, pdf
):
    logger = script_logging(log)
    records = ronkanen.read_records([hold, *ramps, *captures.values()])
    t1, t2 = pd.read_csv(table_1), pd.read_csv(table_2)
    a_cmd = ronkanen.load_identified(identified, "a_cmd")
    built = ronkanen.figures_paper(
        records, hold, ramps, captures, t1, t2, a_cmd, drift_start, velocity_window
    )
    inputs = [hold, *ramps, *captures.values(), table_1, table_2, identified]
    config = {"velocity_window": velocity_window, "drift_start": drift_start}
    for name, fig in built.items():
        save_figure(fig, out[name], inputs=inputs, config=config, pdf=pdf)
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
        pdf=p.pdf,
    )
