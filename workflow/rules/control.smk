# Stage "control" (thesis Chapter 6): closed-loop runs on the twin with the real-time HPO, the
# audit of the logged estimate, Tables 6.1–6.2, Figures 6.2–6.8. Which datasets run it: the stage
# plan (CONTROL_DATASETS in common.smk).


if SIMULATED:

    rule simulate_closed_loop:
        """A closed-loop run on the twin; its real-time loop uses the identified Γ, a0 and k/α."""
        input:
            manifest=RAW / "{dataset}" / "dataset.yaml",
            protocol=lambda w: protocol_file(w.dataset, w.experiment),
            gamma="results/{dataset}/ch5/gamma.json",
            observer="results/{dataset}/ch5/observer.json",
            model="results/{dataset}/ch4/model.json",
            library=library_sources("simulate_closed_loop"),
        output:
            capture=RAW / "{dataset}" / "{experiment}.nc",
            report="results/{dataset}/qc/{experiment}.json",
        log:
            "logs/{dataset}/simulate_closed_loop/{experiment}.log",
        benchmark:
            "benchmarks/out/{dataset}/simulate_closed_loop/{experiment}.tsv"
        wildcard_constraints:
            dataset="|".join(SIMULATED),
            experiment="|".join(SIMULATED_CLOSED_LOOP) or "(?!)",  # none: matches no name
        priority: longest_first
        threads: 1
        resources:
            **resources_for("simulate_closed_loop"),
        params:
            campaign=config["campaign"],
            capture_settings=config["capture"],
            omega_c=config["control"]["omega_c"],
            n_periods=config["ripple"]["n_periods"],
        script:
            "../scripts/simulate_closed_loop.py"


rule audit_realtime:
    """Offline HPO from each closed-loop capture's raw channels against the real-time estimate its
    loop logged, one row per run (one job per dataset: each run is a fraction of a job's start-up).
    """
    input:
        unpack(lambda w: captures(w.dataset, captures=CLOSED_LOOP[w.dataset])),
        gamma="results/{dataset}/ch5/gamma.json",
        observer="results/{dataset}/ch5/observer.json",
        library=library_sources("audit_realtime"),
    output:
        table=report(
            "results/{dataset}/ch6/audit.csv",
            caption="../report/audit.rst",
            category="{dataset}",
            subcategory="Chapter 6",
        ),
    log:
        "logs/{dataset}/audit_realtime.log",
    benchmark:
        "benchmarks/out/{dataset}/audit_realtime.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        n_periods=config["ripple"]["n_periods"],
    script:
        "../scripts/audit_realtime.py"


rule ch6_results:
    """Tables 6.1–6.2, P3 and the loop's tracking prediction."""
    input:
        unpack(lambda w: captures(w.dataset, captures=CH6_RUNS[w.dataset])),
        model="results/{dataset}/ch4/model.json",
        library=library_sources("ch6_results"),
    output:
        **report_tables("ch6", CH6_TABLES, "Chapter 6"),
    log:
        "logs/{dataset}/ch6_results.log",
    benchmark:
        "benchmarks/out/{dataset}/ch6_results.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        protocols=lambda w: protocols_of(w.dataset, CH6_RUNS[w.dataset]),
        profiles=lambda w: profile_pairs(w.dataset),
        omega_c=config["control"]["omega_c"],
    script:
        "../scripts/ch6_results.py"


rule ch6_figures:
    """Figures 6.2–6.8 (a job of its own: an envelope member needs the tables only)."""
    input:
        unpack(lambda w: captures(w.dataset, captures=CH6_RUNS[w.dataset])),
        library=library_sources("ch6_figures"),
    output:
        **{name: report_figure(name, "Chapter 6") for name in CH6_FIGURES},
    log:
        "logs/{dataset}/ch6_figures.log",
    benchmark:
        "benchmarks/out/{dataset}/ch6_figures.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        pdf=FIGURE_PDF,
        protocols=lambda w: protocols_of(w.dataset, CH6_RUNS[w.dataset]),
        profiles=lambda w: profile_pairs(w.dataset),
    script:
        "../scripts/ch6_figures.py"


#: what the stage makes for rule all and the scorecard: its rules' outputs, for the datasets it runs for
CONTROL_OUTPUTS = expand(
    [*rules.ch6_results.output, *rules.ch6_figures.output, *rules.audit_realtime.output],
    dataset=CONTROL_DATASETS,
)
