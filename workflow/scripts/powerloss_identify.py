"""Rule `powerloss_identify`: R from the static hold, X and a from every ramp
→ ramps, Table 1, identified.
"""

from pathlib import Path

from selfsense.chapters import ronkanen
from selfsense.io.provenance import run, script_logging, write_table


def main(hold, ramps, ramp_table, table_1, identified, hold_start, velocity_window, inputs, log):
    logger = script_logging(log)
    records = ronkanen.read_records([hold, *ramps])
    ramps_found, table_1_found, identified_found = ronkanen.identify(
        records.pop(Path(hold).stem), list(records.values()), hold_start, velocity_window
    )
    config = {"hold_start": hold_start, "velocity_window": velocity_window}
    written = {ramp_table: ramps_found, table_1: table_1_found, identified: identified_found}
    for path, table in written.items():
        write_table(table, path, inputs=inputs, config=config)
    logger.info("\n%s", "\n".join(t.to_string() for t in written.values()))


if "snakemake" in globals():
    run(main, snakemake)
