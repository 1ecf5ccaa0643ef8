# Stage "identify" (thesis Chapter 4): Case 1 / Case 2 model identification, Tables 4.1–4.3.

from selfsense.chapters.figure_names import CH4 as CH4_FIGURES

CH4_TABLES = ["sets", "table_4_1", "table_4_2", "table_4_3", "hysteresis_voltage"]

#: the Chapter 4 sine sets of each dataset
CH4_SETS = {d: [e for e in EXPERIMENTS[d] if e.startswith("ch4_sine_")] for d in DATASETS}


def ch4_series(wildcards):
    """The ripple series of the dataset's Chapter 4 sets, in CH4_SETS's order."""
    return [f"results/{wildcards.dataset}/ripple/{e}.nc" for e in CH4_SETS[wildcards.dataset]]


#: the capture whose truth the identified model is held to (Fig 4.8's U_H at its frequency too)
RECOVERY_SINE = "ch4_sine_10hz_s1"

#: datasets with the ripple channels, the Chapter 4 sets and the static stiffness tests
IDENTIFY_DATASETS = [d for d in RIPPLE_DATASETS if CH4_SETS[d]
                     and {"ch4_static_free", "ch4_static_blocked"} <= set(EXPERIMENTS[d])]


rule static_stiffness:
    """k from the blocked force over the free stroke at U_max (Eq 4.16)."""
    input:
        unpack(lambda w: captures(w.dataset, free="ch4_static_free", blocked="ch4_static_blocked")),
        library=library_sources("static_stiffness"),
    output:
        table=report("results/{dataset}/ch4/static_stiffness.csv", caption="../report/static_stiffness.rst",
                     category="{dataset}", subcategory="Chapter 4"),
    params:
        t_hold=0.55,
    log:
        "logs/{dataset}/static_stiffness.log",
    benchmark:
        "benchmarks/out/{dataset}/static_stiffness.tsv"
    threads: 1
    resources:
        mem_mb=500,
        runtime=5,
    script:
        "../scripts/static_stiffness.py"


rule identify:
    """Case 1 and Case 2 for every set (Eq 4.15–4.25); Tables 4.1–4.3 and the model for later stages."""
    input:
        series=ch4_series,
        static="results/{dataset}/ch4/static_stiffness.csv",
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("identify"),
    output:
        **{t: report(f"results/{{dataset}}/ch4/{t}.csv", caption=f"../report/{t}.rst", category="{dataset}",
                     subcategory="Chapter 4") for t in CH4_TABLES},
        model="results/{dataset}/ch4/model.json",
    log:
        "logs/{dataset}/identify.log",
    benchmark:
        "benchmarks/out/{dataset}/identify.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=20,
    script:
        "../scripts/identify.py"


rule ch4_figures:
    """Figures 4.2–4.8."""
    input:
        unpack(lambda w: captures(w.dataset, force="ch4_sine_50hz_s1", drive="ch4_sine_10hz_s1")),
        series=ch4_series,
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
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/ch4_figures.py"


rule model_recovery:
    """Identified parameters against the twin's built values and against the same identification on
    its noiseless states (parameter recovery)."""
    input:
        unpack(lambda w: captures(w.dataset, capture=RECOVERY_SINE, sets=CH4_SETS[w.dataset])),
        series=ch4_series,
        per_set="results/{dataset}/ch4/sets.csv",
        hysteresis="results/{dataset}/ch4/hysteresis_voltage.csv",
        static="results/{dataset}/ch4/static_stiffness.csv",
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("model_recovery"),
    output:
        table=report("results/{dataset}/twin/model_recovery.csv", caption="../report/model_recovery.rst",
                     category="{dataset}", subcategory="Twin validation"),
    params:
        frequency=lambda w: EXPERIMENTS[w.dataset][RECOVERY_SINE].protocol["segments"][0]["frequency"],
        n_periods=config["ripple"]["n_periods"],
    log:
        "logs/{dataset}/model_recovery.log",
    benchmark:
        "benchmarks/out/{dataset}/model_recovery.tsv"
    threads: 1
    resources:
        mem_mb=500,
        runtime=5,
    script:
        "../scripts/model_recovery.py"


#: what the stage makes for rule all and the scorecard: its rules' outputs, for the datasets each runs for
IDENTIFY_OUTPUTS = (
    expand([*rules.static_stiffness.output, *rules.identify.output, *rules.ch4_figures.output],
           dataset=IDENTIFY_DATASETS)
    + expand(rules.model_recovery.output, dataset=[d for d in IDENTIFY_DATASETS if d in SIMULATED])
)
