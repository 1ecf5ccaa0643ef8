"""Rule `scorecard`: every published number beside its reproduction for one dataset (CSV + page;
selfsense.scorecard.card.dataset_scorecard)."""

from pathlib import Path

import pandas as pd

from selfsense.io.manifest import load_dataset, load_yaml
from selfsense.io.provenance import (
    atomic_path,
    provenance,
    run,
    script_logging,
    write_json,
    write_table,
)
from selfsense.scorecard.card import dataset_scorecard
from selfsense.scorecard.registry import parse_registry
from selfsense.scorecard.render import scorecard_html
from selfsense.scorecard.scoring import counts


def main(registry, manifest, tables, results_dir, table, page, inputs, log=None):
    logger = script_logging(log)
    meta = load_dataset(Path(manifest).parent.parent, Path(manifest).parent.name)
    entries = parse_registry(load_yaml(registry), registry)
    read = {Path(t).relative_to(results_dir).as_posix(): pd.read_csv(t) for t in tables}
    card = dataset_scorecard(entries, read, meta)
    write_table(card, table, inputs=inputs)
    with atomic_path(page) as tmp:
        tmp.write_text(scorecard_html(card, f"Scorecard: {meta['name']}"), encoding="utf-8")
    write_json(provenance(inputs), f"{page}.json")
    logger.info("%s: %s", meta["name"], counts(card))


if "snakemake" in globals():
    run(main, snakemake)
