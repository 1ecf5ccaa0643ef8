"""Rule `validation_batch`: one batch's tables from its members' results
(selfsense.envelope.campaign.batch_tables): members × inputs, the plan, members × rows, members ×
targets, each with the declaration's and the unknowns' sha256 and the commit."""

from pathlib import Path

import pandas as pd

from selfsense.envelope.campaign import MEMBER, batch_tables, stamps
from selfsense.io.provenance import run, script_logging, write_table


def main(runs, drawn, row_keys, locate, read, failures, declaration, unknowns, inputs, log, **out):
    """runs: the batch's members × inputs (as drawn when the workflow was parsed); drawn: its
    plan; read: [member, name, file] of each member's scorecard.csv and of its tables the common
    targets read (named as under results/<member>/); failures: {member: where its one job notes
    a failed step}; out: unit, plan, rows, targets."""
    logger = script_logging(log)
    frame = pd.DataFrame(runs)
    failed = {m: Path(p).read_text().strip() for m, p in failures.items() if Path(p).is_file()}
    tables: dict[str, dict[str, pd.DataFrame]] = {m: {} for m in frame[MEMBER]}
    for member, name, path in (r for r in read if r[0] not in failed):
        tables[member][name] = pd.read_csv(path)
    cards = {m: t.pop("scorecard.csv") for m, t in tables.items() if m not in failed}
    located = [tuple(t) for t in locate]
    rows, targets = batch_tables(frame, cards, tables, row_keys, located, failed)
    extra = stamps(declaration, unknowns)
    for table, path in (
        (frame, out["unit"]),
        (pd.DataFrame(drawn), out["plan"]),
        (rows, out["rows"]),
        (targets, out["targets"]),
    ):
        write_table(table, path, inputs=inputs, **extra)
    for member, reason in failed.items():
        logger.warning("%s gave no value: %s", member, reason)
    logger.info(
        "%d members (%d failed): %d of %d row values and %d of %d target values given",
        len(frame),
        len(failed),
        rows[row_keys].notna().to_numpy().sum(),
        rows[row_keys].size,
        targets.drop(columns=MEMBER).notna().to_numpy().sum(),
        targets.drop(columns=MEMBER).size,
    )


if "snakemake" in globals():
    run(main, snakemake)
