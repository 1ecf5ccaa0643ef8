"""Rule `ch6_results`: Tables 6.1–6.2, P3 and the loop's tracking prediction.

All errors are evaluated on means over one folded ripple period (the real-time loop's 4 kHz
rate).
"""

from pathlib import Path

from selfsense.chapters import ch6
from selfsense.io.provenance import run, script_logging, write_table
from selfsense.methods.electromech import load_k_over_alpha


def main(captures, model, protocols, profiles, omega_c, inputs, log=None, **out):
    """profiles: {profile: (open-loop run, closed-loop run)}; out: {table name: path}."""
    logger = script_logging(log)
    k_over_alpha = load_k_over_alpha(model)
    runs = {Path(p).stem: ch6.load_run(p, protocols[Path(p).stem]) for p in captures}
    tables = ch6.results(runs, protocols, profiles, k_over_alpha, omega_c)
    for key, table in tables.items():
        write_table(
            table,
            out[key],
            inputs=inputs,
            config=None if key == "p3" else {"omega_c": omega_c},
        )
    logger.info("%d runs", len(runs))


if "snakemake" in globals():
    run(main, snakemake)
