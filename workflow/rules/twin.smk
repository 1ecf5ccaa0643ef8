# Stage "twin": the digital twin's calibration, a step of the pipeline rather than a hand choice
# (docs/twin.md, "Calibration"): the signatures its free parameters are set to, read from the
# pipeline's own tables beside the thesis's values and their bands (workflow/twin_calibration.yaml).
# Included after report.smk: it reads the stages' tables that STAGE_OUTPUTS lists.

from selfsense.scorecard.calibration import load_targets

TWIN_CALIBRATION_TARGETS = "workflow/twin_calibration.yaml"

# parsed once here so that a bad targets file stops the workflow with one line before anything runs
TWIN_CALIBRATION = load_targets(TWIN_CALIBRATION_TARGETS)

#: datasets the twin made of the thesis's stack: the targets are the thesis's numbers
CALIBRATED_DATASETS = [d for d in SIMULATED if DATASETS[d].get("model") == "stack"]


rule twin_calibration:
    """The twin's calibration signatures (feedforward error, loop widths, ripple phase, stroke, U_P,
    warming, τ) against the thesis's, each with its band; a table not made reads "not measured"."""
    input:
        targets=TWIN_CALIBRATION_TARGETS,
        # only the tables some stage makes for this dataset: the others are rows "not measured"
        tables=lambda w: [t for t in (f"results/{w.dataset}/{t}" for t in TWIN_CALIBRATION.tables())
                          if t in STAGE_OUTPUTS],
        library=library_sources("twin_calibration"),
    output:
        table=report("results/{dataset}/twin/calibration.csv", caption="../report/twin_calibration.rst",
                     category="{dataset}", subcategory="Twin validation"),
    params:
        results_dir=lambda w: f"results/{w.dataset}",
    log:
        "logs/{dataset}/twin_calibration.log",
    benchmark:
        "benchmarks/out/{dataset}/twin_calibration.tsv"
    threads: 1
    resources:
        mem_mb=300,
        runtime=5,
    script:
        "../scripts/twin_calibration.py"


TWIN_OUTPUTS = expand(rules.twin_calibration.output, dataset=CALIBRATED_DATASETS)
