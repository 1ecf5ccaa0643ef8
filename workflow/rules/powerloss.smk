# Stage "powerloss" (Ronkanen 2002): R from the static hold, the loss impedance from the ramps
# (Table 1), the impedance models (Table 2), and compensated current control against open-loop
# voltage control (Section 7, Figures 2–11). Datasets take part when their DAQ records the
# current drive and they run the Ronkanen catalogue; the others skip the stage.


rule powerloss_identify:
    """R from the static hold (Section 4), X and a from every ramp (Table 1, Section 5)."""
    input:
        hold=RAW / "{dataset}" / "rk_static_hold.nc",
        ramps=lambda w: captures(w.dataset, "rk_ramp_"),
        library=library_sources("powerloss_identify"),
    output:
        ramps=ronkanen_report(f"{POWERLOSS}/ramps.csv", "ramps"),
        table_1=ronkanen_report(f"{POWERLOSS}/table_1.csv", "table_1"),
        identified=ronkanen_report(f"{POWERLOSS}/identified.csv", "identified"),
    params:
        hold_start=lambda w: first_segment_end(w.dataset, "rk_static_hold"),
        velocity_window=2.0,
    log:
        "logs/{dataset}/powerloss_identify.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_identify.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=10,
    script:
        "../scripts/powerloss_identify.py"


rule powerloss_table_2:
    """Table 2: models (7)–(11) fitted to the paper's Table 1 and to the identified impedances."""
    input:
        table_1=f"{POWERLOSS}/table_1.csv",
        identified=f"{POWERLOSS}/identified.csv",
        library=library_sources("powerloss_table_2"),
    output:
        table=ronkanen_report(f"{POWERLOSS}/table_2.csv", "table_2"),
    log:
        "logs/{dataset}/powerloss_table_2.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_table_2.tsv"
    threads: 1
    resources:
        mem_mb=300,
        runtime=5,
    script:
        "../scripts/powerloss_table_2.py"


rule powerloss_performance:
    """Hysteresis, drift, repeatability and max error: current vs open-loop voltage control."""
    input:
        unpack(pair_captures),
        identified=f"{POWERLOSS}/identified.csv",
        library=library_sources("powerloss_performance"),
    output:
        performance=ronkanen_report(f"{POWERLOSS}/performance.csv", "performance"),
        repeatability=ronkanen_report(f"{POWERLOSS}/repeatability.csv", "repeatability"),
    params:
        drift_start=lambda w: first_segment_end(w.dataset, RONKANEN_PAIRS["drift"]["current"]),
        drift_duration=120.0,
    log:
        "logs/{dataset}/powerloss_performance.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_performance.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=10,
    script:
        "../scripts/powerloss_performance.py"


rule powerloss_figures:
    """Figures 2–11 of the paper from the captures and the identified constants."""
    input:
        unpack(pair_captures),
        hold=RAW / "{dataset}" / "rk_static_hold.nc",
        ramps=[RAW / "{dataset}" / f"{e}.nc" for e in RONKANEN_VELOCITY_RAMPS],
        table_1=f"{POWERLOSS}/table_1.csv",
        table_2=f"{POWERLOSS}/table_2.csv",
        identified=f"{POWERLOSS}/identified.csv",
        library=library_sources("powerloss_figures"),
    output:
        figures=[ronkanen_report(f"figures/{{dataset}}/{name}.png", f"fig_{n}") for n, name in RONKANEN_FIGURES.items()],
    params:
        out_dir=lambda w: f"figures/{w.dataset}",
        velocity_window=2.0,
        drift_start=lambda w: first_segment_end(w.dataset, RONKANEN_PAIRS["drift"]["current"]),
    log:
        "logs/{dataset}/powerloss_figures.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_figures.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=10,
    script:
        "../scripts/powerloss_figures.py"


rule powerloss_recovery:
    """Identified R, a, X and c against the twin's true parameters (twin validation)."""
    input:
        capture=RAW / "{dataset}" / "rk_static_hold.nc",
        identified=f"{POWERLOSS}/identified.csv",
        table_1=f"{POWERLOSS}/table_1.csv",
        table_2=f"{POWERLOSS}/table_2.csv",
        library=library_sources("powerloss_recovery"),
    output:
        table=ronkanen_report(f"{POWERLOSS}/recovery.csv", "recovery"),
    log:
        "logs/{dataset}/powerloss_recovery.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_recovery.tsv"
    threads: 1
    resources:
        mem_mb=300,
        runtime=5,
    script:
        "../scripts/powerloss_recovery.py"
