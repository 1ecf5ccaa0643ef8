"""Rule `envelope`: the nominal scorecard's emergent numbers against the members' (envelope_result
of selfsense.envelope.verdicts): envelope scorecard, sensitivity, ensemble, figures, summary."""

from pathlib import Path

import pandas as pd

from selfsense.envelope import figures
from selfsense.envelope.design import Design
from selfsense.envelope.unknowns import load_unknowns, unknowns_hash
from selfsense.envelope.verdicts import envelope_result
from selfsense.io.manifest import load_manifest, load_yaml
from selfsense.io.provenance import atomic_path, script_logging, write_table
from selfsense.scorecard.registry import applicable, parse_registry


def main(design, i, o, member_names, raw_dir, log=None, pdf=True):
    logger = script_logging(log)
    base = load_manifest(Path(raw_dir) / design.dataset / "dataset.yaml")
    entries = applicable(parse_registry(load_yaml(i.registry), i.registry), base)
    members = {m: pd.read_csv(c) for m, c in zip(member_names, i.members, strict=True)}
    unit = pd.read_csv(i.unit, index_col="member")
    sha = unknowns_hash(i.unknowns)
    unknowns = load_unknowns(i.unknowns, raw_dir=raw_dir)
    result = envelope_result(design, pd.read_csv(i.nominal), members, unit, unknowns, entries, sha)
    inputs = [i.nominal, i.plan, i.unit, i.registry, i.unknowns, *i.members]
    extra = {"unknowns_sha256": sha, "members": member_names, "design": design.record()}
    extra["calibration_misses"] = result.misses
    write_table(result.card, o.card, inputs=inputs, **extra)
    write_table(result.sensitivity, o.sensitivity, inputs=inputs, **extra)
    for table, path in ((result.values, o.values), (result.signatures, o.signatures)):
        write_table(table.reset_index(), path, inputs=inputs, **extra)
    title = f"{design.dataset}: {len(members)} envelope members"
    figures.forest_figure(result.card, o.forest, title, inputs=inputs, pdf=pdf)
    figures.tornado_figure(
        result.sensitivity, result.card, o.tornado, title, inputs=inputs, pdf=pdf
    )
    with atomic_path(o.summary) as tmp:
        tmp.write_text(result.summary, encoding="utf-8")
    logger.info("%s", result.summary.splitlines()[2])


if "snakemake" in globals():
    p, i, o = snakemake.params, snakemake.input, snakemake.output
    main(Design(**p.design), i, o, list(p.members), p.raw_dir, snakemake.log[0], pdf=p.pdf)
