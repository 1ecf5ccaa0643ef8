"""Rule `frequency_effect`: Figure 7.8 — the C_e–x relationship at each Chapter 5 drive frequency
against Γ, with each run's temperature, to see the frequency's effect apart from self-heating."""

from selfsense.chapters import ch7
from selfsense.io.provenance import save_figure, script_logging, write_table
from selfsense.methods.gamma import load_gamma


def main(
    series, captures, frequencies, gamma, gamma_t, reference, out, bins, min_windows, log, pdf
):
    """series / captures / frequencies: {run: ripple series / capture / drive frequency [Hz]};
    out: {"table" or "figure": path}."""
    logger = script_logging(log)
    gamma_poly = load_gamma(gamma)
    runs = {run: ch7.frequency_run(series[run], captures[run], frequencies[run]) for run in series}
    result, curves = ch7.frequency_effect(
        runs, gamma_poly, load_gamma(gamma_t).g, reference, bins, min_windows
    )
    inputs = [*series.values(), *captures.values(), gamma, gamma_t]
    config = {"bins": bins, "min_windows": min_windows, "reference": reference}
    write_table(result, out["table"], inputs=inputs, config=config)
    figure = ch7.figure_7_8(curves, gamma_poly)
    save_figure(figure, out["figure"], inputs=inputs, config=config, pdf=pdf)
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    i, p = snakemake.input, snakemake.params
    main(
        dict(zip(p.runs, i.series)),
        dict(zip(p.runs, i.captures)),
        dict(zip(p.runs, p.frequencies)),
        i.gamma,
        i.gamma_t,
        p.reference,
        dict(snakemake.output.items()),
        p.bins,
        p.min_windows,
        snakemake.log[0],
        pdf=p.pdf,
    )
