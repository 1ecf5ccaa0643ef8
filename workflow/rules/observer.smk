# Stage "observer" (thesis Chapter 5): charge self-sensing a0, the hybrid position observer,
# Tables 5.3–5.4, Figures 5.1–5.14, and the frequency response x/q of Fig 5.3.

from selfsense.chapters.figure_names import CH5 as CH5_FIGURES, CH5_BUDGET as ERROR_BUDGET_FIGURE, CH5_STUDY as OBSERVER_STUDY_FIGURE
from selfsense.chapters.figure_names import CH5_SWEEP as FREQUENCY_RESPONSE_FIGURE

TABLE_5_4_HZ = (0.01, 0.1, 1.0, 10.0, 50.0, 100.0)

#: {frequency [Hz]: experiment} of the 10–300 Hz sines a0 is fitted on (Eq 5.3)
CHARGE_SINES = {d: {f: e for f, e in sines(d, "ch5_sine_").items() if f >= 10} for d in DATASETS}

#: {frequency [Hz]: experiment} of the sines the observer is evaluated on (Table 5.4)
OBSERVED_SINES = {d: {f: e for f, e in sines(d, "ch5_sine_").items() if f in TABLE_5_4_HZ} for d in DATASETS}

#: {experiment: Table 5.4 frequency [Hz], None for the creep run} of every open-loop run the observer is evaluated on
OBSERVED_RUNS = {d: {e: f for f, e in OBSERVED_SINES[d].items()} | {"ch5_creep": None} for d in DATASETS}

#: the closed-loop runs whose observer error Chapter 6 tabulates (ε_OCL: P1 in Table 6.1, P2a–d in
#: Table 6.2), which the error budget splits too
CH6_BUDGET_RUNS = {d: [e for e, x in EXPERIMENTS[d].items() if x is not None and x.control == "closed_loop"
                       and e.startswith(("ch6_p1_", "ch6_p2"))] for d in DATASETS}

#: {experiment: Table 5.4 frequency [Hz] or None} of every run the error budget splits
BUDGET_RUNS = {d: OBSERVED_RUNS[d] | dict.fromkeys(CH6_BUDGET_RUNS[d]) for d in DATASETS}

OBSERVER_DATASETS = [d for d in GAMMA_DATASETS if CHARGE_SINES[d] and "ch5_creep" in EXPERIMENTS[d]
                     and len(OBSERVED_SINES[d]) == len(TABLE_5_4_HZ)]

#: datasets with the identified model (Chapter 4) and the stepped-sine sweep ch5_sweep
FREQUENCY_RESPONSE_DATASETS = [d for d in IDENTIFY_DATASETS if EXPERIMENTS[d].get("ch5_sweep") is not None]


rule charge_sensing:
    """a0 from q–x over 10–300 Hz (Eq 5.3) and the observer gains of Table 5.3 (Eq 5.9)."""
    input:
        series=lambda w: [f"results/{w.dataset}/ripple/{e}.nc" for e in CHARGE_SINES[w.dataset].values()],
        library=library_sources("charge_sensing"),
    output:
        charge_sensing=report("results/{dataset}/ch5/charge_sensing.csv", caption="../report/charge_sensing.rst",
                              category="{dataset}", subcategory="Chapter 5"),
        table_5_3=report("results/{dataset}/ch5/table_5_3.csv", caption="../report/table_5_3.rst",
                         category="{dataset}", subcategory="Chapter 5"),
        observer="results/{dataset}/ch5/observer.json",
    params:
        frequencies=lambda w: list(CHARGE_SINES[w.dataset]),
        omega_s=config["observer"]["omega_s"],
        zeta_s=config["observer"]["zeta_s"],
    log:
        "logs/{dataset}/charge_sensing.log",
    benchmark:
        "benchmarks/out/{dataset}/charge_sensing.tsv"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
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
    params:
        n_periods=config["ripple"]["n_periods"],
        transient_s=lambda w: config["observer"]["creep_transient_s"] if w.experiment == "ch5_creep" else None,
    log:
        "logs/{dataset}/observe/{experiment}.log",
    benchmark:
        "benchmarks/out/{dataset}/observe/{experiment}.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=30,
    script:
        "../scripts/observe.py"


rule ch5_tables:
    """Table 5.4 (open-loop observer error) and the creep run's errors."""
    input:
        stats=lambda w: [f"results/{w.dataset}/observer/{e}.json" for e in OBSERVED_SINES[w.dataset].values()],
        creep="results/{dataset}/observer/ch5_creep.nc",
        creep_stats="results/{dataset}/observer/ch5_creep.json",
        library=library_sources("ch5_tables"),
    output:
        table=report("results/{dataset}/ch5/table_5_4.csv", caption="../report/table_5_4.rst",
                     category="{dataset}", subcategory="Chapter 5"),
        creep=report("results/{dataset}/ch5/creep.csv", caption="../report/creep.rst",
                     category="{dataset}", subcategory="Chapter 5"),
    params:
        frequencies=lambda w: list(OBSERVED_SINES[w.dataset]),
    log:
        "logs/{dataset}/ch5_tables.log",
    benchmark:
        "benchmarks/out/{dataset}/ch5_tables.tsv"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=10,
    script:
        "../scripts/ch5_tables.py"


rule observer_study:
    """Beyond the thesis: observer error against ω_S and the offset current (1 Hz capture)."""
    input:
        unpack(lambda w: captures(w.dataset, capture="ch5_sine_1hz")),
        gamma="results/{dataset}/ch5/gamma.json",
        observer="results/{dataset}/ch5/observer.json",
        library=library_sources("observer_study"),
    output:
        table=report("results/{dataset}/ch5/observer_study.csv", caption="../report/observer_study.rst",
                     category="{dataset}", subcategory="Chapter 5"),
        figure=report_figure(OBSERVER_STUDY_FIGURE, "Chapter 5"),
    params:
        omegas=config["observer"]["study_omegas"],
        offsets=config["observer"]["study_offsets"],
        n_periods=config["ripple"]["n_periods"],
    log:
        "logs/{dataset}/observer_study.log",
    benchmark:
        "benchmarks/out/{dataset}/observer_study.tsv"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=30,
    script:
        "../scripts/observer_study.py"


rule error_budget:
    """The observer's error of Table 5.4 (and Chapter 6's ε_OCL, Tables 6.1–6.2) split into its
    sources with the twin's truth (verification)."""
    input:
        unpack(lambda w: captures(w.dataset, captures=list(BUDGET_RUNS[w.dataset]))),
        gamma="results/{dataset}/ch5/gamma.json",
        observer="results/{dataset}/ch5/observer.json",
        library=library_sources("error_budget"),
    output:
        table=report("results/{dataset}/twin/error_budget.csv", caption="../report/error_budget.rst",
                     category="{dataset}", subcategory="Twin validation"),
        figure=report_figure(ERROR_BUDGET_FIGURE, "Twin validation"),
    params:
        frequencies=lambda w: list(BUDGET_RUNS[w.dataset].values()),
        # Chapter 6 counts from the loop's settling on (its ω_C), in P1's segments; Table 5.4 from the warm-up on
        loop_omega_c=lambda w: [config["control"]["omega_c"] if e in CH6_BUDGET_RUNS[w.dataset] else None
                                for e in BUDGET_RUNS[w.dataset]],
        p1_protocols=lambda w: [dict(EXPERIMENTS[w.dataset][e].protocol) if e.startswith("ch6_p1_") else None
                                for e in BUDGET_RUNS[w.dataset]],
        transient_s=lambda w: [config["observer"]["creep_transient_s"] if e == "ch5_creep" else None
                               for e in BUDGET_RUNS[w.dataset]],
        n_periods=config["ripple"]["n_periods"],
    log:
        "logs/{dataset}/error_budget.log",
    benchmark:
        "benchmarks/out/{dataset}/error_budget.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=30,
    script:
        "../scripts/error_budget.py"


rule charge_budget:
    """Fig 5.2's charge–position error split into its sources with the twin's truth (verification)."""
    input:
        unpack(lambda w: captures(w.dataset, capture=list(CHARGE_SINES[w.dataset].values()))),
        series=lambda w: [f"results/{w.dataset}/ripple/{e}.nc" for e in CHARGE_SINES[w.dataset].values()],
        library=library_sources("charge_budget"),
    output:
        table=report("results/{dataset}/twin/charge_budget.csv", caption="../report/charge_budget.rst",
                     category="{dataset}", subcategory="Twin validation"),
    params:
        frequencies=lambda w: list(CHARGE_SINES[w.dataset]),
        n_periods=config["ripple"]["n_periods"],
    log:
        "logs/{dataset}/charge_budget.log",
    benchmark:
        "benchmarks/out/{dataset}/charge_budget.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=10,
    script:
        "../scripts/charge_budget.py"


rule ch5_figures:
    """Figures 5.1, 5.2, 5.4–5.8, 5.10, 5.12–5.14."""
    input:
        unpack(lambda w: captures(w.dataset, gamma_capture=GAMMA_RUN)),  # its warm-up, left out of the Γ fits
        series=lambda w: [f"results/{w.dataset}/ripple/{e}.nc" for e in sines(w.dataset, "ch5_sine_").values()],
        gamma_series=f"results/{{dataset}}/ripple/{GAMMA_RUN}.nc",
        traces=lambda w: [f"results/{w.dataset}/observer/{e}.nc" for e in OBSERVED_SINES[w.dataset].values()],
        creep="results/{dataset}/observer/ch5_creep.nc",
        observer="results/{dataset}/ch5/observer.json",
        library=library_sources("ch5_figures"),
    output:
        **{name: report_figure(name, "Chapter 5") for name in CH5_FIGURES},
    params:
        series_f=lambda w: list(sines(w.dataset, "ch5_sine_")),
        traces_f=lambda w: list(OBSERVED_SINES[w.dataset]),
        n_periods=config["ripple"]["n_periods"],
        orders=config["gamma"]["orders"],
    log:
        "logs/{dataset}/ch5_figures.log",
    benchmark:
        "benchmarks/out/{dataset}/ch5_figures.tsv"
    threads: 1
    resources:
        mem_mb=1500,
        runtime=10,
    script:
        "../scripts/ch5_figures.py"


rule frequency_response:
    """Fig 5.3: G(s) = x/q (Eq 5.2) from the stepped-sine sweep against the identified model."""
    input:
        unpack(lambda w: captures(w.dataset, capture="ch5_sweep")),
        model="results/{dataset}/ch4/model.json",
        library=library_sources("frequency_response"),
    output:
        table=report("results/{dataset}/ch5/frequency_response.csv", caption="../report/frequency_response.rst",
                     category="{dataset}", subcategory="Chapter 5"),
        peaks=report("results/{dataset}/ch5/resonance.csv", caption="../report/resonance.rst",
                     category="{dataset}", subcategory="Chapter 5"),
        figure=report_figure(FREQUENCY_RESPONSE_FIGURE, "Chapter 5"),
    params:
        protocol=lambda w: EXPERIMENTS[w.dataset]["ch5_sweep"].protocol,
        settle_s=config["observer"]["sweep_settle_s"],
    log:
        "logs/{dataset}/frequency_response.log",
    benchmark:
        "benchmarks/out/{dataset}/frequency_response.tsv"
    threads: 1
    resources:
        mem_mb=500,
        runtime=5,
    script:
        "../scripts/frequency_response.py"


#: what the stage makes for rule all and the scorecard: its rules' outputs, for the datasets each runs for
OBSERVER_OUTPUTS = (
    expand(rules.frequency_response.output, dataset=FREQUENCY_RESPONSE_DATASETS)
    + expand([*rules.charge_sensing.output, *rules.ch5_tables.output, *rules.observer_study.output,
              *rules.ch5_figures.output], dataset=OBSERVER_DATASETS)
    + expand([*rules.error_budget.output, *rules.charge_budget.output],
             dataset=[d for d in OBSERVER_DATASETS if d in SIMULATED])  # read /truth
)
