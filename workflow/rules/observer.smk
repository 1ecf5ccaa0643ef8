# Stage "observer" (thesis Chapter 5): charge self-sensing a0, the hybrid position observer,
# Tables 5.3–5.4, Figures 5.1–5.14; and stage "frequency_response": x/q of Fig 5.3. Which datasets
# run each: the stage plan (OBSERVER_DATASETS, FREQUENCY_RESPONSE_DATASETS in common.smk).


rule charge_sensing:
    """a0 from q–x over 10–300 Hz (Eq 5.3) and the observer gains of Table 5.3 (Eq 5.9)."""
    input:
        series=lambda w: [
            f"results/{w.dataset}/ripple/{e}.nc" for e in CHARGE_SINES[w.dataset].values()
        ],
        library=library_sources("charge_sensing"),
    output:
        charge_sensing=report(
            "results/{dataset}/ch5/charge_sensing.csv",
            caption="../report/charge_sensing.rst",
            category="{dataset}",
            subcategory="Chapter 5",
        ),
        table_5_3=report(
            "results/{dataset}/ch5/table_5_3.csv",
            caption="../report/table_5_3.rst",
            category="{dataset}",
            subcategory="Chapter 5",
        ),
        observer="results/{dataset}/ch5/observer.json",
    log:
        "logs/{dataset}/charge_sensing.log",
    benchmark:
        "benchmarks/out/{dataset}/charge_sensing.tsv"
    threads: 1
    resources:
        **resources_for("large"),
    params:
        frequencies=lambda w: {e: f for f, e in CHARGE_SINES[w.dataset].items()},
        omega_s=config["observer"]["omega_s"],
        zeta_s=config["observer"]["zeta_s"],
    script:
        "../scripts/charge_sensing.py"


rule observe:
    """The self-sensing chain (ripple → Γ → HPO) over one capture, streamed."""
    input:
        unpack(lambda w: captures(w.dataset, capture=w.experiment)),
        gamma="results/{dataset}/ch5/gamma.json",
        observer="results/{dataset}/ch5/observer.json",
        library=library_sources("observe"),
    output:
        traces="results/{dataset}/observer/{experiment}.nc",
        stats="results/{dataset}/observer/{experiment}.json",
    log:
        "logs/{dataset}/observe/{experiment}.log",
    benchmark:
        "benchmarks/out/{dataset}/observe/{experiment}.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        n_periods=config["ripple"]["n_periods"],
        transient_s=lambda w: (
            config["observer"]["creep_transient_s"]
            if w.experiment in role_runs(w.dataset, "observer.creep")
            else None
        ),
    script:
        "../scripts/observe.py"


rule ch5_tables:
    """Table 5.4 (open-loop observer error) and the creep run's errors."""
    input:
        stats=lambda w: [
            f"results/{w.dataset}/observer/{e}.json" for e in OBSERVED_SINES[w.dataset].values()
        ],
        creep_traces=role_path("results/{dataset}/observer/{run}.nc", "observer.creep"),
        creep_stats=role_path("results/{dataset}/observer/{run}.json", "observer.creep"),
        library=library_sources("ch5_tables"),
    output:
        table=report(
            "results/{dataset}/ch5/table_5_4.csv",
            caption="../report/table_5_4.rst",
            category="{dataset}",
            subcategory="Chapter 5",
        ),
        creep=report(
            "results/{dataset}/ch5/creep.csv",
            caption="../report/creep.rst",
            category="{dataset}",
            subcategory="Chapter 5",
        ),
    log:
        "logs/{dataset}/ch5_tables.log",
    benchmark:
        "benchmarks/out/{dataset}/ch5_tables.tsv"
    threads: 1
    resources:
        **resources_for("large"),
    params:
        frequencies=lambda w: {e: f for f, e in OBSERVED_SINES[w.dataset].items()},
    script:
        "../scripts/ch5_tables.py"


rule observer_study:
    """Beyond the thesis: observer error against ω_S and the offset current (1 Hz capture)."""
    input:
        unpack(lambda w: captures(w.dataset, capture=role_run(w.dataset, "observer.study"))),
        gamma="results/{dataset}/ch5/gamma.json",
        observer="results/{dataset}/ch5/observer.json",
        library=library_sources("observer_study"),
    output:
        table=report(
            "results/{dataset}/ch5/observer_study.csv",
            caption="../report/observer_study.rst",
            category="{dataset}",
            subcategory="Chapter 5",
        ),
        figure=report_figure(OBSERVER_STUDY_FIGURE, "Chapter 5"),
    log:
        "logs/{dataset}/observer_study.log",
    benchmark:
        "benchmarks/out/{dataset}/observer_study.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        pdf=FIGURE_PDF,
        omegas=config["observer"]["study_omegas"],
        offsets=config["observer"]["study_offsets"],
        n_periods=config["ripple"]["n_periods"],
    script:
        "../scripts/observer_study.py"


rule ch5_figures:
    """Figures 5.1, 5.2, 5.4–5.8, 5.10, 5.12–5.14."""
    input:
        unpack(lambda w: captures(w.dataset, gamma_capture=role_run(w.dataset, "gamma.fit"))),  # its warm-up, left out of the Γ fits
        series=role_paths("results/{dataset}/ripple/{run}.nc", "observer.sine"),
        gamma_series=role_path("results/{dataset}/ripple/{run}.nc", "gamma.fit"),
        traces=lambda w: [
            f"results/{w.dataset}/observer/{e}.nc" for e in OBSERVED_SINES[w.dataset].values()
        ],
        creep=role_path("results/{dataset}/observer/{run}.nc", "observer.creep"),
        observer="results/{dataset}/ch5/observer.json",
        library=library_sources("ch5_figures"),
    output:
        **{name: report_figure(name, "Chapter 5") for name in CH5_FIGURES},
    log:
        "logs/{dataset}/ch5_figures.log",
    benchmark:
        "benchmarks/out/{dataset}/ch5_figures.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        pdf=FIGURE_PDF,
        series_f=lambda w: {e: f for f, e in by_frequency(w.dataset, "observer.sine").items()},
        traces_f=lambda w: {e: f for f, e in OBSERVED_SINES[w.dataset].items()},
        n_periods=config["ripple"]["n_periods"],
        orders=config["gamma"]["orders"],
    script:
        "../scripts/ch5_figures.py"


rule frequency_response:
    """Fig 5.3: G(s) = x/q (Eq 5.2) from the stepped-sine sweep against the identified model."""
    input:
        unpack(
            lambda w: captures(w.dataset, capture=role_run(w.dataset, "frequency_response.sweep"))
        ),
        model="results/{dataset}/ch4/model.json",
        library=library_sources("frequency_response"),
    output:
        table=report(
            "results/{dataset}/ch5/frequency_response.csv",
            caption="../report/frequency_response.rst",
            category="{dataset}",
            subcategory="Chapter 5",
        ),
        peaks=report(
            "results/{dataset}/ch5/resonance.csv",
            caption="../report/resonance.rst",
            category="{dataset}",
            subcategory="Chapter 5",
        ),
        figure=report_figure(FREQUENCY_RESPONSE_FIGURE, "Chapter 5"),
    log:
        "logs/{dataset}/frequency_response.log",
    benchmark:
        "benchmarks/out/{dataset}/frequency_response.tsv"
    threads: 1
    resources:
        **resources_for("medium"),
    params:
        pdf=FIGURE_PDF,
        protocol=lambda w: EXPERIMENTS[w.dataset][
            role_run(w.dataset, "frequency_response.sweep")
        ].protocol,
        settle_s=config["observer"]["sweep_settle_s"],
    script:
        "../scripts/frequency_response.py"


#: what the stages make for rule all and the scorecard: their rules' outputs, for the datasets each runs for
OBSERVER_OUTPUTS = expand(
    rules.frequency_response.output, dataset=FREQUENCY_RESPONSE_DATASETS
) + expand(
    [
        *rules.charge_sensing.output,
        *rules.ch5_tables.output,
        *rules.observer_study.output,
        *rules.ch5_figures.output,
    ],
    dataset=OBSERVER_DATASETS,
)
