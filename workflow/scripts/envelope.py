"""Rule `envelope`: the nominal scorecard's emergent numbers against the members' (envelope_result
of selfsense.envelope.verdicts): envelope scorecard, sensitivity, ensemble, figures, summary."""

from pathlib import Path

import pandas as pd

from selfsense.envelope import figures
from selfsense.envelope.design import Design
from selfsense.envelope.unknowns import load_unknowns, unknowns_hash
from selfsense.envelope.verdicts import envelope_result
from selfsense.io.manifest import load_manifest, load_yaml
from selfsense.io.provenance import atomic_path, run, script_logging, write_table
from selfsense.scorecard.registry import applicable, parse_registry


def main(design, raw_dir, nominal, unit, cards, registry, unknowns, inputs, log, pdf, **out):
    """design: the envelope's design record; cards: each member's scorecard, in a folder named
    after the member; out: card, sensitivity, values, signatures, forest, tornado and summary."""
    logger = script_logging(log)
    design = Design(**design)
    base = load_manifest(Path(raw_dir) / design.dataset / "dataset.yaml")
    entries = applicable(parse_registry(load_yaml(registry), registry), base)
    cards = {Path(c).parent.name: pd.read_csv(c) for c in cards}
    sha = unknowns_hash(unknowns)
    drawn = pd.read_csv(unit, index_col="member")
    declared = load_unknowns(unknowns, raw_dir=raw_dir)
    result = envelope_result(design, pd.read_csv(nominal), cards, drawn, declared, entries, sha)
    extra = {"unknowns_sha256": sha, "members": list(cards), "design": design.record()}
    extra["calibration_misses"] = result.misses
    for key in ("card", "sensitivity"):
        write_table(getattr(result, key), out[key], inputs=inputs, **extra)
    for key in ("values", "signatures"):
        write_table(getattr(result, key).reset_index(), out[key], inputs=inputs, **extra)
    title = f"{design.dataset}: {len(cards)} envelope members"
    figures.forest_figure(result.card, out["forest"], title, inputs=inputs, pdf=pdf)
    figures.tornado_figure(
        result.sensitivity, result.card, out["tornado"], title, inputs=inputs, pdf=pdf
    )
    with atomic_path(out["summary"]) as tmp:
        tmp.write_text(result.summary, encoding="utf-8")
    logger.info("%s", result.summary.splitlines()[2])


if "snakemake" in globals():
    run(main, snakemake)
