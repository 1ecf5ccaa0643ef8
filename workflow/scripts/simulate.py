"""Rule `simulate`: one experiment on the digital twin → raw/<dataset>/<experiment>.nc and its QC
report results/<dataset>/qc/<experiment>.json (the capture is validated as it is written).
"""

from pathlib import Path

from selfsense.io.capture import write_scan_report
from selfsense.io.provenance import script_logging
from selfsense.twin.experiment import simulate_experiment


def main(raw_dir, dataset, experiment, campaign, capture, output=None, report=None, log=None):
    logger = script_logging(log)
    scan = simulate_experiment(
        raw_dir, dataset, experiment, {"campaign": campaign, "capture": capture}, output
    )
    write_scan_report(scan, report or f"results/{dataset}/qc/{experiment}.json")
    logger.info(
        "wrote %s (campaign %s), clipped %d", scan.path, campaign, sum(scan.clipped.values())
    )


if "snakemake" in globals():
    p, o = snakemake.params, snakemake.output
    # the manifest input is raw/<dataset>/dataset.yaml: its folder's parent is the raw directory
    main(
        Path(snakemake.input.manifest).parents[1],
        snakemake.wildcards.dataset,
        snakemake.wildcards.experiment,
        p.campaign,
        p.capture,
        o.capture,
        o.report,
        snakemake.log[0],
    )
