"""Rule `validation_verdicts`: the validation's verdicts from the ensemble's tables alone
(selfsense.envelope.judgement.judge): verdicts with their drivers, emulators, Sobol' shares,
waves, compatibility map, the pseudo-theses' coverage and PIT histogram, the summary; every
output naming the declaration's and the unknowns' sha256 and the commit."""

import pandas as pd

from selfsense.envelope import figures
from selfsense.envelope.campaign import ensemble_tables, stamps
from selfsense.envelope.judgement import judge
from selfsense.envelope.validation import load_validation
from selfsense.io.manifest import load_yaml
from selfsense.io.provenance import atomic_path, run, script_logging, write_table
from selfsense.scorecard.registry import parse_registry


def main(
    model, pdf, drivers, units, rows, targets, declaration, registry, unknowns, inputs, log, **out
):
    """model: the inputs (ids), each one's nominal as a unit value (for runs that held it) and
    those the model holds (fixed); units, rows, targets: every batch's tables, the joined
    validations' first; out: the rule's outputs by name."""
    logger = script_logging(log)
    decl = load_validation(declaration)
    entries = parse_registry(load_yaml(registry), registry)
    read = ([pd.read_csv(p) for p in ps] for ps in (units, rows, targets))
    tables = ensemble_tables(*read, ids=model["ids"], nominal=model["nominal"])
    result = judge(decl, entries, model["ids"], *tables, **drivers, fixed=model["fixed"])
    extra = stamps(declaration, unknowns) | {"members": len(tables[0])}
    for key in ("verdicts", "emulators", "waves", "compatibility", "coverage", "pit", "sobol"):
        write_table(getattr(result, key), out[key], inputs=inputs, **extra)
    title = f"{decl.dataset}, {len(tables[0])} runs"
    folds = list(result.compatibility["fold"])
    share = result.compatibility[folds].to_numpy() if folds else []
    pit = result.headline_pit["inside 95 %"]
    coverage = float(pit.mean()) if len(pit) else float("nan")
    drawn = (
        (figures.pit_histogram(result.histogram, coverage, len(pit), title), out["pit_histogram"]),
        (figures.compatibility_map(folds, share, title), out["compatibility_map"]),
    )
    for fig, path in drawn:
        figures.validation_figure(fig, path, inputs=inputs, pdf=pdf, **extra)
    with atomic_path(out["summary"]) as tmp:
        named = ", ".join(f"{k} {v}" for k, v in stamps(declaration, unknowns).items())
        tmp.write_text(f"{result.summary}\nProvenance: {named}.\n", encoding="utf-8")
    logger.info("%s", "\n".join(result.summary.splitlines()[:7]))


if "snakemake" in globals():
    run(main, snakemake)
