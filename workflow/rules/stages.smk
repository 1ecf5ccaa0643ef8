# Stage "stages": the stage plan of each dataset as a table. The plan (selfsense.stages, computed
# in common.smk as STAGE_PLANS) also gates every rule file's datasets, so the table says exactly
# which stages run and, for the skipped ones, what the dataset lacks of what they need.


rule stage_plan:
    """Which analyses run for a dataset and, for the skipped ones, what they would need."""
    input:
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("stage_plan"),
    output:
        table=report(
            "results/{dataset}/stages.csv",
            caption="../report/stages.rst",
            category="{dataset}",
            subcategory="Stages",
        ),
    log:
        "logs/{dataset}/stage_plan.log",
    benchmark:
        "benchmarks/out/{dataset}/stage_plan.tsv"
    threads: 1
    resources:
        **resources_for("small"),
    params:
        rows=lambda w: STAGE_PLANS[w.dataset].rows(),
    script:
        "../scripts/stage_plan.py"


STAGE_PLAN_OUTPUTS = expand(rules.stage_plan.output, dataset=DATASETS)
