"""Rule `validation_wave`: a later wave's design from the earlier waves' members × inputs and
members × targets alone (selfsense.envelope.judgement.next_wave: the common targets only), or
no run with the reason the declared waves stop."""

import pandas as pd

from selfsense.envelope.campaign import MEMBER, design_table, stamps
from selfsense.envelope.judgement import ensemble, next_wave
from selfsense.envelope.validation import load_validation
from selfsense.io.provenance import run, script_logging, write_table


def main(ids, first, units, targets, declaration, unknowns, inputs, log, design):
    """ids: the unknowns varied, in the tables' order; first: how many runs the earlier waves
    hold (the next wave's noise seeds follow theirs)."""
    logger = script_logging(log)
    decl = load_validation(declaration)
    unit = pd.concat([pd.read_csv(p) for p in units], ignore_index=True)
    target = pd.concat([pd.read_csv(p) for p in targets], ignore_index=True)
    ens = ensemble(decl, ids, unit, pd.DataFrame({MEMBER: unit[MEMBER]}), target)
    runs, fractions, stopped = next_wave(ens, decl, len(ids), first)
    table = (
        design_table(runs, ids)
        if runs is not None
        else pd.DataFrame(columns=["point", "replicate", "seed", *ids])
    )
    extra = stamps(declaration, unknowns)
    write_table(table, design, inputs=inputs, nroy_fractions=fractions, stopped=stopped, **extra)
    logger.info("NROY fractions by wave %s; %s", fractions, stopped or f"{len(table)} runs next")


if "snakemake" in globals():
    run(main, snakemake)
