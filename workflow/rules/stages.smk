# Which stages run for each dataset, and why the others are skipped (a dataset that lacks the
# channels or experiments an analysis needs skips it with a stated reason, it does not crash).

STAGES = (  # (stage, datasets it runs for, what it needs)
    ("ripple (Ch. 3)", RIPPLE_DATASETS, "ripple channels Ur, Ir with U, I, x_laser and a folding plan (daq.ripple)"),
    ("identify (Ch. 4)", IDENTIFY_DATASETS, "ripple stage, Chapter 4 sine sets and the static stiffness tests"),
    ("gamma (Ch. 5)", GAMMA_DATASETS, "ripple stage and the 0.1 Hz run ch5_sine_0p1hz"),
    ("observer (Ch. 5)", OBSERVER_DATASETS, "gamma stage, the Table 5.4 sines, 10–300 Hz sines and ch5_creep"),
    ("frequency response (Ch. 5, Fig 5.3)", FREQUENCY_RESPONSE_DATASETS,
     "identify stage and the stepped-sine sweep ch5_sweep"),
    ("control (Ch. 6)", CONTROL_DATASETS, "observer and identify stages and closed-loop runs"),
    ("thermal (Ch. 7)", THERMAL_DATASETS, "observer and identify stages, the Chapter 7 runs and T_mid"),
    ("powerloss (Ronkanen)", POWERLOSS_DATASETS, "U, I, i_cmd, x_disp channels and the ronkanen catalogue"),
)


rule stage_plan:
    """Which analyses run for a dataset and, for the skipped ones, what they would need."""
    input:
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("stage_plan"),
    output:
        table=report("results/{dataset}/stages.csv", caption="../report/stages.rst", category="{dataset}",
                     subcategory="Stages"),
    params:
        rows=lambda w: [{"stage": name, "runs": w.dataset in which, "needs": needs} for name, which, needs in STAGES],
    log:
        "logs/{dataset}/stage_plan.log",
    benchmark:
        "benchmarks/out/{dataset}/stage_plan.tsv"
    threads: 1
    resources:
        mem_mb=200,
        runtime=5,
    script:
        "../scripts/stage_plan.py"


STAGE_PLAN_OUTPUTS = expand(rules.stage_plan.output, dataset=DATASETS)
