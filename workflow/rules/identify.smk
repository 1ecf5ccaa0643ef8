# Stage "identify" (thesis Chapter 4): Case 1 / Case 2 model identification, Tables 4.1–4.3.
# Which datasets run it: the stage plan (IDENTIFY_DATASETS in common.smk).


rule static_stiffness:
    """k from the blocked force over the free stroke at U_max (Eq 4.16)."""
    input:
        unpack(
            lambda w: captures(
                w.dataset,
                free=role_run(w.dataset, "identify.static_free"),
                blocked=role_run(w.dataset, "identify.static_blocked"),
            )
        ),
        library=library_sources("static_stiffness"),
    output:
        table=report(
            "results/{dataset}/ch4/static_stiffness.csv",
            caption="../report/static_stiffness.rst",
            category="{dataset}",
            subcategory="Chapter 4",
        ),
    log:
        "logs/{dataset}/static_stiffness.log",
    benchmark:
        "benchmarks/out/{dataset}/static_stiffness.tsv"
    threads: 1
    resources:
        **resources_for("medium"),
    params:
        t_hold=config["identify"]["static_hold_s"],
    script:
        "../scripts/static_stiffness.py"


rule identify:
    """Case 1 and Case 2 for every set (Eq 4.15–4.25); Tables 4.1–4.3 and the model for later stages."""
    input:
        series=role_paths("results/{dataset}/ripple/{run}.nc", "identify.set"),
        static="results/{dataset}/ch4/static_stiffness.csv",
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("identify"),
    output:
        **report_tables("ch4", CH4_TABLES, "Chapter 4"),
        model="results/{dataset}/ch4/model.json",
    log:
        "logs/{dataset}/identify.log",
    benchmark:
        "benchmarks/out/{dataset}/identify.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    script:
        "../scripts/identify.py"


rule ch4_figures:
    """Figures 4.2–4.8."""
    input:
        unpack(
            lambda w: captures(
                w.dataset,
                force=role_run(w.dataset, "identify.force_record"),
                drive=role_run(w.dataset, "identify.recovery_drive"),
            )
        ),
        series=role_paths("results/{dataset}/ripple/{run}.nc", "identify.set"),
        per_set="results/{dataset}/ch4/sets.csv",
        library=library_sources("ch4_figures"),
    output:
        **{name: report_figure(name, "Chapter 4") for name in CH4_FIGURES},
    log:
        "logs/{dataset}/ch4_figures.log",
    benchmark:
        "benchmarks/out/{dataset}/ch4_figures.tsv"
    threads: 1
    resources:
        **resources_for("large"),
    params:
        pdf=FIGURE_PDF,
    script:
        "../scripts/ch4_figures.py"


#: what the stage makes for rule all and the scorecard: its rules' outputs, for the datasets it runs for
IDENTIFY_OUTPUTS = expand(
    [*rules.static_stiffness.output, *rules.identify.output, *rules.ch4_figures.output],
    dataset=IDENTIFY_DATASETS,
)
