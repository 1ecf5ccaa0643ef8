"""Rule `ch6_figures`: Figures 6.2–6.8 from the Chapter 6 runs' 4 kHz series (means over one
folded ripple period, as Tables 6.1–6.2 read them)."""

from pathlib import Path

from selfsense.chapters import ch6
from selfsense.io.provenance import run, save_figure, script_logging


def main(captures, protocols, profiles, inputs, log, pdf, **out):
    """profiles: {profile: (open-loop run, closed-loop run)}; out: {figure name: path}."""
    logger = script_logging(log)
    runs = {Path(p).stem: ch6.load_run(p, protocols[Path(p).stem]) for p in captures}
    built = ch6.figures_ch6(runs, protocols, profiles)
    for name, fig in built.items():
        save_figure(fig, out[name], inputs=inputs, pdf=pdf)
    logger.info("wrote %s", ", ".join(sorted(built)))


if "snakemake" in globals():
    run(main, snakemake)
