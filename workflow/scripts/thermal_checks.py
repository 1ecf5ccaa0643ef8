"""Rule `thermal_checks`: the identified thermal model against the voltage steps and the check
runs; Figures 7.3, 7.5–7.6 (selfsense.chapters.ch7.thermal_checks)."""

import json
from pathlib import Path

from selfsense.chapters import ch7
from selfsense.io.capture import read_series
from selfsense.io.provenance import run, save_figure, script_logging, write_table


def main(volt_series, checks, thermal_model, volt_segments, inputs, log, pdf, **out):
    """checks: Figs 7.5–7.6's runs; volt_segments: the voltage run's protocol segments."""
    logger = script_logging(log)
    tables, built = ch7.thermal_checks(
        read_series(volt_series),
        volt_segments,
        {Path(p).stem: read_series(p) for p in checks},
        json.loads(Path(thermal_model).read_text()),
    )
    for key, table in tables.items():
        write_table(table, out[key], inputs=inputs)
    for name, fig in built.items():
        save_figure(fig, out[name], inputs=inputs, pdf=pdf)
    logger.info("\n%s", tables["prediction"].to_string())


if "snakemake" in globals():
    run(main, snakemake)
