"""Rule `tracking_budget`: Chapter 6's tracking errors ε_TOL and ε_TCL (Tables 6.1–6.2) split into
their sources with the twin's truth → one row per run (P1: per segment a–h); and the closed loops'
controller error ε_CCL split through the loop → a second table, the same rows.
"""

from pathlib import Path

import pandas as pd

from selfsense.io.provenance import run, script_logging, write_table
from selfsense.verify.tracking_budget import capture_tracking_budget


def main(captures, protocols, controls, profiles, omega_c, inputs, log=None, **tables):
    """protocols, controls, profiles: {run: its protocol, control, profile}; tables: {"tracking",
    "controller": path}."""
    logger = script_logging(log)
    rows = {name: [] for name in tables}
    for k, capture in enumerate(captures, 1):
        run = Path(capture).stem
        closed, p1 = controls[run] == "closed_loop", profiles[run] == "P1"
        budgets = capture_tracking_budget(capture, protocols[run], closed, omega_c, p1)
        for name, budget in budgets.items():
            rows[name] += [{"run": run, "segment": s or None} | row for s, row in budget.items()]
            logger.info(
                "%d/%d %s, %s: %s",
                k,
                len(captures),
                capture,
                name,
                ", ".join(
                    f"{s or 'max'} {r['total max error [µm]']:.2f} µm" for s, r in budget.items()
                ),
            )
    for name, path in tables.items():
        write_table(pd.DataFrame(rows[name]), path, inputs=inputs, config={"omega_c": omega_c})


if "snakemake" in globals():
    run(main, snakemake)
