"""Rule `envelope`: every emergent number of the nominal scorecard against its envelope over the
members (selfsense.scorecard.envelope.envelope_result): the envelope scorecard, the Morris
sensitivity table, the forest and tornado figures and the opening's summary."""

from pathlib import Path

import pandas as pd

from selfsense.io.manifest import load_manifest, load_yaml
from selfsense.io.provenance import atomic_path, run, script_logging, write_table
from selfsense.io.unknowns import load_unknowns, unknowns_hash
from selfsense.scorecard import envelope_figures as figures
from selfsense.scorecard.envelope import envelope_result
from selfsense.scorecard.registry import applicable, parse_registry


def main(section, raw_dir, nominal, unit, members, registry, unknowns, inputs, log, pdf, **out):
    """members: each member's scorecard, results/<member>/scorecard.csv; out: card, sensitivity,
    forest, tornado and summary."""
    logger = script_logging(log)
    section = dict(section)
    base = load_manifest(Path(raw_dir) / section["dataset"] / "dataset.yaml")
    entries = applicable(parse_registry(load_yaml(registry), registry), base)
    cards = {Path(c).parent.name: pd.read_csv(c) for c in members}
    sha = unknowns_hash(unknowns)
    drawn = pd.read_csv(unit, index_col="member")
    declared = load_unknowns(unknowns, raw_dir=raw_dir)
    result = envelope_result(section, pd.read_csv(nominal), cards, drawn, declared, entries, sha)
    extra = {"unknowns_sha256": sha, "members": list(cards), "design": section}
    write_table(result.card, out["card"], inputs=inputs, **extra)
    write_table(result.sensitivity, out["sensitivity"], inputs=inputs, **extra)
    title = f"{section['dataset']}: {len(cards)} envelope members"
    figures.forest_figure(result.card, out["forest"], title, inputs=inputs, pdf=pdf)
    figures.tornado_figure(
        result.sensitivity, result.card, out["tornado"], title, inputs=inputs, pdf=pdf
    )
    with atomic_path(out["summary"]) as tmp:
        tmp.write_text(result.summary, encoding="utf-8")
    logger.info("%s", result.summary.splitlines()[2])


if "snakemake" in globals():
    run(main, snakemake)
