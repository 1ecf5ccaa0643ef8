# Stage "verify": what the analyses give back of what the twin was built with. Every rule here
# reads a simulated capture's /truth (selfsense.verify), which the analyses never do, so a measured
# dataset has none of them: each runs for the simulated datasets (simulated() in common.smk) of the
# stage whose results it verifies (the stage plan's *_DATASETS); the np study simulates on the
# twin its manifest describes (with_twin()). Their tables are the report's "Twin validation".


rule ce_recovery:
    """C_e from the ripple against the twin's true clamped capacitance (parameter recovery)."""
    input:
        unpack(
            lambda w: captures(
                w.dataset, captures=[role_run(w.dataset, r) for r in stages.CH3_SERIES.values()]
            )
        ),
        series=lambda w: [
            f"results/{w.dataset}/ripple/{role_run(w.dataset, r)}.nc"
            for r in stages.CH3_SERIES.values()
        ],
        library=library_sources("ce_recovery"),
    output:
        table=report(
            "results/{dataset}/twin/ce_recovery.csv",
            caption="../report/ce_recovery.rst",
            category="{dataset}",
            subcategory="Twin validation",
        ),
    log:
        "logs/{dataset}/ce_recovery.log",
    benchmark:
        "benchmarks/out/{dataset}/ce_recovery.tsv"
    threads: 1
    resources:
        **resources_for("large"),
    params:
        n_periods=config["ripple"]["n_periods"],
    script:
        "../scripts/ce_recovery.py"


rule ce_np_study:
    """C_e error against np and ripple-frequency wander (why np = 4), on the twin."""
    input:
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("ce_np_study"),
    output:
        table=report(
            "results/{dataset}/twin/ce_np_study.csv",
            caption="../report/ce_np_study.rst",
            category="{dataset}",
            subcategory="Twin validation",
        ),
        figure=report_figure("fig_3_np_study", "Twin validation"),
    log:
        "logs/{dataset}/ce_np_study.log",
    benchmark:
        "benchmarks/out/{dataset}/ce_np_study.tsv"
    threads: 1
    resources:
        **resources_for("large"),
    params:
        pdf=FIGURE_PDF,
        nps=config["ripple"]["np_sweep"],
        wanders=config["ripple"]["np_study_wander_hz"],
        drive_hz=config["ripple"]["np_study_drive_hz"],
    script:
        "../scripts/ce_np_study.py"


rule model_recovery:
    """Identified parameters against the twin's built values and against the same identification on
    its noiseless states (parameter recovery)."""
    input:
        unpack(
            lambda w: captures(
                w.dataset,
                capture=role_run(w.dataset, "identify.recovery_drive"),
                sets=role_runs(w.dataset, "identify.set"),
            )
        ),
        series=role_paths("results/{dataset}/ripple/{run}.nc", "identify.set"),
        per_set="results/{dataset}/ch4/sets.csv",
        hysteresis="results/{dataset}/ch4/hysteresis_voltage.csv",
        static="results/{dataset}/ch4/static_stiffness.csv",
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("model_recovery"),
    output:
        table=report(
            "results/{dataset}/twin/model_recovery.csv",
            caption="../report/model_recovery.rst",
            category="{dataset}",
            subcategory="Twin validation",
        ),
    log:
        "logs/{dataset}/model_recovery.log",
    benchmark:
        "benchmarks/out/{dataset}/model_recovery.tsv"
    threads: 1
    resources:
        **resources_for("medium"),
    params:
        frequency=lambda w: drive_frequency(
            w.dataset, role_run(w.dataset, "identify.recovery_drive")
        ),
        n_periods=config["ripple"]["n_periods"],
    script:
        "../scripts/model_recovery.py"


rule error_budget:
    """The observer's error of Table 5.4 (and Chapter 6's ε_OCL, Tables 6.1–6.2) split into its
    sources with the twin's truth (verification)."""
    input:
        unpack(lambda w: captures(w.dataset, captures=list(BUDGET_RUNS[w.dataset]))),
        gamma="results/{dataset}/ch5/gamma.json",
        observer="results/{dataset}/ch5/observer.json",
        library=library_sources("error_budget"),
    output:
        table=report(
            "results/{dataset}/twin/error_budget.csv",
            caption="../report/error_budget.rst",
            category="{dataset}",
            subcategory="Twin validation",
        ),
        figure=report_figure(ERROR_BUDGET_FIGURE, "Twin validation"),
    log:
        "logs/{dataset}/error_budget.log",
    benchmark:
        "benchmarks/out/{dataset}/error_budget.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        pdf=FIGURE_PDF,
        frequencies=lambda w: BUDGET_RUNS[w.dataset],
        # Chapter 6 counts from the loop's settling on (its ω_C), in P1's segments; Table 5.4 from the warm-up on
        loop_omega_c=lambda w: {
            e: config["control"]["omega_c"] if e in CLOSED_LOOP[w.dataset] else None
            for e in BUDGET_RUNS[w.dataset]
        },
        p1_protocols=lambda w: {
            e: (
                dict(EXPERIMENTS[w.dataset][e].protocol)
                if CH6_RUNS[w.dataset].get(e) == "P1"
                else None
            )
            for e in BUDGET_RUNS[w.dataset]
        },
        transient_s=lambda w: {
            e: (
                config["observer"]["creep_transient_s"]
                if e in role_runs(w.dataset, "observer.creep")
                else None
            )
            for e in BUDGET_RUNS[w.dataset]
        },
        n_periods=config["ripple"]["n_periods"],
    script:
        "../scripts/error_budget.py"


rule charge_budget:
    """Fig 5.2's charge–position error split into its sources with the twin's truth (verification)."""
    input:
        unpack(lambda w: captures(w.dataset, captures=list(CHARGE_SINES[w.dataset].values()))),
        series=lambda w: [
            f"results/{w.dataset}/ripple/{e}.nc" for e in CHARGE_SINES[w.dataset].values()
        ],
        library=library_sources("charge_budget"),
    output:
        table=report(
            "results/{dataset}/twin/charge_budget.csv",
            caption="../report/charge_budget.rst",
            category="{dataset}",
            subcategory="Twin validation",
        ),
    log:
        "logs/{dataset}/charge_budget.log",
    benchmark:
        "benchmarks/out/{dataset}/charge_budget.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        frequencies=lambda w: {e: f for f, e in CHARGE_SINES[w.dataset].items()},
        n_periods=config["ripple"]["n_periods"],
    script:
        "../scripts/charge_budget.py"


rule tracking_budget:
    """Chapter 6's tracking errors ε_TOL and ε_TCL (Tables 6.1–6.2) split into their sources with
    the twin's truth, and the closed loops' controller error ε_CCL split through the loop (verification).
    """
    input:
        unpack(lambda w: captures(w.dataset, captures=TRACKED_RUNS[w.dataset])),
        library=library_sources("tracking_budget"),
    output:
        tracking=report(
            "results/{dataset}/twin/tracking_budget.csv",
            caption="../report/tracking_budget.rst",
            category="{dataset}",
            subcategory="Twin validation",
        ),
        controller=report(
            "results/{dataset}/twin/controller_budget.csv",
            caption="../report/controller_budget.rst",
            category="{dataset}",
            subcategory="Twin validation",
        ),
    log:
        "logs/{dataset}/tracking_budget.log",
    benchmark:
        "benchmarks/out/{dataset}/tracking_budget.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        protocols=lambda w: {
            e: dict(EXPERIMENTS[w.dataset][e].protocol) for e in TRACKED_RUNS[w.dataset]
        },
        controls=lambda w: {e: EXPERIMENTS[w.dataset][e].control for e in TRACKED_RUNS[w.dataset]},
        profiles=lambda w: TRACKED_RUNS[w.dataset],
        omega_c=config["control"]["omega_c"],
    script:
        "../scripts/tracking_budget.py"


rule loop_leak:
    """The closed loop's drive at the folded ripple frequency and the C_e bias it makes: each P2 run
    as simulated and again with the drive kept out of the ripple channels (twin study: reads /truth).
    """
    input:
        unpack(lambda w: captures(w.dataset, captures=LEAK_RUNS[w.dataset])),
        manifest=RAW / "{dataset}" / "dataset.yaml",  # the what-if simulates from it
        gamma="results/{dataset}/ch5/gamma.json",
        observer="results/{dataset}/ch5/observer.json",
        model="results/{dataset}/ch4/model.json",
        library=library_sources("loop_leak"),
    output:
        table=report(
            "results/{dataset}/twin/loop_leak.csv",
            caption="../report/loop_leak.rst",
            category="{dataset}",
            subcategory="Twin validation",
        ),
    log:
        "logs/{dataset}/loop_leak.log",
    benchmark:
        "benchmarks/out/{dataset}/loop_leak.tsv"
    threads: 1
    resources:
        **resources_for("simulate"),
    params:
        campaign=config["campaign"],
        capture_settings=config["capture"],
        omega_c=config["control"]["omega_c"],
        n_periods=config["ripple"]["n_periods"],
    script:
        "../scripts/loop_leak.py"


rule thermal_recovery:
    """τ, γ, k_T of Table 7.1 and Γ_T's g against the twin's truth (simulated datasets: it reads /truth)."""
    input:
        unpack(
            lambda w: captures(
                w.dataset, truth_capture=role_run(w.dataset, "thermal.gamma_t_validation")
            )
        ),
        table_7_1="results/{dataset}/ch7/table_7_1.csv",
        gamma_t=rules.gamma_t_fit.output.gamma_t,
        library=library_sources("thermal_recovery"),
    output:
        recovery=report(
            "results/{dataset}/twin/thermal_recovery.csv",
            caption="../report/thermal_recovery.rst",
            category="{dataset}",
            subcategory="Twin validation",
        ),
    log:
        "logs/{dataset}/thermal_recovery.log",
    benchmark:
        "benchmarks/out/{dataset}/thermal_recovery.tsv"
    threads: 1
    resources:
        **resources_for("small"),
    script:
        "../scripts/thermal_recovery.py"


rule temperature_budget:
    """The mixed run's coupled temperature errors (Fig 7.12) split into their sources with the twin's
    truth: power estimate, thermal model, thermometer (verification; simulated datasets: it reads /truth).
    """
    input:
        unpack(
            lambda w: captures(w.dataset, capture=role_run(w.dataset, "thermal.coupled_fig_7_12"))
        ),
        traces=role_path("results/{dataset}/ch7/coupled/{run}.nc", "thermal.coupled_fig_7_12"),
        stats=role_path("results/{dataset}/ch7/coupled/{run}.json", "thermal.coupled_fig_7_12"),
        thermal_model="results/{dataset}/ch7/thermal_model.json",
        library=library_sources("temperature_budget"),
    output:
        table=report(
            "results/{dataset}/twin/temperature_budget.csv",
            caption="../report/temperature_budget.rst",
            category="{dataset}",
            subcategory="Twin validation",
        ),
    log:
        "logs/{dataset}/temperature_budget.log",
    benchmark:
        "benchmarks/out/{dataset}/temperature_budget.tsv"
    threads: 1
    resources:
        **resources_for("large"),
    script:
        "../scripts/temperature_budget.py"


rule powerloss_recovery:
    """Identified R, a, X and c against the twin's true parameters (twin validation)."""
    input:
        unpack(lambda w: captures(w.dataset, capture=role_run(w.dataset, "powerloss.hold"))),
        identified=f"{POWERLOSS}/identified.csv",
        table_1=f"{POWERLOSS}/table_1.csv",
        table_2=f"{POWERLOSS}/table_2.csv",
        library=library_sources("powerloss_recovery"),
    output:
        table=report(
            f"{POWERLOSS}/recovery.csv",
            caption="../report/ronkanen_recovery.rst",
            **RONKANEN_REPORT,
        ),
    log:
        "logs/{dataset}/powerloss_recovery.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_recovery.tsv"
    threads: 1
    resources:
        **resources_for("small"),
    script:
        "../scripts/powerloss_recovery.py"


rule powerloss_truth:
    """Section 7's results from the sensor and from the twin's true displacement, and the sensor's
    share (twin validation: it reads /truth)."""
    input:
        unpack(
            lambda w: captures(
                w.dataset, captures=list(ronkanen_runs(w.dataset, stages.RONKANEN_PAIRS).values())
            )
        ),
        identified=f"{POWERLOSS}/identified.csv",
        library=library_sources("powerloss_truth"),
    output:
        table=report(
            f"{POWERLOSS}/performance_truth.csv",
            caption="../report/ronkanen_performance_truth.rst",
            **RONKANEN_REPORT,
        ),
    log:
        "logs/{dataset}/powerloss_truth.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_truth.tsv"
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        drift_start=lambda w: first_segment_end(w.dataset, "powerloss.drift_current"),
        drift_duration=config["powerloss"]["drift_duration_s"],
        pairs=lambda w: ronkanen_runs(w.dataset, stages.RONKANEN_PAIRS),
    script:
        "../scripts/powerloss_truth.py"


rule gamma_truth:
    """Γ / Γ_T refitted with the measured C_e, x (and T) replaced by the twin's truth, one at a time
    and all at once: what of a curve's distance from the thesis's is the twin's C–x relation, and
    Γ_T's C·T interaction (verification, twin datasets only)."""
    input:
        unpack(lambda w: captures(w.dataset, capture=role_run(w.dataset, CURVES[w.fit]["role"]))),
        registry=SCORECARD_REGISTRY,
        series=lambda w: curve_input(w, "series"),
        power=lambda w: [curve_input(w, "power")] if CURVES[w.fit]["power"] else [],
        fits=curve_fits,
        library=library_sources("gamma_truth"),
    output:
        table=report(
            "results/{dataset}/twin/{fit}_truth.csv",
            caption="../report/gamma_truth.rst",
            category="{dataset}",
            subcategory="Twin validation",
        ),
    log:
        "logs/{dataset}/gamma_truth/{fit}.log",
    benchmark:
        "benchmarks/out/{dataset}/gamma_truth/{fit}.tsv"
    wildcard_constraints:
        fit="|".join(CURVES),
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        fit_names=lambda w: {f: name for name, f in CURVES[w.fit]["fits"].items()},
        source=lambda w: CURVES[w.fit]["source"],
        coefficients=lambda w: CURVES[w.fit]["coefficients"],
        g=lambda w: CURVES[w.fit]["g"],
        temperatures=lambda w: CURVES[w.fit]["temperatures"],
        n_periods=config["ripple"]["n_periods"],
        span=lambda w: drive_span(w.dataset, CURVES[w.fit]["role"]),
    script:
        "../scripts/gamma_truth.py"


#: what the stage makes for rule all and the scorecard: its rules' outputs, for the datasets each verifies
VERIFY_OUTPUTS = (
    expand(rules.ce_np_study.output, dataset=with_twin(CH3_DATASETS))
    + expand(rules.ce_recovery.output, dataset=simulated(CH3_DATASETS))
    + expand(rules.model_recovery.output, dataset=simulated(IDENTIFY_DATASETS))
    + expand(
        [*rules.error_budget.output, *rules.charge_budget.output],
        dataset=simulated(OBSERVER_DATASETS),
    )
    + expand(
        [*rules.tracking_budget.output, *rules.loop_leak.output],
        dataset=[d for d in simulated(CONTROL_DATASETS) if LEAK_RUNS[d]],
    )
    + expand(
        [*rules.thermal_recovery.output, *rules.temperature_budget.output],
        dataset=simulated(THERMAL_DATASETS),
    )
    + expand(
        [*rules.powerloss_recovery.output, *rules.powerloss_truth.output],
        dataset=simulated(POWERLOSS_DATASETS),
    )
    + [
        f"results/{d}/twin/{fit}_truth.csv"
        for fit, c in CURVES.items()
        for d in simulated(c["datasets"])
    ]
)
