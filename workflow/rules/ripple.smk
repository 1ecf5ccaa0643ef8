# Stage "ripple" (thesis Chapter 3): folded-sampling plan, C_e and R_e from the ripple channels.

from selfsense.chapters.figure_names import CH3 as CH3_FIGURES, CH3_MODEL as CH3_MODEL_FIGURE

#: the Chapter 3 runs by drive frequency (Figures 3.9–3.14, hysteresis, C_e recovery)
CH3_SERIES = {"10 Hz": "ch3_sine_10hz", "1 Hz": "ch3_sine_1hz", "0.1 Hz": "ch3_sine_0p1hz"}

#: datasets whose DAQ records the ripple channels (the others skip this stage)
RIPPLE_DATASETS = [d for d in DATASETS
                   if has_channels(d, "Ur", "Ir", "U", "I", "x_laser") and "ripple" in DATASETS[d]["daq"]]

#: ripple datasets with the three Chapter 3 runs
CH3_DATASETS = [d for d in RIPPLE_DATASETS if set(CH3_SERIES.values()) <= set(EXPERIMENTS[d])]


rule extract_ripple:
    """C_e and R_e per folded period (Eq 3.6–3.13) plus window means of U, x, I, q."""
    input:
        unpack(lambda w: captures(w.dataset, capture=w.experiment)),
        library=library_sources("extract_ripple"),
    output:
        series="results/{dataset}/ripple/{experiment}.nc",
    params:
        n_periods=config["ripple"]["n_periods"],
    log:
        "logs/{dataset}/extract_ripple/{experiment}.log",
    benchmark:
        "benchmarks/out/{dataset}/extract_ripple/{experiment}.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=30,
    script:
        "../scripts/extract_ripple.py"


rule ch3_tables:
    """Tables 3.1 and 3.2 from the folding equations (Eq 3.4, 3.5, 3.8, 3.9)."""
    input:
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("ch3_tables"),
    output:
        table_31=report("results/{dataset}/ch3/table_3_1.csv", caption="../report/table_3_1.rst",
                        category="{dataset}", subcategory="Chapter 3"),
        table_32=report("results/{dataset}/ch3/table_3_2.csv", caption="../report/table_3_2.rst",
                        category="{dataset}", subcategory="Chapter 3"),
    params:
        fr=lambda w: DATASETS[w.dataset]["daq"]["ripple"]["fr_nominal"],
        ns=lambda w: DATASETS[w.dataset]["daq"]["ripple"]["ns"],
        fs=lambda w: DATASETS[w.dataset]["daq"]["fs"],
    log:
        "logs/{dataset}/ch3_tables.log",
    benchmark:
        "benchmarks/out/{dataset}/ch3_tables.tsv"
    threads: 1
    resources:
        mem_mb=200,
        runtime=5,
    script:
        "../scripts/ch3_tables.py"


rule ch3_hysteresis:
    """Loop widths C–U, C–x, R–C, x–U at 100 V, 10 Hz beside the thesis's percentages; the drive
    and ripple U–I phases (Figs 3.3–3.4)."""
    input:
        series="results/{dataset}/ripple/ch3_sine_10hz.nc",
        library=library_sources("ch3_hysteresis"),
    output:
        table=report("results/{dataset}/ch3/hysteresis.csv", caption="../report/hysteresis.rst",
                     category="{dataset}", subcategory="Chapter 3"),
        phases=report("results/{dataset}/ch3/phases.csv", caption="../report/phases.rst",
                      category="{dataset}", subcategory="Chapter 3"),
    params:
        skip_s=0.1,
        frequency=10.0,  # the drive of ch3_sine_10hz
    log:
        "logs/{dataset}/ch3_hysteresis.log",
    benchmark:
        "benchmarks/out/{dataset}/ch3_hysteresis.tsv"
    threads: 1
    resources:
        mem_mb=500,
        runtime=5,
    script:
        "../scripts/ch3_hysteresis.py"


rule ch3_figures:
    """Figures 3.2–3.14 of the ripple impedance measurement."""
    input:
        unpack(lambda w: captures(w.dataset, capture="ch3_sine_10hz")),
        series=[f"results/{{dataset}}/ripple/{e}.nc" for e in CH3_SERIES.values()],
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("ch3_figures"),
    output:
        **{name: report_figure(name, "Chapter 3") for name in CH3_FIGURES},
    params:
        labels=list(CH3_SERIES),
        skip_s=0.1,
    log:
        "logs/{dataset}/ch3_figures.log",
    benchmark:
        "benchmarks/out/{dataset}/ch3_figures.tsv"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
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
        mem_mb=300,
        runtime=5,
    script:
        "../scripts/ch3_model_figure.py"


rule ce_recovery:
    """C_e from the ripple against the twin's true clamped capacitance (parameter recovery)."""
    input:
        unpack(lambda w: captures(w.dataset, captures=list(CH3_SERIES.values()))),
        series=[f"results/{{dataset}}/ripple/{e}.nc" for e in CH3_SERIES.values()],
        library=library_sources("ce_recovery"),
    output:
        table=report("results/{dataset}/twin/ce_recovery.csv", caption="../report/ce_recovery.rst",
                     category="{dataset}", subcategory="Twin validation"),
    params:
        n_periods=config["ripple"]["n_periods"],
    log:
        "logs/{dataset}/ce_recovery.log",
    benchmark:
        "benchmarks/out/{dataset}/ce_recovery.tsv"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/ce_recovery.py"


rule ce_np_study:
    """C_e error against np and ripple-frequency wander (why np = 4), on the twin."""
    input:
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("ce_np_study"),
    output:
        table=report("results/{dataset}/twin/ce_np_study.csv", caption="../report/ce_np_study.rst",
                     category="{dataset}", subcategory="Twin validation"),
        figure=report_figure("fig_3_np_study", "Twin validation"),
    params:
        nps=config["ripple"]["np_sweep"],
        wanders=[0, 30, 100, 300],
        drive_hz=100.0,
    log:
        "logs/{dataset}/ce_np_study.log",
    benchmark:
        "benchmarks/out/{dataset}/ce_np_study.tsv"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/ce_np_study.py"


#: what the stage makes for rule all and the scorecard: its rules' outputs, for the datasets each runs for
RIPPLE_OUTPUTS = (
    expand(rules.ch3_tables.output, dataset=RIPPLE_DATASETS)
    + expand([*rules.ch3_hysteresis.output, *rules.ch3_figures.output], dataset=CH3_DATASETS)
    + expand([*rules.ch3_model_figure.output, *rules.ce_np_study.output],
             dataset=[d for d in CH3_DATASETS if "twin" in DATASETS[d]])
    + expand(rules.ce_recovery.output, dataset=[d for d in CH3_DATASETS if d in SIMULATED])  # reads /truth
)
