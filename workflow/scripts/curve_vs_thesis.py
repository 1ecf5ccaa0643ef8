"""Rule `curve_vs_thesis`: our fitted Γ (or Γ_T) against the one the thesis prints, max |Γ − Γ_thesis|
over the printed curve's C range — what the ill-conditioned coefficients cannot compare.

Alone: python workflow/scripts/curve_vs_thesis.py workflow/scorecard.yaml out.csv "Table 5.2" \
    --fit "thesis order=results/pi_p885/ch5/gamma_j5.json" --fit "our order=results/pi_p885/ch5/gamma.json"
"""

import argparse

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
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("registry")
    cli.add_argument("table")
    cli.add_argument("source")
    cli.add_argument("--fit", action="append", required=True, help="name=path of a Γ record")
    cli.add_argument(
        "--prefix", default="b", help="coefficient names in the registry: b0…b5 or bT0…bT5"
    )
    cli.add_argument("--g", default=None, help="the registry's quantity for g (Γ_T)")
    cli.add_argument("--temperature", type=float, action="append", default=None)
    a = cli.parse_args()
    main(
        a.registry,
        dict(f.split("=", 1) for f in a.fit),
        a.table,
        a.source,
        [f"{a.prefix}{i}" for i in range(6)],
        a.g,
        temperatures=a.temperature or (0.0,),
    )
