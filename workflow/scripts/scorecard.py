"""Rule `scorecard`: every published number beside its reproduction for one dataset (CSV + page;
selfsense.scorecard.card.dataset_scorecard)."""

from pathlib import Path

import pandas as pd

from selfsense.io.manifest import load_dataset, load_yaml
from selfsense.io.provenance import atomic_path, provenance, script_logging, write_json, write_table
from selfsense.scorecard.card import dataset_scorecard, dataset_tables
from selfsense.scorecard.registry import parse_registry
from selfsense.scorecard.render import scorecard_html
from selfsense.scorecard.scoring import counts

REGISTRY = "workflow/scorecard.yaml"


def main(manifest, results_dir, table, page, tables=None, registry=REGISTRY, log=None):
    logger = script_logging(log)
    meta = load_dataset(Path(manifest).parent.parent, Path(manifest).parent.name)
    entries = parse_registry(load_yaml(registry), registry)
    if tables is None:  # run alone: the registry's tables that exist
        tables = [p for t in dataset_tables(entries, meta) if (p := Path(results_dir) / t).exists()]
    read = {Path(t).relative_to(results_dir).as_posix(): pd.read_csv(t) for t in tables}
    card = dataset_scorecard(entries, read, meta)
    inputs = [registry, manifest, *map(str, tables)]
    write_table(card, table, inputs=inputs)
    with atomic_path(page) as tmp:
        tmp.write_text(scorecard_html(card, f"Scorecard: {meta['name']}"), encoding="utf-8")
    write_json(provenance(inputs), f"{page}.json")
    logger.info("%s: %s", meta["name"], counts(card))


if "snakemake" in globals():
    main(
        snakemake.input.manifest,
        snakemake.params.results_dir,
        snakemake.output.table,
        snakemake.output.page,
        list(snakemake.input.tables),
        snakemake.input.registry,
        snakemake.log[0],
    )
