"""Rule `ch4_figures`: Figures 4.2–4.8 from the sets' ripple series and two captures."""

from pathlib import Path

import numpy as np
import pandas as pd

from selfsense.chapters import ch4
from selfsense.io.capture import open_capture, read_series
from selfsense.io.provenance import run, save_figure, script_logging


def channel(capture, name):
    with open_capture(capture, require=(name,)) as cap:
        return {"t": np.arange(cap.n) / cap.fs, name: cap.read((name,))[name]}


def main(series, per_set, force, drive, inputs, log, pdf, **out):
    """out: {figure name: path}."""
    logger = script_logging(log)
    sets = {Path(p).stem: read_series(p) for p in series}
    fits = ch4.fits_from_table(pd.read_csv(per_set))
    built = ch4.figures_ch4(sets, fits, channel(force, "F"), channel(drive, "U"))
    for name, fig in built.items():
        save_figure(fig, out[name], inputs=inputs, pdf=pdf)
    logger.info("wrote %s", ", ".join(sorted(built)))


if "snakemake" in globals():
    run(main, snakemake)
