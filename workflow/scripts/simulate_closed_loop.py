"""Rule `simulate_closed_loop`: a closed-loop experiment on the twin, its loop configured with the
identified Γ, a0 and k/α (selfsense.twin.closed_loop.simulate_closed_loop), and its QC report."""

from pathlib import Path

from selfsense.io.capture import write_scan_report
from selfsense.io.provenance import script_logging
from selfsense.twin.closed_loop import simulate_closed_loop


def main(
    raw_dir,
    dataset,
    experiment,
    gamma,
    observer,
    model,
    campaign,
    capture,
    omega_c,
    n_periods,
    output=None,
    report=None,
    log=None,
):
    script_logging(log)  # the twin logs the capture it wrote and the loop it ran with
    cfg = {"campaign": campaign, "capture": capture, "omega_c": omega_c, "n_periods": n_periods}
    scan = simulate_closed_loop(raw_dir, dataset, experiment, cfg, gamma, observer, model, output)
    write_scan_report(scan, report or f"results/{dataset}/qc/{experiment}.json")


if "snakemake" in globals():
    i, p = snakemake.input, snakemake.params
    # the manifest input is raw/<dataset>/dataset.yaml: its folder's parent is the raw directory
    main(
        Path(i.manifest).parents[1],
        snakemake.wildcards.dataset,
        snakemake.wildcards.experiment,
        i.gamma,
        i.observer,
        i.model,
        p.campaign,
        p.capture,
        p.omega_c,
        p.n_periods,
        snakemake.output.capture,
        snakemake.output.report,
        snakemake.log[0],
    )
