"""Rule `ch3_figures`: Figures 3.3, 3.4, 3.7 and 3.9–3.14 from the ripple series and one capture.

Alone: python workflow/scripts/ch3_figures.py --help
"""

import argparse
from pathlib import Path

import numpy as np

from selfsense.capture import open_capture, read_series
from selfsense.chapters import ch3
from selfsense.manifest import load_dataset
from selfsense.provenance import save_figure, script_logging


def main(capture_10hz, series, manifest, out_dir, skip_s=0.1, log=None):
    """series: {label: path} of ripple series, the 10 Hz one first."""
    logger = script_logging(log)
    out = Path(out_dir)
    data = {label: ch3.steady(read_series(path), skip_s) for label, path in series.items()}
    at_10hz = next(iter(data.values()))
    meta = load_dataset(Path(manifest).parent.parent, Path(manifest).parent.name)
    fr, ns = meta["daq"]["ripple"]["fr_nominal"], meta["daq"]["ripple"]["ns"]
    with open_capture(capture_10hz, require=("U", "I")) as cap:
        last = cap.read(("U", "I"), max(0, cap.n - int(0.2 * cap.fs)))
        t = (max(0, cap.n - int(0.2 * cap.fs)) + np.arange(len(last["U"]))) / cap.fs
    built = {
        "fig_3_3": ch3.figure_3_3(t, last["U"], last["I"], 10.0),
        "fig_3_4": ch3.figure_3_4(at_10hz, fr),
        "fig_3_7": ch3.figure_3_7(fr, ns),
        "fig_3_9": ch3.figure_3_9(at_10hz),
        "fig_3_10": ch3.loop_figure({"10 Hz": at_10hz}, "U", "C_e", "Effective capacitance against voltage"),
        "fig_3_11": ch3.loop_figure({"10 Hz": at_10hz}, "x_laser", "C_e", "Effective capacitance against position"),
        "fig_3_12": ch3.loop_figure({"10 Hz": at_10hz}, "U", "x_laser", "Position against voltage"),
        "fig_3_13": ch3.loop_figure(data, "x_laser", "C_e", "Effective capacitance against position at several frequencies"),
        "fig_3_14": ch3.loop_figure({"10 Hz": at_10hz}, "C_e", "R_e", "Effective resistance against effective capacitance"),
    }
    inputs = [capture_10hz, *series.values(), manifest]
    for name, fig in built.items():
        save_figure(fig, out / f"{name}.png", inputs=inputs, config={"skip_s": skip_s})
    logger.info("wrote %s", ", ".join(sorted(built)))


if "snakemake" in globals():
    main(snakemake.input.capture, dict(zip(snakemake.params.labels, snakemake.input.series)),
         snakemake.input.manifest, snakemake.params.out_dir, snakemake.params.skip_s, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("capture_10hz")
    cli.add_argument("manifest")
    cli.add_argument("out_dir")
    cli.add_argument("--series", nargs="+", required=True, help="label=path, the 10 Hz one first")
    args = cli.parse_args()
    main(args.capture_10hz, dict(s.split("=", 1) for s in args.series), args.manifest, args.out_dir)
