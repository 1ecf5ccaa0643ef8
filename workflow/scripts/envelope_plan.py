"""Rule `envelope_plan`: the envelope's sampling plan (selfsense.envelope.design.envelope):
results/envelope/<name>/plan.csv (each member's values) and unit.csv (the same draws in the
unit hypercube, as SALib drew them)."""

from pathlib import Path

from selfsense.envelope.design import Design, envelope
from selfsense.envelope.unknowns import load_unknowns, unknowns_hash
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import run, script_logging, write_table


def main(design, base, unknowns, plan, unit, inputs, log=None):
    """base: raw/<dataset>/dataset.yaml, the envelope dataset's manifest (its raw folder's)."""
    logger = script_logging(log)
    design, manifest = Design(**design), load_manifest(base)
    declared = load_unknowns(unknowns, raw_dir=Path(base).parents[1])
    drawn = envelope(design, {manifest["name"]: manifest}, declared)
    extra = {
        "unknowns_sha256": unknowns_hash(unknowns),
        "varied": [u.id for u in drawn.varied],
        "held": [u.id for u in drawn.held],
    }
    for frame, path in ((drawn.plan, plan), (drawn.unit, unit)):
        write_table(frame.reset_index(), path, inputs=inputs, config=design.record(), **extra)
    logger.info("%d members, %d unknowns varied", len(drawn.plan), len(drawn.varied))


if "snakemake" in globals():
    run(main, snakemake)
