# Stage "report": the scorecard (every published number beside its reproduction, with a band and a
# verdict) per dataset, and the summary that opens `snakemake --report` (workflow/report/workflow.rst).
from selfsense.manifest import load_yaml
from selfsense.scorecard import applicable, parse_registry, tables_read

SCORECARD_REGISTRY = "workflow/scorecard.yaml"
# parsed once here so that a bad registry stops the workflow with one line before anything runs
SCORECARD = parse_registry(load_yaml(SCORECARD_REGISTRY), SCORECARD_REGISTRY)


def report_outputs():
    return [f"results/{d}/scorecard.csv" for d in DATASETS] + ["results/scorecard_summary.rst"]


def stage_outputs():
    """Everything the stages promise to make (each stage's *_outputs(), as rule all collects them)."""
    return set(acquire_outputs() + ripple_outputs() + identify_outputs() + gamma_outputs()
               + observer_outputs() + control_outputs() + thermal_outputs() + powerloss_outputs())


def scorecard_tables(dataset):
    """The registry's tables that some stage makes for this dataset: the scorecard reads (and
    reruns after) exactly these; the registry's other entries show as "not reproduced yet"."""
    made = stage_outputs()
    wanted = [f"results/{dataset}/{t}" for t in tables_read(applicable(SCORECARD, DATASETS[dataset]))]
    return [t for t in wanted if t in made]


rule scorecard:
    """Published vs reproduced numbers for one dataset: deviation, band, verdict (CSV and a page)."""
    input:
        registry=SCORECARD_REGISTRY,
        manifest=RAW / "{dataset}" / "dataset.yaml",
        tables=lambda w: scorecard_tables(w.dataset),
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
    """The summary that opens the report: counts per dataset, what is out of band and why."""
    input:
        cards=[f"results/{d}/scorecard.csv" for d in DATASETS],
    output:
        summary=report("results/scorecard_summary.rst", caption="../report/scorecard_summary.rst",
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
