"""Rule `simulate_closed_loop`: a closed-loop experiment on the twin, its loop configured with the
identified Γ, a0 and k/α (selfsense.twin.closed_loop.simulate_closed_loop), and its QC report."""

from pathlib import Path

from selfsense.io.capture import write_scan_report
from selfsense.io.provenance import run, script_logging
from selfsense.twin.closed_loop import simulate_closed_loop


def main(
    manifest,
    gamma,
    observer,
    model,
    capture,
    report,
    campaign,
    capture_settings,
    omega_c,
    n_periods,
    log=None,
):
    script_logging(log)  # the twin logs the capture it wrote and the loop it ran with
    cfg = {
        "campaign": campaign,
        "capture": capture_settings,
        "omega_c": omega_c,
        "n_periods": n_periods,
    }
    # the manifest is raw/<dataset>/dataset.yaml and the capture raw/<dataset>/<experiment>.nc
    raw_dir, dataset, experiment = (
        Path(manifest).parents[1],
        Path(manifest).parent.name,
        Path(capture).stem,
    )
    scan = simulate_closed_loop(raw_dir, dataset, experiment, cfg, gamma, observer, model, capture)
    write_scan_report(scan, report)


if "snakemake" in globals():
    run(main, snakemake)
