"""Rule `frequency_effect`: Figure 7.8 — the C_e–x relationship at each Chapter 5 drive frequency
against Γ, with each run's temperature, to see the frequency's effect apart from self-heating."""

from pathlib import Path

from selfsense.chapters import ch7
from selfsense.io.provenance import run, save_figure, script_logging, write_table
from selfsense.methods.gamma import load_gamma


def main(
    series,
    captures,
    frequencies,
    gamma,
    gamma_t,
    reference,
    table,
    figure,
    bins,
    min_windows,
    inputs,
    log,
    pdf,
):
    """series / captures: each run's ripple series / capture, named after it; frequencies: {run:
    drive frequency [Hz]}."""
    logger = script_logging(log)
    gamma_poly = load_gamma(gamma)
    series_of, capture_of = {Path(p).stem: p for p in series}, {Path(c).stem: c for c in captures}
    runs = {e: ch7.frequency_run(series_of[e], capture_of[e], f) for e, f in frequencies.items()}
    result, curves = ch7.frequency_effect(
        runs, gamma_poly, load_gamma(gamma_t).g, reference, bins, min_windows
    )
    config = {"bins": bins, "min_windows": min_windows, "reference": reference}
    write_table(result, table, inputs=inputs, config=config)
    save_figure(ch7.figure_7_8(curves, gamma_poly), figure, inputs=inputs, config=config, pdf=pdf)
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    run(main, snakemake)
