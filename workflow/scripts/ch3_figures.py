"""Rule `ch3_figures`: Figures 3.3, 3.4, 3.7 and 3.9–3.14 from the ripple series and one capture."""

from pathlib import Path

from selfsense.chapters import ch3
from selfsense.io.capture import read_series
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import run, save_figure, script_logging


def main(capture, series, labels, manifest, skip_s, inputs, log, pdf, **out):
    """series: the ripple series, the 10 Hz one first; labels: {experiment: label};
    out: {figure name: path}."""
    logger = script_logging(log)
    data = {labels[Path(p).stem]: ch3.steady(read_series(p), skip_s) for p in series}
    ripple = load_manifest(manifest)["daq"]["ripple"]
    built = ch3.figures_ch3(capture, data, ripple["fr_nominal"], ripple["ns"])
    for name, fig in built.items():
        save_figure(fig, out[name], inputs=inputs, config={"skip_s": skip_s}, pdf=pdf)
    logger.info("wrote %s", ", ".join(sorted(built)))


if "snakemake" in globals():
    run(main, snakemake)
