"""Rule `gamma_truth`: Γ (Table 5.2) or Γ_T (Tables 7.2–7.3, given the thermometers' --power
series) refitted with the measured C_e, x (and T) replaced by the twin's truth, one at a time and
all at once (selfsense.verify.gamma_truth).
"""

from selfsense.io.capture import read_series
from selfsense.io.manifest import load_yaml
from selfsense.io.provenance import script_logging, write_table
from selfsense.methods.gamma import load_gamma
from selfsense.scorecard.registry import parse_registry, printed_gamma
from selfsense.verify.gamma_truth import capture_variants, curve_rows


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
    thesis, stroke = printed_gamma(
        parse_registry(load_yaml(registry), registry), source, coefficients, g
    )
    data = capture_variants(
        capture,
        read_series(series),
        n_periods,
        read_series(power, ["time", "T_mid"]) if power else None,
    )
    orders = {name: load_gamma(path).order for name, path in fits.items()}
    result = curve_rows(
        data, orders, thesis, stroke, temperatures, orders["thesis order"] if power else None
    )
    write_table(
        result,
        table,
        inputs=[registry, capture, series, *fits.values(), *filter(None, [power])],
        config={"source": source, "temperatures": list(temperatures), "n_periods": n_periods},
    )
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
