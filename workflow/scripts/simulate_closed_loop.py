"""Rule `simulate_closed_loop`: a closed-loop experiment on the twin, its real-time loop configured
with the identified Γ (Ch 5), a0 (Ch 5) and k/α (Ch 4), as the bench's loop was; writes the capture
and its QC report (validated as it is written).
"""

from pathlib import Path

from selfsense.io.capture import write_scan_report
from selfsense.io.provenance import script_logging
from selfsense.methods.control import IntegralController
from selfsense.methods.electromech import load_k_over_alpha
from selfsense.methods.gamma import load_gamma
from selfsense.methods.observer import load_gains
from selfsense.twin.closed_loop import controller_factory
from selfsense.twin.experiment import simulate_experiment


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
    logger = script_logging(log)
    g, gains, loop = (
        load_gamma(gamma),
        load_gains(observer),
        IntegralController(omega_c, load_k_over_alpha(model)),
    )
    scan = simulate_experiment(
        raw_dir,
        dataset,
        experiment,
        {"campaign": campaign, "capture": capture},
        output,
        controller_for=controller_factory(n_periods, g, gains, loop),
    )
    write_scan_report(scan, report or f"results/{dataset}/qc/{experiment}.json")
    logger.info(
        "wrote %s with K_I from k/α = %.4g V/m, a0 = %.4g C/m",
        scan.path,
        loop.k_over_alpha,
        gains.a0,
    )


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
