# Stage "control" (thesis Chapter 6): closed-loop runs on the twin with the real-time HPO, the
# audit of the logged estimate, Tables 6.1–6.2, Figures 6.2–6.8.

CH6_TABLES = ["table_6_1", "p1_summary", "table_6_2", "p3", "tracking"]

from selfsense.chapters.figure_names import CH6 as CH6_FIGURES

#: the closed-loop experiments of each dataset (audited against the estimate their loop logged)
CLOSED_LOOP = {d: [e for e, x in EXPERIMENTS[d].items() if x is not None and x.control == "closed_loop"]
               for d in DATASETS}

#: the Chapter 6 runs of each dataset, open and closed loop
CH6_RUNS = {d: [e for e in EXPERIMENTS[d] if e.startswith("ch6_")] for d in DATASETS}

CONTROL_DATASETS = [d for d in OBSERVER_DATASETS if CLOSED_LOOP[d] and d in IDENTIFY_DATASETS]


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
        params:
            campaign=config["campaign"],
            capture=config["capture"],
            omega_c=config["control"]["omega_c"],
            n_periods=config["ripple"]["n_periods"],
        wildcard_constraints:
            dataset="|".join(SIMULATED),
            experiment=r"[A-Za-z0-9_]*_closed[A-Za-z0-9_]*",
        log:
            "logs/{dataset}/simulate_closed_loop/{experiment}.log",
        benchmark:
            "benchmarks/out/{dataset}/simulate_closed_loop/{experiment}.tsv"
        threads: 1
        resources:
            mem_mb=config["resources"]["simulate_mem_mb"],
            runtime=120,
        script:
            "../scripts/simulate_closed_loop.py"


rule audit_realtime:
    """Offline HPO from each closed-loop capture's raw channels against the real-time estimate its
    loop logged, one row per run (one job per dataset: each run is a fraction of a job's start-up)."""
    input:
        unpack(lambda w: captures(w.dataset, capture=CLOSED_LOOP[w.dataset])),
        gamma="results/{dataset}/ch5/gamma.json",
        observer="results/{dataset}/ch5/observer.json",
        library=library_sources("audit_realtime"),
    output:
        table=report("results/{dataset}/ch6/audit.csv", caption="../report/audit.rst", category="{dataset}",
                     subcategory="Chapter 6"),
    params:
        n_periods=config["ripple"]["n_periods"],
    log:
        "logs/{dataset}/audit_realtime.log",
    benchmark:
        "benchmarks/out/{dataset}/audit_realtime.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=30,
    script:
        "../scripts/audit_realtime.py"


rule ch6_results:
    """Tables 6.1–6.2, P3, the loop's tracking prediction, Figures 6.2–6.8."""
    input:
        unpack(lambda w: captures(w.dataset, captures=CH6_RUNS[w.dataset])),
        model="results/{dataset}/ch4/model.json",
        library=library_sources("ch6_results"),
    output:
        **{t: report(f"results/{{dataset}}/ch6/{t}.csv", caption=f"../report/{t}.rst", category="{dataset}",
                     subcategory="Chapter 6") for t in CH6_TABLES},
        **{name: report_figure(name, "Chapter 6") for name in CH6_FIGURES},
    params:
        protocols=lambda w: {e: dict(EXPERIMENTS[w.dataset][e].protocol) for e in CH6_RUNS[w.dataset]},
        controls=lambda w: {e: EXPERIMENTS[w.dataset][e].control for e in CH6_RUNS[w.dataset]},
        omega_c=config["control"]["omega_c"],
    log:
        "logs/{dataset}/ch6_results.log",
    benchmark:
        "benchmarks/out/{dataset}/ch6_results.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=30,
    script:
        "../scripts/ch6_results.py"


#: the runs of Tables 6.1–6.2 whose tracking error the budget splits
TRACKED_RUNS = {d: [e for e in CH6_RUNS[d] if e.startswith(("ch6_p1_", "ch6_p2"))] for d in DATASETS}


rule tracking_budget:
    """Chapter 6's tracking errors ε_TOL and ε_TCL (Tables 6.1–6.2) split into their sources with
    the twin's truth, and the closed loops' controller error ε_CCL split through the loop (verification)."""
    input:
        unpack(lambda w: captures(w.dataset, capture=TRACKED_RUNS[w.dataset])),
        library=library_sources("tracking_budget"),
    output:
        tracking=report("results/{dataset}/twin/tracking_budget.csv", caption="../report/tracking_budget.rst",
                        category="{dataset}", subcategory="Twin validation"),
        controller=report("results/{dataset}/twin/controller_budget.csv", caption="../report/controller_budget.rst",
                          category="{dataset}", subcategory="Twin validation"),
    params:
        protocols=lambda w: {e: dict(EXPERIMENTS[w.dataset][e].protocol) for e in TRACKED_RUNS[w.dataset]},
        controls=lambda w: {e: EXPERIMENTS[w.dataset][e].control for e in TRACKED_RUNS[w.dataset]},
        omega_c=config["control"]["omega_c"],
    log:
        "logs/{dataset}/tracking_budget.log",
    benchmark:
        "benchmarks/out/{dataset}/tracking_budget.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=30,
    script:
        "../scripts/tracking_budget.py"


#: the closed-loop runs the leak study simulates again (Table 6.2's P2 profiles: seconds each)
LEAK_RUNS = {d: [e for e in CLOSED_LOOP[d] if e.startswith("ch6_p2")] for d in DATASETS}


rule loop_leak:
    """The closed loop's drive at the folded ripple frequency and the C_e bias it makes: each P2 run
    as simulated and again with the drive kept out of the ripple channels (twin study: reads /truth)."""
    input:
        unpack(lambda w: captures(w.dataset, capture=LEAK_RUNS[w.dataset])),
        manifest=RAW / "{dataset}" / "dataset.yaml",  # the what-if simulates from it
        gamma="results/{dataset}/ch5/gamma.json",
        observer="results/{dataset}/ch5/observer.json",
        model="results/{dataset}/ch4/model.json",
        library=library_sources("loop_leak"),
    output:
        report("results/{dataset}/twin/loop_leak.csv", caption="../report/loop_leak.rst", category="{dataset}",
               subcategory="Twin validation"),
    params:
        campaign=config["campaign"],
        capture=config["capture"],
        omega_c=config["control"]["omega_c"],
        n_periods=config["ripple"]["n_periods"],
    log:
        "logs/{dataset}/loop_leak.log",
    benchmark:
        "benchmarks/out/{dataset}/loop_leak.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["simulate_mem_mb"],
        runtime=30,
    script:
        "../scripts/loop_leak.py"


#: what the stage makes for rule all and the scorecard: its rules' outputs, for the datasets each runs for
CONTROL_OUTPUTS = (
    expand([*rules.ch6_results.output, *rules.audit_realtime.output], dataset=CONTROL_DATASETS)
    + expand([*rules.tracking_budget.output, *rules.loop_leak.output],  # they read /truth
             dataset=[d for d in CONTROL_DATASETS if d in SIMULATED and LEAK_RUNS[d]])
)
