"""Rule `ch3_figures`: Figures 3.3, 3.4, 3.7 and 3.9–3.14 from the ripple series and one capture.

Alone: python workflow/scripts/ch3_figures.py --help
"""

import argparse
from pathlib import Path

from selfsense.chapters import ch3
from selfsense.io.capture import read_series
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import save_figure, script_logging


def main(capture_10hz, series, manifest, out, skip_s=0.1, log=None):
    """series: {label: path} of ripple series, the 10 Hz one first; out: {figure name: path}."""
    logger = script_logging(log)
    data = {label: ch3.steady(read_series(path), skip_s) for label, path in series.items()}
    ripple = load_manifest(manifest)["daq"]["ripple"]
    built = ch3.figures_ch3(capture_10hz, data, ripple["fr_nominal"], ripple["ns"])
    inputs = [capture_10hz, *series.values(), manifest]
    for name, fig in built.items():
        save_figure(fig, out[name], inputs=inputs, config={"skip_s": skip_s})
    logger.info("wrote %s", ", ".join(sorted(built)))


if "snakemake" in globals():
    main(
        snakemake.input.capture,
        dict(zip(snakemake.params.labels, snakemake.input.series)),
        snakemake.input.manifest,
        dict(snakemake.output.items()),
        snakemake.params.skip_s,
        snakemake.log[0],
    )
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("capture_10hz")
    cli.add_argument("manifest")
    cli.add_argument("out_dir")
    cli.add_argument("--series", nargs="+", required=True, help="label=path, the 10 Hz one first")
    args = cli.parse_args()
    main(
        args.capture_10hz,
        dict(s.split("=", 1) for s in args.series),
        args.manifest,
        {name: Path(args.out_dir) / f"{name}.png" for name in ch3.FIGURES},
    )
