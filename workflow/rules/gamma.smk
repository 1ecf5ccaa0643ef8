# Stage "gamma" (thesis Chapter 5): capacitance self-sensing Γ, Tables 5.1–5.2. Which datasets run
# it: the stage plan (GAMMA_DATASETS in common.smk).


rule gamma_fit:
    """Γ of orders 3–6 and ln on the 0.1 Hz data; ANOVA and coefficients (statsmodels) at the
    order the model selection picks and at the thesis's j = 5."""
    input:
        unpack(lambda w: captures(w.dataset, capture=role_run(w.dataset, "gamma.fit"))),  # its warm-up at 0 V is left out of the fit
        series=role_path("results/{dataset}/ripple/{run}.nc", "gamma.fit"),
        library=library_sources("gamma_fit"),
    output:
        **{
            k: report(
                f"results/{{dataset}}/ch5/{v}",
                caption=f"../report/{k}.rst",
                category="{dataset}",
                subcategory="Chapter 5",
            )
            for k, v in GAMMA_TABLES.items()
        },
        gamma="results/{dataset}/ch5/gamma.json",
        gamma_j5="results/{dataset}/ch5/gamma_j5.json",
    log:
        "logs/{dataset}/gamma_fit.log",
    benchmark:
        "benchmarks/out/{dataset}/gamma_fit.tsv"
    threads: 1
    resources:
        **resources_for("large"),
    params:
        n_periods=config["ripple"]["n_periods"],
        orders=config["gamma"]["orders"],
    script:
        "../scripts/gamma_fit.py"


#: what the stage makes for rule all and the scorecard: its rules' outputs, for the datasets it runs for
GAMMA_OUTPUTS = expand(rules.gamma_fit.output, dataset=GAMMA_DATASETS)
