"""Rule `tracking_budget`: Chapter 6's tracking errors ε_TOL and ε_TCL (Tables 6.1–6.2) split into
their sources with the twin's truth → one row per run (P1: per segment a–h); and the closed loops'
controller error ε_CCL split through the loop → a second table, the same rows.
"""

from pathlib import Path

import pandas as pd

from selfsense.io.provenance import script_logging, write_table
from selfsense.verify.tracking_budget import capture_tracking_budget


def main(runs, tables, omega_c, log=None):
    """runs: {capture path: (its protocol, whether its loop is closed, whether it is P1, counted
    per segment)}; tables: {"tracking", "controller": path}."""
    logger = script_logging(log)
    rows = {name: [] for name in tables}
    for k, (capture, (protocol, closed, p1)) in enumerate(runs.items(), 1):
        for name, budget in capture_tracking_budget(capture, protocol, closed, omega_c, p1).items():
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
        write_table(pd.DataFrame(rows[name]), path, inputs=list(runs), config={"omega_c": omega_c})


if "snakemake" in globals():
    p = snakemake.params
    main(
        {
            c: (
                p.protocols[Path(c).stem],
                p.controls[Path(c).stem] == "closed_loop",
                p.profiles[Path(c).stem] == "P1",
            )
            for c in snakemake.input.capture
        },
        dict(snakemake.output.items()),
        p.omega_c,
        snakemake.log[0],
    )
