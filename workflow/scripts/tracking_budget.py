"""Rule `tracking_budget`: Chapter 6's tracking errors ε_TOL and ε_TCL (Tables 6.1–6.2) split into
their sources with the twin's truth → one row per run (P1: per segment a–h).

Alone: python workflow/scripts/tracking_budget.py out.csv raw/pi_p885/ch6_p1_open.nc raw/pi_p885/ch6_p2b_closed.nc \
    --config tests/config/smoke.yaml
"""

import argparse
from pathlib import Path

import pandas as pd

from selfsense.manifest import expand_protocols, load_config
from selfsense.provenance import script_logging, write_table
from selfsense.tracking_budget import capture_tracking_budget


def main(runs, table, omega_c, log=None):
    """runs: {capture path: (its protocol, whether its loop is closed)}."""
    logger = script_logging(log)
    rows = []
    for k, (capture, (protocol, closed)) in enumerate(runs.items(), 1):
        budget = capture_tracking_budget(capture, protocol, closed, omega_c)
        rows += [{"run": Path(capture).stem, "segment": s or None} | row for s, row in budget.items()]
        logger.info("%d/%d %s: %s", k, len(runs), capture,
                    ", ".join(f"{s or 'max'} {r['total max error [µm]']:.2f} µm" for s, r in budget.items()))
    write_table(pd.DataFrame(rows), table, inputs=list(runs), config={"omega_c": omega_c})


if "snakemake" in globals():
    p = snakemake.params
    main({c: (p.protocols[Path(c).stem], p.controls[Path(c).stem] == "closed_loop") for c in snakemake.input.capture},
         snakemake.output.table, p.omega_c, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("table")
    cli.add_argument("captures", nargs="+")
    cli.add_argument("--config", default="config.yaml")
    a = cli.parse_args()
    config = load_config(a.config)
    catalogue = expand_protocols(["ch6"], config["campaign"])
    main({c: (dict(catalogue[Path(c).stem].protocol), catalogue[Path(c).stem].control == "closed_loop")
          for c in a.captures}, a.table, config["control"]["omega_c"])
