"""Rule `ch3_model_figure`: Figure 3.2, ripple-driven velocity free vs clamped (model)."""

from selfsense.chapters.ch3 import figure_3_2
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import run, save_figure, script_logging


def main(manifest, figure, inputs, log, pdf):
    logger = script_logging(log)
    twin = load_manifest(manifest)["twin"]
    save_figure(
        figure_3_2(twin["stack"], twin["ripple"]["amplitude"], twin["ripple"]["f_nominal"]),
        figure,
        inputs=inputs,
        pdf=pdf,
    )
    logger.info("wrote %s", figure)


if "snakemake" in globals():
    run(main, snakemake)
