"""Rule `validation_batch`: one batch's tables from its members' results
(selfsense.envelope.campaign.batch_tables): members × inputs, the plan, members × rows, members ×
targets, each with the declaration's and the unknowns' sha256 and the commit."""

from pathlib import Path

import pandas as pd

from selfsense.envelope.campaign import MEMBER, batch_tables, stamps
from selfsense.io.provenance import run, script_logging, write_table


def main(runs, drawn, row_keys, locate, cards, tables, declaration, unknowns, inputs, log, **out):
    """runs: the batch's members × inputs (as drawn when the workflow was parsed); drawn: its
    plan; cards: each member's results/<member>/scorecard.csv; tables: the members' tables the
    common targets read; out: unit, plan, rows, targets."""
    logger = script_logging(log)
    frame = pd.DataFrame(runs)
    read: dict[str, dict[str, pd.DataFrame]] = {m: {} for m in frame[MEMBER]}
    for path in map(Path, tables):
        read[path.parts[1]]["/".join(path.parts[2:])] = pd.read_csv(path)
    scorecards = {Path(c).parent.name: pd.read_csv(c) for c in cards}
    rows, targets = batch_tables(frame, scorecards, read, row_keys, [tuple(t) for t in locate])
    extra = stamps(declaration, unknowns)
    for table, path in (
        (frame, out["unit"]),
        (pd.DataFrame(drawn), out["plan"]),
        (rows, out["rows"]),
        (targets, out["targets"]),
    ):
        write_table(table, path, inputs=inputs, **extra)
    logger.info(
        "%d members: %d of %d row values and %d of %d target values given",
        len(frame),
        rows.drop(columns=MEMBER).notna().to_numpy().sum(),
        rows.drop(columns=MEMBER).size,
        targets.drop(columns=MEMBER).notna().to_numpy().sum(),
        targets.drop(columns=MEMBER).size,
    )


if "snakemake" in globals():
    run(main, snakemake)
