"""Rule `gamma_truth`: Γ (Table 5.2) or Γ_T (Tables 7.2–7.3, given the thermometers' power series)
refitted with the measured C_e, x (and T) replaced by the twin's truth, in every combination
(selfsense.verify.gamma_truth.truth_refits)."""

from pathlib import Path

from selfsense.io.manifest import load_yaml
from selfsense.io.provenance import run, script_logging, write_table
from selfsense.scorecard.registry import parse_registry, printed_gamma
from selfsense.verify.gamma_truth import truth_refits


def main(
    registry,
    capture,
    series,
    fits,
    fit_names,
    power,
    table,
    source,
    coefficients,
    g,
    temperatures,
    n_periods,
    span,
    inputs,
    log=None,
):
    """fit_names: {Γ record file name: its name}; power: [] or [the loss power series] (Γ_T's);
    span: the run's drive [s], where Γ_T's samples are fitted."""
    logger = script_logging(log)
    entries = parse_registry(load_yaml(registry), registry)
    thesis, stroke = printed_gamma(entries, source, coefficients, g)
    named = {fit_names[Path(p).name]: p for p in fits}
    power = power[0] if power else None
    result = truth_refits(
        capture, series, named, thesis, stroke, n_periods, temperatures, power, tuple(span)
    )
    config = {"source": source, "temperatures": list(temperatures), "n_periods": n_periods}
    config |= {"span": list(span)}
    write_table(result, table, inputs=inputs, config=config)
    logger.info("\n%s", result.T.to_string())


if "snakemake" in globals():
    run(main, snakemake)
