# Stage "thermal" (thesis Chapter 7): loss power, the thermal model (Table 7.1), Γ_T (Tables 7.2,
# 7.3), the frequency effect on C_e–x, the coupled observer/thermal estimation, Figures 7.1–7.12.
# Which datasets run it: the stage plan (THERMAL_DATASETS in common.smk).


rule thermal_extract:
    """Loss power per 0.1 s with the IR temperatures, and C_e/x samples for Γ_T (streamed)."""
    input:
        unpack(lambda w: captures(w.dataset, capture=w.experiment)),
        model="results/{dataset}/ch4/model.json",
        library=library_sources("thermal_extract"),
    output:
        power="results/{dataset}/thermal/{experiment}.nc",
        samples="results/{dataset}/thermal/{experiment}_gamma.nc",
    log:
        "logs/{dataset}/thermal_extract/{experiment}.log",
    benchmark:
        "benchmarks/out/{dataset}/thermal_extract/{experiment}.tsv"
    threads: 1
    resources:
        **resources_for("stream_long"),
    params:
        n_periods=config["ripple"]["n_periods"],
        interval=config["thermal"]["power_interval_s"],
        every=config["thermal"]["gamma_t_every"],
    script:
        "../scripts/thermal_extract.py"


rule thermal_identify:
    """τ, γ, k_T per heating run and Table 7.1, the trend with frequency: the thermal model, from
    the heating runs alone."""
    input:
        freq_series=role_paths("results/{dataset}/thermal/{run}.nc", "thermal.heating"),
        manifest=RAW / "{dataset}" / "dataset.yaml",
        model="results/{dataset}/ch4/model.json",
        library=library_sources("thermal_identify"),
    output:
        **report_tables("ch7", THERMAL_TABLES, "Chapter 7"),
        **{name: report_figure(name, "Chapter 7") for name in THERMAL_FIGURES},
        thermal_model="results/{dataset}/ch7/thermal_model.json",
    log:
        "logs/{dataset}/thermal_identify.log",
    benchmark:
        "benchmarks/out/{dataset}/thermal_identify.tsv"
    threads: 1
    resources:
        **resources_for("large"),
    params:
        pdf=FIGURE_PDF,
        freqs=lambda w: {e: f for f, e in by_frequency(w.dataset, "thermal.heating").items()},
    script:
        "../scripts/thermal_identify.py"


rule thermal_checks:
    """The thermal model against the runs it was not identified on: the trend with V², the check
    runs' predicted temperatures (a member that reads neither skips their records)."""
    input:
        volt_series=role_path("results/{dataset}/thermal/{run}.nc", "thermal.voltage"),
        checks=role_paths("results/{dataset}/thermal/{run}.nc", "thermal.check"),
        thermal_model="results/{dataset}/ch7/thermal_model.json",
        library=library_sources("thermal_checks"),
    output:
        **report_tables("ch7", THERMAL_CHECK_TABLES, "Chapter 7"),
        **{name: report_figure(name, "Chapter 7") for name in THERMAL_CHECK_FIGURES},
    log:
        "logs/{dataset}/thermal_checks.log",
    benchmark:
        "benchmarks/out/{dataset}/thermal_checks.tsv"
    threads: 1
    resources:
        **resources_for("large"),
    params:
        pdf=FIGURE_PDF,
        volt_segments=lambda w: EXPERIMENTS[w.dataset][
            role_run(w.dataset, "thermal.voltage")
        ].protocol["segments"],
    script:
        "../scripts/thermal_checks.py"


rule gamma_t_fit:
    """Γ_T of orders 4–6 with temperature, and with a C·T interaction, on the 50 Hz run (Tables
    7.2, 7.3 at the thesis's n = 5); the order of the Γ_T used downstream validated on the 100 Hz run.
    """
    input:
        samples=role_path("results/{dataset}/thermal/{run}_gamma.nc", "thermal.gamma_t_fit"),
        power=role_path("results/{dataset}/thermal/{run}.nc", "thermal.gamma_t_fit"),
        val_samples=role_path(
            "results/{dataset}/thermal/{run}_gamma.nc", "thermal.gamma_t_validation"
        ),
        val_power=role_path("results/{dataset}/thermal/{run}.nc", "thermal.gamma_t_validation"),
        library=library_sources("gamma_t_fit"),
    output:
        **{
            k: report(
                f"results/{{dataset}}/ch7/{v}",
                caption=f"../report/{k}_t.rst",
                category="{dataset}",
                subcategory="Chapter 7",
            )
            for k, v in GAMMA_T_TABLES.items()
        },
        gamma_t="results/{dataset}/ch7/gamma_t.json",
        gamma_t_n5="results/{dataset}/ch7/gamma_t_n5.json",
        figure=report_figure(GAMMA_T_FIGURE, "Chapter 7"),
    log:
        "logs/{dataset}/gamma_t_fit.log",
    benchmark:
        "benchmarks/out/{dataset}/gamma_t_fit.tsv"
    threads: 1
    resources:
        **resources_for("large"),
    params:
        pdf=FIGURE_PDF,
        orders=config["thermal"]["gamma_t_orders"],
        gamma_t_order=config["thermal"]["gamma_t_order"],
        candidates=config["thermal"]["gamma_t_candidates"],
        spans=lambda w: [
            drive_span(w.dataset, role)
            for role in ("thermal.gamma_t_fit", "thermal.gamma_t_validation")
        ],
    script:
        "../scripts/gamma_t_fit.py"


rule frequency_effect:
    """Figure 7.8: C_e–x at each Chapter 5 drive frequency against Γ, beside each run's temperature."""
    input:
        unpack(lambda w: captures(w.dataset, captures=role_runs(w.dataset, "observer.sine"))),
        series=role_paths("results/{dataset}/ripple/{run}.nc", "observer.sine"),
        gamma="results/{dataset}/ch5/gamma.json",
        gamma_t="results/{dataset}/ch7/gamma_t.json",
        library=library_sources("frequency_effect"),
    output:
        table=report(
            "results/{dataset}/ch7/frequency_effect.csv",
            caption="../report/frequency_effect.rst",
            category="{dataset}",
            subcategory="Chapter 7",
        ),
        figure=report_figure(FREQUENCY_FIGURE, "Chapter 7"),
    log:
        "logs/{dataset}/frequency_effect.log",
    benchmark:
        "benchmarks/out/{dataset}/frequency_effect.tsv"
    threads: 1
    resources:
        **resources_for("large"),
    params:
        pdf=FIGURE_PDF,
        frequencies=lambda w: {
            e: drive_frequency(w.dataset, e) for e in role_runs(w.dataset, "observer.sine")
        },
        reference=lambda w: role_run(w.dataset, "gamma.fit"),
        bins=config["thermal"]["frequency_effect_bins"],
        min_windows=config["thermal"]["frequency_effect_min_windows"],
    script:
        "../scripts/frequency_effect.py"


rule estimator_diagram:
    """Figure 7.9: block diagrams of the coupled estimation, annotated with the identified values."""
    input:
        gamma_t="results/{dataset}/ch7/gamma_t.json",
        observer="results/{dataset}/ch5/observer.json",
        thermal_model="results/{dataset}/ch7/thermal_model.json",
        model="results/{dataset}/ch4/model.json",
        library=library_sources("estimator_diagram"),
    output:
        figure=report_figure(DIAGRAM_FIGURE, "Chapter 7"),
    log:
        "logs/{dataset}/estimator_diagram.log",
    benchmark:
        "benchmarks/out/{dataset}/estimator_diagram.tsv"
    threads: 1
    resources:
        **resources_for("medium"),
    params:
        pdf=FIGURE_PDF,
        fs=lambda w: DATASETS[w.dataset]["daq"]["fs"],
        fr=lambda w: DATASETS[w.dataset]["daq"]["ripple"]["fr_nominal"],
        ns=lambda w: DATASETS[w.dataset]["daq"]["ripple"]["ns"],
        n_periods=config["ripple"]["n_periods"],
    script:
        "../scripts/estimator_diagram.py"


rule coupled:
    """Temperature-compensated observer coupled with the thermal model over one run (Fig 7.9)."""
    input:
        unpack(lambda w: captures(w.dataset, capture=w.experiment)),
        power="results/{dataset}/thermal/{experiment}.nc",
        gamma_t="results/{dataset}/ch7/gamma_t.json",
        observer="results/{dataset}/ch5/observer.json",
        thermal_model="results/{dataset}/ch7/thermal_model.json",
        model="results/{dataset}/ch4/model.json",
        library=library_sources("coupled"),
    output:
        traces="results/{dataset}/ch7/coupled/{experiment}.nc",
        stats="results/{dataset}/ch7/coupled/{experiment}.json",
    log:
        "logs/{dataset}/coupled/{experiment}.log",
    benchmark:
        "benchmarks/out/{dataset}/coupled/{experiment}.tsv"
    threads: 1
    resources:
        **resources_for("stream_long"),
    params:
        n_periods=config["ripple"]["n_periods"],
    script:
        "../scripts/coupled.py"


rule ch7_summary:
    """Coupled-estimation errors beside the thesis, Figures 7.10–7.12."""
    input:
        stats=lambda w: [
            f"results/{w.dataset}/ch7/coupled/{e}.json" for e in coupled_runs(w.dataset)
        ],
        traces=lambda w: [
            f"results/{w.dataset}/ch7/coupled/{e}.nc" for e in coupled_runs(w.dataset)
        ],
        library=library_sources("ch7_summary"),
    output:
        **{name: report_figure(name, "Chapter 7") for name in COUPLED_FIGURES},
        coupled=report(
            "results/{dataset}/ch7/coupled.csv",
            caption="../report/coupled.rst",
            category="{dataset}",
            subcategory="Chapter 7",
        ),
    log:
        "logs/{dataset}/ch7_summary.log",
    benchmark:
        "benchmarks/out/{dataset}/ch7_summary.tsv"
    threads: 1
    resources:
        **resources_for("medium"),
    params:
        pdf=FIGURE_PDF,
        figures=lambda w: dict(zip(COUPLED_FIGURES, coupled_runs(w.dataset))),
    script:
        "../scripts/ch7_summary.py"


#: what the stage makes for rule all and the scorecard: its rules' outputs, for the datasets it runs for
THERMAL_OUTPUTS = expand(
    [
        *rules.thermal_identify.output,
        *rules.thermal_checks.output,
        *rules.gamma_t_fit.output,
        *rules.frequency_effect.output,
        *rules.estimator_diagram.output,
        *rules.ch7_summary.output,
    ],
    dataset=THERMAL_DATASETS,
)
