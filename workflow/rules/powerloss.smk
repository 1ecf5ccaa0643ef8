# Stage "powerloss" (Ronkanen 2002): R from the static hold, the loss impedance from the ramps
# (Table 1), the impedance models (Table 2), and compensated current control against open-loop
# voltage control (Section 7, Figures 2–11). Datasets take part when their DAQ records the
# current drive and they run the Ronkanen catalogue: the stage plan (POWERLOSS_DATASETS in
# common.smk); the others skip the stage.


rule powerloss_identify:
    """R from the static hold (Section 4), X and a from every ramp (Table 1, Section 5). Only
    captures with fixed settings (none, a trial impedance): the Eq 15 runs read what this and
    powerloss_table_2 (c of model (10)) identify (rule simulate)."""
    input:
        unpack(lambda w: captures(w.dataset, **identification_runs(w.dataset))),
        library=library_sources("powerloss_identify"),
    output:
        ramp_table=report(
            f"{POWERLOSS}/ramps.csv", caption="../report/ronkanen_ramps.rst", **RONKANEN_REPORT
        ),
        table_1=report(
            f"{POWERLOSS}/table_1.csv", caption="../report/ronkanen_table_1.rst", **RONKANEN_REPORT
        ),
        identified=report(
            f"{POWERLOSS}/identified.csv",
            caption="../report/ronkanen_identified.rst",
            **RONKANEN_REPORT,
        ),
    log:
        "logs/{dataset}/powerloss_identify.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_identify.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        hold_start=lambda w: first_segment_end(w.dataset, "powerloss.hold"),
        velocity_window=config["powerloss"]["velocity_window_s"],
    script:
        "../scripts/powerloss_identify.py"


rule powerloss_table_2:
    """Table 2: models (7)–(11) fitted to the paper's Table 1 and to the identified impedances."""
    input:
        table_1=f"{POWERLOSS}/table_1.csv",
        identified=f"{POWERLOSS}/identified.csv",
        library=library_sources("powerloss_table_2"),
    output:
        table=report(
            f"{POWERLOSS}/table_2.csv", caption="../report/ronkanen_table_2.rst", **RONKANEN_REPORT
        ),
    log:
        "logs/{dataset}/powerloss_table_2.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_table_2.tsv"
    threads: 1
    resources:
        **resources_for("small"),
    script:
        "../scripts/powerloss_table_2.py"


rule powerloss_performance:
    """Hysteresis, drift, repeatability and max error: current vs open-loop voltage control."""
    input:
        unpack(
            lambda w: captures(
                w.dataset, captures=list(ronkanen_runs(w.dataset, stages.RONKANEN_PAIRS).values())
            )
        ),
        identified=f"{POWERLOSS}/identified.csv",
        library=library_sources("powerloss_performance"),
    output:
        performance=report(
            f"{POWERLOSS}/performance.csv",
            caption="../report/ronkanen_performance.rst",
            **RONKANEN_REPORT,
        ),
        repeatability=report(
            f"{POWERLOSS}/repeatability.csv",
            caption="../report/ronkanen_repeatability.rst",
            **RONKANEN_REPORT,
        ),
    log:
        "logs/{dataset}/powerloss_performance.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_performance.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        drift_start=lambda w: first_segment_end(w.dataset, "powerloss.drift_current"),
        drift_duration=config["powerloss"]["drift_duration_s"],
        pairs=lambda w: ronkanen_runs(w.dataset, stages.RONKANEN_PAIRS),
    script:
        "../scripts/powerloss_performance.py"


rule powerloss_figures:
    """Figures 2–11 of the paper from the captures and the identified constants."""
    input:
        unpack(
            lambda w: captures(
                w.dataset,
                hold=role_run(w.dataset, "powerloss.hold"),
                ramps=[role_run(w.dataset, r) for r in stages.RONKANEN_VELOCITY_RAMPS],
                captures=list(ronkanen_runs(w.dataset, stages.RONKANEN_PAIRS).values()),
            )
        ),
        table_1=f"{POWERLOSS}/table_1.csv",
        table_2=f"{POWERLOSS}/table_2.csv",
        identified=f"{POWERLOSS}/identified.csv",
        library=library_sources("powerloss_figures"),
    output:
        **{
            name: report(
                f"figures/{{dataset}}/{name}.png",
                caption=f"../report/ronkanen_fig_{n}.rst",
                **RONKANEN_REPORT,
            )
            for n, name in RONKANEN_FIGURES.items()
        },
    log:
        "logs/{dataset}/powerloss_figures.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_figures.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        pdf=FIGURE_PDF,
        velocity_window=config["powerloss"]["velocity_window_s"],
        drift_start=lambda w: first_segment_end(w.dataset, "powerloss.drift_current"),
        pairs=lambda w: ronkanen_runs(w.dataset, stages.RONKANEN_PAIRS),
    script:
        "../scripts/powerloss_figures.py"


#: what the stage makes for rule all and the scorecard: its rules' outputs, for the datasets it runs for
POWERLOSS_OUTPUTS = expand(
    [
        *rules.powerloss_identify.output,
        *rules.powerloss_table_2.output,
        *rules.powerloss_performance.output,
        *rules.powerloss_figures.output,
    ],
    dataset=POWERLOSS_DATASETS,
)
