"""Rule `envelope_plan`: the envelope's sampling plan (selfsense.verify.envelope.envelope):
results/envelope/<name>/plan.csv (each member's values) and unit.csv (the same draws in the
unit hypercube, as SALib drew them)."""

from pathlib import Path

from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import run, script_logging, write_table
from selfsense.io.unknowns import load_unknowns, unknowns_hash
from selfsense.verify.envelope import envelope


def main(section, base, unknowns, raw_dir, plan, unit, inputs, log=None):
    logger = script_logging(log)
    section, manifest = dict(section), load_manifest(base)
    declared = load_unknowns(unknowns, raw_dir=Path(raw_dir))
    drawn = envelope(section, {manifest["name"]: manifest}, declared)
    extra = {
        "unknowns_sha256": unknowns_hash(unknowns),
        "varied": [u.id for u in drawn.varied],
        "held": [u.id for u in drawn.held],
    }
    for frame, path in ((drawn.plan, plan), (drawn.unit, unit)):
        write_table(frame.reset_index(), path, inputs=inputs, config=section, **extra)
    logger.info("%d members, %d unknowns varied", len(drawn.plan), len(drawn.varied))


if "snakemake" in globals():
    run(main, snakemake)
