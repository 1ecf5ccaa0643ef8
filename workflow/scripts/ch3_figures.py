"""Rule `ch3_figures`: Figures 3.3, 3.4, 3.7 and 3.9–3.14 from the ripple series and one capture."""

from selfsense.chapters import ch3
from selfsense.io.capture import read_series
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import save_figure, script_logging


def main(capture_10hz, series, manifest, out, skip_s=0.1, log=None, pdf=True):
    """series: {label: path} of ripple series, the 10 Hz one first; out: {figure name: path}."""
    logger = script_logging(log)
    data = {label: ch3.steady(read_series(path), skip_s) for label, path in series.items()}
    ripple = load_manifest(manifest)["daq"]["ripple"]
    built = ch3.figures_ch3(capture_10hz, data, ripple["fr_nominal"], ripple["ns"])
    inputs = [capture_10hz, *series.values(), manifest]
    for name, fig in built.items():
        save_figure(fig, out[name], inputs=inputs, config={"skip_s": skip_s}, pdf=pdf)
    logger.info("wrote %s", ", ".join(sorted(built)))


if "snakemake" in globals():
    main(
        snakemake.input.capture,
        dict(zip(snakemake.params.labels, snakemake.input.series)),
        snakemake.input.manifest,
        dict(snakemake.output.items()),
        snakemake.params.skip_s,
        snakemake.log[0],
        pdf=snakemake.params.pdf,
    )
