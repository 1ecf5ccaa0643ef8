# Which stages run for each dataset, and why the others are skipped (a dataset that lacks the
# channels or experiments an analysis needs skips it with a stated reason, it does not crash).


rule stage_plan:
    """Which analyses run for a dataset and, for the skipped ones, what they would need."""
    input:
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("stage_plan"),
    output:
        table=report("results/{dataset}/stages.csv", caption="../report/stages.rst", category="{dataset}",
                     subcategory="Stages"),
    params:
        rows=lambda w: stage_rows(w.dataset),
    log:
        "logs/{dataset}/stage_plan.log",
    benchmark:
        "benchmarks/out/{dataset}/stage_plan.tsv"
    threads: 1
    resources:
        mem_mb=200,
        runtime=5,
    script:
        "../scripts/stage_plan.py"
