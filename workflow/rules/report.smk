# Stage "report": the scorecard (every published number beside its reproduction, with a band and a
# verdict) per dataset, and the summary that opens `snakemake --report` (workflow/report/workflow.rst).
# The scorecard reads the tables some stage makes (scorecard_tables in common.smk).


rule curve_vs_thesis:
    """Our fitted Γ / Γ_T against the thesis's printed one: max |Γ − Γ_thesis| over its C range."""
    input:
        registry=SCORECARD_REGISTRY,
        fits=curve_fits,
        library=library_sources("curve_vs_thesis"),
    output:
        table=report(
            "results/{dataset}/{folder}/{fit}_vs_thesis.csv",
            caption="../report/curve_vs_thesis.rst",
            category="{dataset}",
            subcategory="Scorecard",
        ),
    log:
        "logs/{dataset}/curve_vs_thesis/{folder}_{fit}.log",
    benchmark:
        "benchmarks/out/{dataset}/curve_vs_thesis/{folder}_{fit}.tsv"
    wildcard_constraints:
        fit="|".join(CURVES),
        folder="ch5|ch7",
    threads: 1
    resources:
        **resources_for("small"),
    params:
        fit_names=lambda w: {f: name for name, f in CURVES[w.fit]["fits"].items()},
        source=lambda w: CURVES[w.fit]["source"],
        coefficients=lambda w: CURVES[w.fit]["coefficients"],
        g=lambda w: CURVES[w.fit]["g"],
        temperatures=lambda w: CURVES[w.fit]["temperatures"],
    script:
        "../scripts/curve_vs_thesis.py"


#: the curves' comparisons with the thesis, for the datasets that fit each curve
CURVE_OUTPUTS = [
    f"results/{d}/{c['folder']}/{fit}_vs_thesis.csv"
    for fit, c in CURVES.items()
    for d in c["datasets"]
]


rule scorecard:
    """Published vs reproduced numbers for one dataset: deviation, band, verdict (CSV and a page).
    A local rule: it takes a second or two, and on a cluster a job's turn in the queue (an
    envelope's members each end with one) would take longer."""
    input:
        registry=SCORECARD_REGISTRY,
        manifest=RAW / "{dataset}" / "dataset.yaml",
        tables=lambda w: scorecard_tables(w.dataset),
        library=library_sources("scorecard"),
    output:
        table=report(
            "results/{dataset}/scorecard.csv",
            caption="../report/scorecard.rst",
            category="{dataset}",
            subcategory="Scorecard",
        ),
        page=report(
            "results/{dataset}/scorecard.html",
            caption="../report/scorecard.rst",
            category="{dataset}",
            subcategory="Scorecard",
        ),
    log:
        "logs/{dataset}/scorecard.log",
    benchmark:
        "benchmarks/out/{dataset}/scorecard.tsv"
    wildcard_constraints:
        # this run's datasets only: another dataset's scorecard, read by the summary as an earlier
        # run left it, is never made again by this run
        dataset="|".join(DATASETS),
    localrule: True
    threads: 1
    resources:
        **resources_for("small"),
    params:
        results_dir=lambda w: f"results/{w.dataset}",
    script:
        "../scripts/scorecard.py"


rule scorecard_summary:
    """The summary that opens the report (counts per dataset), and pages of its long lists: what is
    out of band and why, what is not reproduced yet. The lists are report items of their own, not
    part of the opening: Snakemake centres its landing text, so a long one starts out of reach.
    Project-wide: this run's datasets, made fresh, and every other dataset under raw_dir with a
    scorecard from an earlier run, as it is (ancient: never made again here), each said to be so
    with its date; running one dataset never drops another's numbers."""
    input:
        cards=[f"results/{d}/scorecard.csv" for d in NOMINAL],
        earlier=[ancient(card) for card in EARLIER_SCORECARDS.values()],
        library=library_sources("scorecard_summary"),
    output:
        summary=report(
            "results/scorecard_summary.rst",
            caption="../report/scorecard_summary.rst",
            category="Scorecard",
            subcategory="All datasets",
        ),
        counts=report(
            "results/scorecard_counts.csv",
            caption="../report/scorecard_counts.rst",
            category="Scorecard",
            subcategory="All datasets",
        ),
        out_of_band=report(
            "results/scorecard_out_of_band.html",
            caption="../report/scorecard_out_of_band.rst",
            category="Scorecard",
            subcategory="All datasets",
        ),
        not_yet=report(
            "results/scorecard_not_yet.html",
            caption="../report/scorecard_not_yet.rst",
            category="Scorecard",
            subcategory="All datasets",
        ),
    log:
        "logs/scorecard_summary.log",
    benchmark:
        "benchmarks/out/scorecard_summary.tsv"
    threads: 1
    resources:
        **resources_for("small"),
    params:
        campaign=config["campaign"],
    script:
        "../scripts/scorecard_summary.py"


REPORT_OUTPUTS = (
    expand(rules.scorecard.output.table, dataset=NOMINAL)
    + list(rules.scorecard_summary.output)
    + CURVE_OUTPUTS
)
