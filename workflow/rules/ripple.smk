# Stage "ripple" (thesis Chapter 3): folded-sampling plan, C_e and R_e from the ripple channels;
# and stage "ch3": the loop widths, phases and figures of the three Chapter 3 runs. Which datasets
# run each: the stage plan (RIPPLE_DATASETS, CH3_DATASETS in common.smk).


rule extract_ripple:
    """C_e and R_e per folded period (Eq 3.6–3.13) plus window means of U, x, I, q."""
    input:
        unpack(lambda w: captures(w.dataset, capture=w.experiment)),
        library=library_sources("extract_ripple"),
    output:
        series="results/{dataset}/ripple/{experiment}.nc",
    log:
        "logs/{dataset}/extract_ripple/{experiment}.log",
    benchmark:
        "benchmarks/out/{dataset}/extract_ripple/{experiment}.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        n_periods=config["ripple"]["n_periods"],
    script:
        "../scripts/extract_ripple.py"


rule ch3_tables:
    """Tables 3.1 and 3.2 from the folding equations (Eq 3.4, 3.5, 3.8, 3.9)."""
    input:
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("ch3_tables"),
    output:
        table_31=report(
            "results/{dataset}/ch3/table_3_1.csv",
            caption="../report/table_3_1.rst",
            category="{dataset}",
            subcategory="Chapter 3",
        ),
        table_32=report(
            "results/{dataset}/ch3/table_3_2.csv",
            caption="../report/table_3_2.rst",
            category="{dataset}",
            subcategory="Chapter 3",
        ),
    log:
        "logs/{dataset}/ch3_tables.log",
    benchmark:
        "benchmarks/out/{dataset}/ch3_tables.tsv"
    threads: 1
    resources:
        **resources_for("small"),
    params:
        fr=lambda w: DATASETS[w.dataset]["daq"]["ripple"]["fr_nominal"],
        ns=lambda w: DATASETS[w.dataset]["daq"]["ripple"]["ns"],
        fs=lambda w: DATASETS[w.dataset]["daq"]["fs"],
    script:
        "../scripts/ch3_tables.py"


rule ch3_hysteresis:
    """Loop widths C–U, C–x, R–C, x–U at 100 V, 10 Hz beside the thesis's percentages; the drive
    and ripple U–I phases (Figs 3.3–3.4)."""
    input:
        series=role_path("results/{dataset}/ripple/{run}.nc", stages.CH3_SERIES["10 Hz"]),
        library=library_sources("ch3_hysteresis"),
    output:
        table=report(
            "results/{dataset}/ch3/hysteresis.csv",
            caption="../report/hysteresis.rst",
            category="{dataset}",
            subcategory="Chapter 3",
        ),
        phases=report(
            "results/{dataset}/ch3/phases.csv",
            caption="../report/phases.rst",
            category="{dataset}",
            subcategory="Chapter 3",
        ),
    log:
        "logs/{dataset}/ch3_hysteresis.log",
    benchmark:
        "benchmarks/out/{dataset}/ch3_hysteresis.tsv"
    threads: 1
    resources:
        **resources_for("medium"),
    params:
        skip_s=config["ripple"]["skip_s"],
        frequency=lambda w: float(
            drive_frequency(w.dataset, role_run(w.dataset, stages.CH3_SERIES["10 Hz"]))
        ),
    script:
        "../scripts/ch3_hysteresis.py"


rule ch3_figures:
    """Figures 3.2–3.14 of the ripple impedance measurement."""
    input:
        unpack(
            lambda w: captures(w.dataset, capture=role_run(w.dataset, stages.CH3_SERIES["10 Hz"]))
        ),
        series=lambda w: [
            f"results/{w.dataset}/ripple/{role_run(w.dataset, r)}.nc"
            for r in stages.CH3_SERIES.values()
        ],
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("ch3_figures"),
    output:
        **{name: report_figure(name, "Chapter 3") for name in CH3_FIGURES},
    log:
        "logs/{dataset}/ch3_figures.log",
    benchmark:
        "benchmarks/out/{dataset}/ch3_figures.tsv"
    threads: 1
    resources:
        **resources_for("large"),
    params:
        pdf=FIGURE_PDF,
        labels=lambda w: {role_run(w.dataset, r): label for label, r in stages.CH3_SERIES.items()},
        skip_s=config["ripple"]["skip_s"],
    script:
        "../scripts/ch3_figures.py"


rule ch3_model_figure:
    """Figure 3.2: ripple-driven velocity, free vs clamped (needs the stack's mechanics)."""
    input:
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("ch3_model_figure"),
    output:
        figure=report_figure(CH3_MODEL_FIGURE, "Chapter 3"),
    log:
        "logs/{dataset}/ch3_model_figure.log",
    benchmark:
        "benchmarks/out/{dataset}/ch3_model_figure.tsv"
    threads: 1
    resources:
        **resources_for("small"),
    params:
        pdf=FIGURE_PDF,
    script:
        "../scripts/ch3_model_figure.py"


#: what the stages make for rule all and the scorecard: their rules' outputs, for the datasets each runs for
RIPPLE_OUTPUTS = (
    expand(rules.ch3_tables.output, dataset=RIPPLE_DATASETS)
    + expand([*rules.ch3_hysteresis.output, *rules.ch3_figures.output], dataset=CH3_DATASETS)
    + expand(rules.ch3_model_figure.output, dataset=with_twin(CH3_DATASETS))
)
