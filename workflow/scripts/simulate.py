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
    identified=None,
    table_2=None,
):
    logger = script_logging(log)
    eq15 = None
    if identified is not None:
        # here: only the Eq 15 runs read the identification (the bender twin's module)
        from selfsense.twin.bender import identified_compensation

        eq15 = identified_compensation(identified, table_2)
        logger.info(
            "Eq 15 compensation as identified: R = %.6g Ohm (%s), c = %.6g 1/A (%s)",
            eq15["R"],
            identified,
            eq15["c"],
            table_2,
        )
    scan = simulate_experiment(
        raw_dir,
        dataset,
        experiment,
        {"campaign": campaign, "capture": capture},
        output,
        identified=eq15,
    )
    write_scan_report(scan, report or f"results/{dataset}/qc/{experiment}.json")
    logger.info(
        "wrote %s (campaign %s), clipped %d", scan.path, campaign, sum(scan.clipped.values())
    )


if "snakemake" in globals():
    i, p, o = snakemake.input, snakemake.params, snakemake.output
    # the manifest input is raw/<dataset>/dataset.yaml: its folder's parent is the raw directory
    main(
        Path(i.manifest).parents[1],
        snakemake.wildcards.dataset,
        snakemake.wildcards.experiment,
        p.campaign,
        p.capture,
        o.capture,
        o.report,
        snakemake.log[0],
        getattr(i, "identified", None),
        getattr(i, "table_2", None),
    )
