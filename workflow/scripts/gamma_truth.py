"""Rule `gamma_truth`: Γ (Table 5.2) or Γ_T (Tables 7.2–7.3, given the thermometers' power series)
refitted with the measured C_e, x (and T) replaced by the twin's truth, in every combination
(selfsense.verify.gamma_truth.truth_refits)."""

from selfsense.io.manifest import load_yaml
from selfsense.io.provenance import script_logging, write_table
from selfsense.scorecard.registry import parse_registry, printed_gamma
from selfsense.verify.gamma_truth import truth_refits


def main(
    registry,
    capture,
    series,
    fits,
    table,
    source,
    coefficients,
    g=None,
    temperatures=(0.0,),
    power=None,
    n_periods=4,
    log=None,
):
    logger = script_logging(log)
    entries = parse_registry(load_yaml(registry), registry)
    thesis, stroke = printed_gamma(entries, source, coefficients, g)
    result = truth_refits(capture, series, fits, thesis, stroke, n_periods, temperatures, power)
    inputs = [registry, capture, series, *fits.values(), *filter(None, [power])]
    config = {"source": source, "temperatures": list(temperatures), "n_periods": n_periods}
    write_table(result, table, inputs=inputs, config=config)
    logger.info("\n%s", result.T.to_string())


if "snakemake" in globals():
    i, p = snakemake.input, snakemake.params
    main(
        i.registry,
        i.capture,
        i.series,
        dict(zip(p.fits, i.fits)),
        snakemake.output.table,
        p.source,
        p.coefficients,
        p.g,
        p.temperatures,
        i.power[0] if i.power else None,
        p.n_periods,
        snakemake.log[0],
    )
