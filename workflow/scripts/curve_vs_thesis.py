"""Rule `curve_vs_thesis`: our fitted Γ (or Γ_T) against the one the thesis prints,
max |Γ − Γ_thesis| over the printed curve's C range — what the ill-conditioned coefficients
cannot compare.
"""

from selfsense.io.manifest import load_yaml
from selfsense.io.provenance import script_logging, write_table
from selfsense.methods.gamma import curve_table, load_gamma
from selfsense.scorecard.registry import parse_registry, printed_gamma


def main(registry, fits, table, source, coefficients, g=None, temperatures=(0.0,), log=None):
    """fits: {name: Γ record path}; coefficients: the registry's quantities b0…b5 of ``source``."""
    logger = script_logging(log)
    thesis, stroke = printed_gamma(
        parse_registry(load_yaml(registry), registry), source, coefficients, g
    )
    result = curve_table(
        {name: load_gamma(path) for name, path in fits.items()}, thesis, stroke, temperatures
    )
    write_table(
        result,
        table,
        inputs=[registry, *fits.values()],
        config={"source": source, "temperatures": list(temperatures)},
    )
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    p = snakemake.params
    main(
        snakemake.input.registry,
        dict(zip(p.fits, snakemake.input.fits)),
        snakemake.output.table,
        p.source,
        p.coefficients,
        p.g,
        temperatures=p.temperatures,
        log=snakemake.log[0],
    )
