"""Rule `charge_sensing`: a0 over 10–300 Hz (Eq 5.3, Fig 5.2) and Table 5.3 (Eq 5.9)."""

from pathlib import Path

from selfsense.chapters.ch5 import charge_sensing, table_5_3
from selfsense.io.capture import read_series
from selfsense.io.provenance import provenance, run, script_logging, write_json, write_table
from selfsense.methods.observer import HPOGains


def main(series, frequencies, omega_s, zeta_s, inputs, log=None, **out):
    """series: ripple-series paths; frequencies: {experiment: drive frequency [Hz]}."""
    logger = script_logging(log)
    table = charge_sensing({float(frequencies[Path(p).stem]): read_series(p) for p in series})
    a0 = float(table["a0 [C/m]"].mean())
    cfg = {"omega_s": omega_s, "zeta_s": zeta_s}
    write_table(table, out["charge_sensing"], inputs=inputs)
    write_table(table_5_3(a0, omega_s, zeta_s), out["table_5_3"], inputs=inputs, config=cfg)
    write_json(
        HPOGains(a0, omega_s, zeta_s).record() | {"provenance": provenance(inputs, cfg)},
        out["observer"],
    )
    logger.info("a0 = %.3f C/m\n%s", a0, table.to_string())


if "snakemake" in globals():
    run(main, snakemake)
