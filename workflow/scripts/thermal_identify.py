"""Rule `thermal_identify`: τ, γ, k_T from the heating runs (Table 7.1); Figures 7.1–7.2
(selfsense.chapters.ch7.thermal_identification)."""

from pathlib import Path

from selfsense.chapters import ch7
from selfsense.io.capture import read_series, series_scalars
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import (
    provenance,
    run,
    save_figure,
    script_logging,
    write_json,
    write_table,
)
from selfsense.methods.electromech import load_k_over_alpha
from selfsense.methods.thermal import ThermalProperties


def main(freq_series, freqs, manifest, model, inputs, log, pdf, **out):
    """freqs: {experiment: frequency [Hz]} of freq_series."""
    logger = script_logging(log)
    th = load_manifest(manifest)["actuator"]["thermal"]
    tables, record, built = ch7.thermal_identification(
        {Path(p).stem: read_series(p) | series_scalars(p) for p in freq_series},
        {Path(p).stem: float(freqs[Path(p).stem]) for p in freq_series},
        ThermalProperties(th["rho"], th["c"], th["volume_m3"], th["area_m2"]),
        load_k_over_alpha(model),
    )
    for key, table in tables.items():
        write_table(table, out[key], inputs=inputs)
    write_json(record | {"provenance": provenance(inputs)}, out["thermal_model"])
    for name, fig in built.items():
        save_figure(fig, out[name], inputs=inputs, pdf=pdf)
    if not record["identified"]:  # e.g. the smoke campaign's short runs: later stages skip
        logger.warning(record["reason"])
    logger.info("\n%s", tables["per_run"].to_string())


if "snakemake" in globals():
    run(main, snakemake)
