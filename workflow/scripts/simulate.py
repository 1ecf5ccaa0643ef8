"""Rule `simulate`: one experiment on the digital twin → raw/<dataset>/<experiment>.nc and its QC
report results/<dataset>/qc/<experiment>.json (the capture is validated as it is written).

A Ronkanen run compensated with ``{R: identified, c: identified}`` (Eq 15) also has the
identification's tables as inputs, results/<dataset>/powerloss/identified.csv (R, from the static
hold) and table_2.csv (c of model (10), from the ramps): the twin's operator runs Eq 15 with them.
"""

from pathlib import Path

from selfsense.io.capture import write_scan_report
from selfsense.io.provenance import script_logging
from selfsense.twin.experiment import simulate_experiment


def main(
    raw_dir,
    dataset,
    experiment,
    campaign,
    capture,
    output=None,
    report=None,
    log=None,
    identified_tables=None,
):
    logger = script_logging(log)
    config = {"campaign": campaign, "capture": capture}
    scan = simulate_experiment(
        raw_dir, dataset, experiment, config, output, identified_tables=identified_tables
    )
    write_scan_report(scan, report or f"results/{dataset}/qc/{experiment}.json")
    logger.info(
        "wrote %s (campaign %s), clipped %d", scan.path, campaign, sum(scan.clipped.values())
    )


if "snakemake" in globals():
    i, p, o = snakemake.input, snakemake.params, snakemake.output
    tables = (i.identified, i.table_2) if hasattr(i, "identified") else None
    # the manifest input is raw/<dataset>/dataset.yaml: its folder's parent is the raw directory
    raw, w = Path(i.manifest).parents[1], snakemake.wildcards
    args = (p.campaign, p.capture, o.capture, o.report, snakemake.log[0], tables)
    main(raw, w.dataset, w.experiment, *args)
