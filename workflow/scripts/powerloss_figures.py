"""Rule `powerloss_figures`: Figures 2–11 of Ronkanen 2002 from the captures and the identified
constants (selfsense.chapters.ronkanen.figures_paper)."""

from pathlib import Path

import pandas as pd

from selfsense.chapters import ronkanen
from selfsense.io.provenance import run, save_figure, script_logging


def main(
    hold,
    ramps,
    captures,
    pairs,
    table_1,
    table_2,
    identified,
    drift_start,
    velocity_window,
    inputs,
    log,
    pdf,
    **out,
):
    """pairs: {"<decay|repeat|drift>_<current|voltage>": experiment} of the captures."""
    logger = script_logging(log)
    capture_of = {Path(c).stem: c for c in captures}
    captures = {pair: capture_of[e] for pair, e in pairs.items()}
    records = ronkanen.read_records([hold, *ramps, *captures.values()])
    t1, t2 = pd.read_csv(table_1), pd.read_csv(table_2)
    a_cmd = ronkanen.load_identified(identified, "a_cmd")
    built = ronkanen.figures_paper(
        records, hold, ramps, captures, t1, t2, a_cmd, drift_start, velocity_window
    )
    config = {"velocity_window": velocity_window, "drift_start": drift_start}
    for name, fig in built.items():
        save_figure(fig, out[name], inputs=inputs, config=config, pdf=pdf)
        ronkanen.plt.close(fig)
    logger.info("wrote %s", ", ".join(out[name] for name in built))


if "snakemake" in globals():
    run(main, snakemake)
