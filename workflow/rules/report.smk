# Stage "report": the scorecard (every published number beside its reproduction, with a band and a
# verdict) per dataset, and the summary that opens `snakemake --report` (workflow/report/workflow.rst).

from selfsense.io.manifest import load_yaml
from selfsense.scorecard.reference_values import tables_read as reference_tables
from selfsense.scorecard import applicable, parse_registry, tables_read

SCORECARD_REGISTRY = "workflow/scorecard.yaml"

# parsed once here so that a bad registry stops the workflow with one line before anything runs
SCORECARD = parse_registry(load_yaml(SCORECARD_REGISTRY), SCORECARD_REGISTRY)

#: the thesis's printed Γ (Table 5.2, j = 5) and Γ_T (Table 7.3, n = 5 with T) against ours, compared
#: as curves: per fit, the folder, the registry's source and coefficient names, the records compared
#: (the thesis's order and the order the pipeline uses), the temperatures (Table 7.1's T_ref), and the
#: run, ripple series and thermometers (Γ_T) each was fitted on, which rule gamma_truth refits
CURVES = {
    "gamma": {"folder": "ch5", "source": "Table 5.2", "coefficients": [f"b{i}" for i in range(6)], "g": None,
              "fits": {"thesis order": "gamma_j5.json", "our order": "gamma.json"}, "temperatures": [0.0],
              "datasets": GAMMA_DATASETS, "run": GAMMA_RUN, "series": f"ripple/{GAMMA_RUN}.nc", "power": None},
    "gamma_t": {"folder": "ch7", "source": "Table 7.3", "coefficients": [f"bT{i}" for i in range(6)],
                "g": "g (temperature coefficient)", "fits": {"thesis order": "gamma_t_n5.json", "our order": "gamma_t.json"},
                "temperatures": [23.0], "datasets": THERMAL_DATASETS, "run": GAMMA_T_RUNS["fit"],
                "series": f"thermal/{GAMMA_T_RUNS['fit']}_gamma.nc", "power": f"thermal/{GAMMA_T_RUNS['fit']}.nc"},
}


def curve_fits(w):
    """The Γ records of one curve (CURVES) of one dataset."""
    c = CURVES[w.fit]
    return [f"results/{w.dataset}/{c['folder']}/{f}" for f in c["fits"].values()]


rule curve_vs_thesis:
    """Our fitted Γ / Γ_T against the thesis's printed one: max |Γ − Γ_thesis| over its C range."""
    input:
        registry=SCORECARD_REGISTRY,
        fits=curve_fits,
        library=library_sources("curve_vs_thesis"),
    output:
        table=report("results/{dataset}/{folder}/{fit}_vs_thesis.csv", caption="../report/curve_vs_thesis.rst",
                     category="{dataset}", subcategory="Scorecard"),
    wildcard_constraints:
        fit="|".join(CURVES),
        folder="ch5|ch7",
    params:
        fits=lambda w: list(CURVES[w.fit]["fits"]),
        source=lambda w: CURVES[w.fit]["source"],
        coefficients=lambda w: CURVES[w.fit]["coefficients"],
        g=lambda w: CURVES[w.fit]["g"],
        temperatures=lambda w: CURVES[w.fit]["temperatures"],
    log:
        "logs/{dataset}/curve_vs_thesis/{folder}_{fit}.log",
    benchmark:
        "benchmarks/out/{dataset}/curve_vs_thesis/{folder}_{fit}.tsv"
    threads: 1
    resources:
        mem_mb=300,
        runtime=5,
    script:
        "../scripts/curve_vs_thesis.py"


rule gamma_truth:
    """Γ / Γ_T refitted with the measured C_e, x (and T) replaced by the twin's truth, one at a time
    and all at once: what of a curve's distance from the thesis's is the twin's C–x relation, and
    Γ_T's C·T interaction (verification, twin datasets only)."""
    input:
        unpack(lambda w: captures(w.dataset, capture=CURVES[w.fit]["run"])),
        registry=SCORECARD_REGISTRY,
        series=lambda w: f"results/{w.dataset}/{CURVES[w.fit]['series']}",
        power=lambda w: [f"results/{w.dataset}/{CURVES[w.fit]['power']}"] if CURVES[w.fit]["power"] else [],
        fits=curve_fits,
        library=library_sources("gamma_truth"),
    output:
        table=report("results/{dataset}/twin/{fit}_truth.csv", caption="../report/gamma_truth.rst",
                     category="{dataset}", subcategory="Twin validation"),
    wildcard_constraints:
        fit="|".join(CURVES),
    params:
        fits=lambda w: list(CURVES[w.fit]["fits"]),
        source=lambda w: CURVES[w.fit]["source"],
        coefficients=lambda w: CURVES[w.fit]["coefficients"],
        g=lambda w: CURVES[w.fit]["g"],
        temperatures=lambda w: CURVES[w.fit]["temperatures"],
        n_periods=config["ripple"]["n_periods"],
    log:
        "logs/{dataset}/gamma_truth/{fit}.log",
    benchmark:
        "benchmarks/out/{dataset}/gamma_truth/{fit}.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=10,
    script:
        "../scripts/gamma_truth.py"


CURVE_OUTPUTS = ([f"results/{d}/{c['folder']}/{fit}_vs_thesis.csv" for fit, c in CURVES.items() for d in c["datasets"]]
                 + [f"results/{d}/twin/{fit}_truth.csv" for fit, c in CURVES.items() for d in c["datasets"] if d in SIMULATED])

#: everything the stages promise to make (each stage's *_OUTPUTS, as rule all collects them)
STAGE_OUTPUTS = set(ACQUIRE_OUTPUTS + RIPPLE_OUTPUTS + IDENTIFY_OUTPUTS + GAMMA_OUTPUTS + OBSERVER_OUTPUTS
                    + CONTROL_OUTPUTS + THERMAL_OUTPUTS + POWERLOSS_OUTPUTS + CHARACTERISE_OUTPUTS + CURVE_OUTPUTS)

#: per dataset, the registry's tables (and those its reference values are compared with) that some
#: stage makes: the scorecard reads (and reruns after) exactly these; the other entries show as
#: "not reproduced yet"
SCORECARD_TABLES = {d: [t for t in (f"results/{d}/{t}" for t in tables_read(applicable(SCORECARD, DATASETS[d]))
                                    + reference_tables(DATASETS[d]))
                        if t in STAGE_OUTPUTS] for d in DATASETS}


rule scorecard:
    """Published vs reproduced numbers for one dataset: deviation, band, verdict (CSV and a page)."""
    input:
        registry=SCORECARD_REGISTRY,
        manifest=RAW / "{dataset}" / "dataset.yaml",
        tables=lambda w: SCORECARD_TABLES[w.dataset],
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
        counts=report("results/scorecard_counts.csv", caption="../report/scorecard_counts.rst",
                      category="Scorecard", subcategory="All datasets"),
        out_of_band=report("results/scorecard_out_of_band.html", caption="../report/scorecard_out_of_band.rst",
                           category="Scorecard", subcategory="All datasets"),
        not_yet=report("results/scorecard_not_yet.html", caption="../report/scorecard_not_yet.rst",
                       category="Scorecard", subcategory="All datasets"),
    params:
        campaign=config["campaign"],
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


REPORT_OUTPUTS = expand(rules.scorecard.output.table, dataset=DATASETS) + list(rules.scorecard_summary.output) + CURVE_OUTPUTS
