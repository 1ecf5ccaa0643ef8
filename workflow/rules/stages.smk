# Which stages run for each dataset, and why the others are skipped (a dataset that lacks the
# channels or experiments an analysis needs skips it with a stated reason, it does not crash).

STAGES = (  # (stage, datasets it runs for, what it needs)
    ("ripple (Ch. 3)", ripple_datasets, "ripple channels Ur, Ir with U, I, x_laser and a folding plan (daq.ripple)"),
    ("identify (Ch. 4)", identify_datasets, "ripple stage, Chapter 4 sine sets and the static stiffness tests"),
    ("gamma (Ch. 5)", gamma_datasets, "ripple stage and the 0.1 Hz run ch5_sine_0p1hz"),
    ("observer (Ch. 5)", observer_datasets, "gamma stage, the Table 5.4 sines, 10–300 Hz sines and ch5_creep"),
    ("frequency response (Ch. 5, Fig 5.3)", frequency_response_datasets, "identify stage and the stepped-sine sweep ch5_sweep"),
    ("control (Ch. 6)", control_datasets, "observer and identify stages and closed-loop runs"),
    ("thermal (Ch. 7)", thermal_datasets, "observer and identify stages, the Chapter 7 runs and T_mid"),
    ("powerloss (Ronkanen)", powerloss_datasets, "U, I, i_cmd, x_disp channels and the ronkanen catalogue"),
)


def stage_rows(dataset):
    return [{"stage": name, "runs": dataset in which(), "needs": needs} for name, which, needs in STAGES]


rule stage_plan:
    """Which analyses run for a dataset and, for the skipped ones, what they would need."""
    input:
        manifest=RAW / "{dataset}" / "dataset.yaml",
    output:
        table=report("results/{dataset}/stages.csv", caption="../report/stages.rst", category="{dataset}",
                     subcategory="Stages"),
    params:
        rows=lambda w: stage_rows(w.dataset),
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
