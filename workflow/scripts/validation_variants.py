"""Rule `validation_variants`: the twin's variants chosen by the data they are not judged on
(selfsense.envelope.variant_choice.choose): every model's verdicts, compatibility maps, fold
states, the declared rows side by side and the summary; every output naming the
declaration's and the unknowns' sha256 and the commit."""

import pandas as pd

from selfsense.envelope.campaign import Model, ensemble_tables, stamps
from selfsense.envelope.validation import load_validation
from selfsense.envelope.variant_choice import choose
from selfsense.io.manifest import load_yaml
from selfsense.io.provenance import atomic_path, run, script_logging, write_table
from selfsense.scorecard.registry import parse_registry


def main(model, models, units, rows, targets, declaration, registry, unknowns, inputs, log, **out):
    """model: the inputs (ids) and each one's nominal as a unit value; models: the models
    judged (name, fixed); units, rows, targets: every batch's tables, the joined ones' first;
    out: the rule's outputs by name."""
    logger = script_logging(log)
    decl = load_validation(declaration)
    entries = parse_registry(load_yaml(registry), registry)
    read = ([pd.read_csv(p) for p in ps] for ps in (units, rows, targets))
    tables = ensemble_tables(*read, ids=model["ids"], nominal=model["nominal"])
    chosen = [Model(**m) for m in models]
    result = choose(decl, entries, model["ids"], *tables, chosen)
    extra = stamps(declaration, unknowns) | {"members": len(tables[0])}
    for key in ("verdicts", "compatibility"):
        write_table(getattr(result, key), out[key], inputs=inputs, **extra)
    write_table(result.rows, out["side_by_side"], inputs=inputs, **extra)
    write_table(result.folds.reset_index(), out["folds"], inputs=inputs, **extra)
    with atomic_path(out["summary"]) as tmp:
        named = ", ".join(f"{k} {v}" for k, v in stamps(declaration, unknowns).items())
        tmp.write_text(f"{result.summary}\nProvenance: {named}.\n", encoding="utf-8")
    logger.info("%s", result.summary)


if "snakemake" in globals():
    run(main, snakemake)
