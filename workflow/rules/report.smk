# Stage "report": the scorecard (every published number beside its reproduction, with a band and a
# verdict) per dataset, and the summary that opens `snakemake --report` (workflow/report/workflow.rst).

from selfsense.manifest import load_yaml
from selfsense.reference_values import tables_read as reference_tables
from selfsense.scorecard import applicable, parse_registry, tables_read

SCORECARD_REGISTRY = "workflow/scorecard.yaml"

# parsed once here so that a bad registry stops the workflow with one line before anything runs
SCORECARD = parse_registry(load_yaml(SCORECARD_REGISTRY), SCORECARD_REGISTRY)

#: everything the stages promise to make (each stage's *_OUTPUTS, as rule all collects them)
STAGE_OUTPUTS = set(ACQUIRE_OUTPUTS + RIPPLE_OUTPUTS + IDENTIFY_OUTPUTS + GAMMA_OUTPUTS + OBSERVER_OUTPUTS
                    + CONTROL_OUTPUTS + THERMAL_OUTPUTS + POWERLOSS_OUTPUTS + CHARACTERISE_OUTPUTS)

#: per dataset, the registry's tables (and those its reference values are compared with) that some
#: stage makes: the scorecard reads (and reruns after) exactly these; the other entries show as
#: "not reproduced yet"
SCORECARD_TABLES = {d: [t for t in (f"results/{d}/{t}" for t in tables_read(applicable(SCORECARD, DATASETS[d]))
                                    + reference_tables(DATASETS[d]))
                        if t in STAGE_OUTPUTS] for d in DATASETS}


rule scorecard:
    """Published vs reproduced numbers for one dataset: deviation, band, verdict (CSV and a page)."""
    input:
        registry=SCORECARD_REGISTRY,
        manifest=RAW / "{dataset}" / "dataset.yaml",
        tables=lambda w: SCORECARD_TABLES[w.dataset],
        library=library_sources("scorecard"),
    output:
        table=report("results/{dataset}/scorecard.csv", caption="../report/scorecard.rst",
                     category="{dataset}", subcategory="Scorecard"),
        page=report("results/{dataset}/scorecard.html", caption="../report/scorecard.rst",
                    category="{dataset}", subcategory="Scorecard"),
    params:
        results_dir=lambda w: f"results/{w.dataset}",
    log:
        "logs/{dataset}/scorecard.log",
    benchmark:
        "benchmarks/out/{dataset}/scorecard.tsv"
    threads: 1
    resources:
        mem_mb=300,
        runtime=5,
    script:
        "../scripts/scorecard.py"


rule scorecard_summary:
    """The summary that opens the report (counts per dataset), and pages of its long lists: what is
    out of band and why, what is not reproduced yet. The lists are report items of their own, not
    part of the opening: Snakemake centres its landing text, so a long one starts out of reach."""
    input:
        cards=[f"results/{d}/scorecard.csv" for d in DATASETS],
        library=library_sources("scorecard_summary"),
    output:
        summary=report("results/scorecard_summary.rst", caption="../report/scorecard_summary.rst",
                       category="Scorecard", subcategory="All datasets"),
        out_of_band=report("results/scorecard_out_of_band.html", caption="../report/scorecard_out_of_band.rst",
                           category="Scorecard", subcategory="All datasets"),
        not_yet=report("results/scorecard_not_yet.html", caption="../report/scorecard_not_yet.rst",
                       category="Scorecard", subcategory="All datasets"),
    log:
        "logs/scorecard_summary.log",
    benchmark:
        "benchmarks/out/scorecard_summary.tsv"
    threads: 1
    resources:
        mem_mb=300,
        runtime=5,
    script:
        "../scripts/scorecard_summary.py"


REPORT_OUTPUTS = expand(rules.scorecard.output.table, dataset=DATASETS) + list(rules.scorecard_summary.output)
