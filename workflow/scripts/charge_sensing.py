"""Rule `charge_sensing`: a0 over 10–300 Hz (Eq 5.3, Fig 5.2) and Table 5.3 (Eq 5.9).

Alone: python workflow/scripts/charge_sensing.py out_dir --series 10=results/pi_p885/ripple/ch5_sine_10hz.nc ...
"""

import argparse
from pathlib import Path

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
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("out_dir")
    cli.add_argument("--series", nargs="+", required=True, help="frequency=path")
    cli.add_argument("--omega-s", type=float, default=6.283185307179586)
    cli.add_argument("--zeta-s", type=float, default=1.0)
    a = cli.parse_args()
    out = {
        k: str(Path(a.out_dir) / f"{k}.{'json' if k == 'observer' else 'csv'}")
        for k in ("charge_sensing", "table_5_3", "observer")
    }
    main(dict(s.split("=", 1) for s in a.series), out, a.omega_s, a.zeta_s)
