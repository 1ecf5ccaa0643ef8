"""Rule `charge_sensing`: a0 over 10–300 Hz (Eq 5.3, Fig 5.2) and Table 5.3 (Eq 5.9)."""

from selfsense.chapters.ch5 import charge_sensing, table_5_3
from selfsense.io.capture import read_series
from selfsense.io.provenance import provenance, script_logging, write_json, write_table
from selfsense.methods.observer import HPOGains


def main(series, out, omega_s, zeta_s, log=None):
    """series: {frequency [Hz]: ripple-series path}."""
    logger = script_logging(log)
    table = charge_sensing({float(f): read_series(p) for f, p in series.items()})
    a0 = float(table["a0 [C/m]"].mean())
    cfg = {"omega_s": omega_s, "zeta_s": zeta_s}
    inputs = list(series.values())
    write_table(table, out["charge_sensing"], inputs=inputs)
    write_table(table_5_3(a0, omega_s, zeta_s), out["table_5_3"], inputs=inputs, config=cfg)
    write_json(
        HPOGains(a0, omega_s, zeta_s).record() | {"provenance": provenance(inputs, cfg)},
        out["observer"],
    )
    logger.info("a0 = %.3f C/m\n%s", a0, table.to_string())


if "snakemake" in globals():
    main(
        dict(zip(snakemake.params.frequencies, snakemake.input.series)),
        dict(snakemake.output.items()),
        snakemake.params.omega_s,
        snakemake.params.zeta_s,
        snakemake.log[0],
    )
