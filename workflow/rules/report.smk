# Stage "report": the scorecard (every published number beside its reproduction, with a band and a
# verdict) per dataset, and the summary that opens `snakemake --report` (workflow/report/workflow.rst).


rule scorecard:
    """Published vs reproduced numbers for one dataset: deviation, band, verdict (CSV and a page)."""
    input:
        registry=SCORECARD_REGISTRY,
        manifest=RAW / "{dataset}" / "dataset.yaml",
        tables=lambda w: scorecard_tables(w.dataset),
        library=library_sources("scorecard"),
    output:
        table=report("results/{dataset}/scorecard.csv", caption="../report/scorecard.rst",
                     category="{dataset}", subcategory="Scorecard"),
        page=report("results/{dataset}/scorecard.html", caption="../report/scorecard.rst",
                    category="{dataset}", subcategory="Scorecard"),
    params:
        results_dir=lambda w: f"results/{w.dataset}",
    log:
        "logs/{dataset}/scorecard.log",
    benchmark:
        "benchmarks/out/{dataset}/scorecard.tsv"
    threads: 1
    resources:
        mem_mb=300,
        runtime=5,
    script:
        "../scripts/scorecard.py"


rule scorecard_summary:
    """The summary that opens the report (counts per dataset), and pages of its long lists: what is
    out of band and why, what is not reproduced yet. The lists are report items of their own, not
    part of the opening: Snakemake centres its landing text, so a long one starts out of reach."""
    input:
        cards=[f"results/{d}/scorecard.csv" for d in DATASETS],
        library=library_sources("scorecard_summary"),
    output:
        summary=report("results/scorecard_summary.rst", caption="../report/scorecard_summary.rst",
                       category="Scorecard", subcategory="All datasets"),
        out_of_band=report("results/scorecard_out_of_band.html", caption="../report/scorecard_out_of_band.rst",
                           category="Scorecard", subcategory="All datasets"),
        not_yet=report("results/scorecard_not_yet.html", caption="../report/scorecard_not_yet.rst",
                       category="Scorecard", subcategory="All datasets"),
    log:
        "logs/scorecard_summary.log",
    benchmark:
        "benchmarks/out/scorecard_summary.tsv"
    threads: 1
    resources:
        mem_mb=300,
        runtime=5,
    script:
        "../scripts/scorecard_summary.py"
