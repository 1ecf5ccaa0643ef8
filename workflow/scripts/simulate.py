"""Rules `simulate` and `simulate_<protocol>`: experiments on the digital twin → raw/<dataset>/
<experiment>.nc and their QC reports results/<dataset>/qc/<experiment>.json (each capture is
validated as it is written); one experiment, or every run of a protocol simulated together.

A Ronkanen run compensated with ``{R: identified, c: identified}`` (Eq 15) also has the
identification's tables as inputs, results/<dataset>/powerloss/identified.csv (R, from the static
hold) and table_2.csv (c of model (10), from the ramps): the twin's operator runs Eq 15 with them.
"""

from pathlib import Path

from selfsense.io.capture import write_scan_report
from selfsense.io.provenance import run, script_logging
from selfsense.twin.experiment import simulate_experiment


def main(manifest, capture, report, campaign, capture_settings, log, identified=None, table_2=None):
    """capture, report: a path each, or a list each (a protocol's runs simulated together)."""
    logger = script_logging(log)
    # the manifest is raw/<dataset>/dataset.yaml; each capture raw/<dataset>/<experiment>.nc and
    # its report results/<dataset>/qc/<experiment>.json
    raw_dir, dataset = Path(manifest).parents[1], Path(manifest).parent.name
    config = {"campaign": campaign, "capture": capture_settings}
    tables = (identified, table_2) if identified else None
    captures, reports = ([x] if isinstance(x, str) else list(x) for x in (capture, report))
    report_of = {Path(r).stem: r for r in reports}
    for output in captures:
        experiment = Path(output).stem
        scan = simulate_experiment(
            raw_dir, dataset, experiment, config, output, identified_tables=tables
        )
        write_scan_report(scan, report_of[experiment])
        logger.info(
            "wrote %s (campaign %s), clipped %d", scan.path, campaign, sum(scan.clipped.values())
        )


if "snakemake" in globals():
    run(main, snakemake)
