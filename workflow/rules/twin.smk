# Stage "twin": the digital twin's calibration, a step of the pipeline rather than a hand choice
# (docs/twin.md, "Calibration"): the signatures its free parameters are set to, read from the
# pipeline's own tables beside the thesis's values and their bands (workflow/twin_calibration.yaml).
# It runs for the datasets the twin made of the thesis's stack (CALIBRATED_DATASETS in common.smk).


rule twin_calibration:
    """The twin's calibration signatures (feedforward error, loop widths, ripple phase, stroke, U_P,
    warming, τ) against the thesis's, each with its band; a table not made reads "not measured"."""
    input:
        targets=TWIN_CALIBRATION_TARGETS,
        # only the tables some stage makes for this dataset: the others are rows "not measured"
        tables=lambda w: calibration_tables(w.dataset),
        library=library_sources("twin_calibration"),
    output:
        table=report(
            "results/{dataset}/twin/calibration.csv",
            caption="../report/twin_calibration.rst",
            category="{dataset}",
            subcategory="Twin validation",
        ),
    log:
        "logs/{dataset}/twin_calibration.log",
    benchmark:
        "benchmarks/out/{dataset}/twin_calibration.tsv"
    threads: 1
    resources:
        **resources_for("small"),
    params:
        results_dir=lambda w: f"results/{w.dataset}",
    script:
        "../scripts/twin_calibration.py"


TWIN_OUTPUTS = expand(rules.twin_calibration.output, dataset=CALIBRATED_DATASETS)
