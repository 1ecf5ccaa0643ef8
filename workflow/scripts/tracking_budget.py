"""Rule `tracking_budget`: Chapter 6's tracking errors ε_TOL and ε_TCL (Tables 6.1–6.2) split into
their sources with the twin's truth → one row per run (P1: per segment a–h); and the closed loops'
controller error ε_CCL split through the loop → a second table, the same rows.
"""

from pathlib import Path

import pandas as pd

from selfsense.io.provenance import run, script_logging, write_table
from selfsense.verify.tracking_budget import capture_tracking_budget


def main(captures, protocols, controls, omega_c, inputs, log=None, **tables):
    """protocols / controls: {experiment: its protocol / its control}; tables: {"tracking",
    "controller": path}."""
    logger = script_logging(log)
    runs = {c: (protocols[Path(c).stem], controls[Path(c).stem] == "closed_loop") for c in captures}
    rows = {name: [] for name in tables}
    for k, (capture, (protocol, closed)) in enumerate(runs.items(), 1):
        for name, budget in capture_tracking_budget(capture, protocol, closed, omega_c).items():
            rows[name] += [
                {"run": Path(capture).stem, "segment": s or None} | row for s, row in budget.items()
            ]
            logger.info(
                "%d/%d %s, %s: %s",
                k,
                len(runs),
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
