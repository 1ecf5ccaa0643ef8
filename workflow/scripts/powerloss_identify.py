"""Rule `powerloss_identify`: R from the static hold, X and a from every ramp
→ ramps, Table 1, identified.
"""

from pathlib import Path

from selfsense.chapters import ronkanen
from selfsense.io.provenance import script_logging, write_table


def main(
    hold, ramps, out_ramps, out_table_1, out_identified, hold_start, velocity_window=2.0, log=None
):
    logger = script_logging(log)
    records = ronkanen.read_records([hold, *ramps])
    ramp_table, table_1, identified = ronkanen.identify(
        records.pop(Path(hold).stem), list(records.values()), hold_start, velocity_window
    )
    config = {"hold_start": hold_start, "velocity_window": velocity_window}
    for table, path in (
        (ramp_table, out_ramps),
        (table_1, out_table_1),
        (identified, out_identified),
    ):
        write_table(table, path, inputs=[hold, *ramps], config=config)
    logger.info("\n%s\n%s\n%s", ramp_table.to_string(), table_1.to_string(), identified.to_string())


if "snakemake" in globals():
    i, o, p = snakemake.input, snakemake.output, snakemake.params
    main(
        i.hold,
        list(i.ramps),
        o.ramps,
        o.table_1,
        o.identified,
        p.hold_start,
        p.velocity_window,
        snakemake.log[0],
    )
