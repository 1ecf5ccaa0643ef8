"""Rule `curve_vs_thesis`: our fitted Γ (or Γ_T) against the one the thesis prints,
max |Γ − Γ_thesis| over the printed curve's C range — what the ill-conditioned coefficients
cannot compare.
"""

from pathlib import Path

from selfsense.io.manifest import load_yaml
from selfsense.io.provenance import run, script_logging, write_table
from selfsense.methods.gamma import curve_table, load_gamma
from selfsense.scorecard.registry import parse_registry, printed_gamma


def main(registry, fits, fit_names, table, source, coefficients, g, temperatures, inputs, log):
    """fit_names: {Γ record file name: its name}; coefficients: the registry's quantities b0…b5
    of ``source``."""
    logger = script_logging(log)
    thesis, stroke = printed_gamma(
        parse_registry(load_yaml(registry), registry), source, coefficients, g
    )
    result = curve_table(
        {fit_names[Path(p).name]: load_gamma(p) for p in fits}, thesis, stroke, temperatures
    )
    write_table(
        result,
        table,
        inputs=inputs,
        config={"source": source, "temperatures": list(temperatures)},
    )
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    run(main, snakemake)
