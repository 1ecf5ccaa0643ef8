"""Rules `simulate` and `simulate_<protocol>`: experiments on the digital twin → raw/<dataset>/
<experiment>.nc and their QC reports results/<dataset>/qc/<experiment>.json (each capture is
validated as it is written); one experiment, or every run of a protocol simulated together.

A Ronkanen run compensated with ``{R: identified, c: identified}`` (Eq 15) also has the
identification's tables as inputs, results/<dataset>/powerloss/identified.csv (R, from the static
hold) and table_2.csv (c of model (10), from the ramps): the twin's operator runs Eq 15 with them.
"""

from pathlib import Path

from selfsense.io.capture import write_scan_report
from selfsense.io.provenance import script_logging
from selfsense.twin.experiment import simulate_experiment


def main(raw_dir, dataset, experiments, campaign, capture, outputs, reports, log=None, tables=None):
    logger = script_logging(log)
    config = {"campaign": campaign, "capture": capture}
    for experiment, output, report in zip(experiments, outputs, reports, strict=True):
        scan = simulate_experiment(
            raw_dir, dataset, experiment, config, output, identified_tables=tables
        )
        write_scan_report(scan, report)
        logger.info(
            "wrote %s (campaign %s), clipped %d", scan.path, campaign, sum(scan.clipped.values())
        )


if "snakemake" in globals():
    i, p, o = snakemake.input, snakemake.params, snakemake.output
    tables = (i.identified, i.table_2) if hasattr(i, "identified") else None
    # the manifest input is raw/<dataset>/dataset.yaml: its folder's parent is the raw directory
    raw = Path(i.manifest).parents[1]
    captures, reports = ([x] if isinstance(x, str) else list(x) for x in (o.capture, o.report))
    # each capture is raw/<dataset>/<experiment>.nc
    experiments = [Path(c).stem for c in captures]
    args = (p.campaign, p.capture, captures, reports, snakemake.log[0], tables)
    main(raw, snakemake.wildcards.dataset, experiments, *args)
