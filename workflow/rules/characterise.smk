# Stage "characterise": what the channels allow, whatever the protocol. Every capture with a drive
# voltage U and a displacement (x_laser or x_disp) of a dataset whose DAQ records both: stroke,
# gains, the x–U loop's width and nonlinearity, creep after a held step, and with the current the
# charge–position slope and the q–U loop; a loop figure (a page per characterise_page job:
# config characterise.captures_per_job) and a table per dataset.
# Which datasets run it: the stage plan (CHARACTERISE_DATASETS in common.smk).


rule characterise_page:
    """The captures of one page of the dataset's loop figure, each streamed once: their rows of
    the characterisation table and their page (x–U, and q–U with the current). A job per page,
    not per dataset (its pages, one after another, kept a core busy alone at the end of the run):
    a page runs as soon as its captures are there. Six captures a page for a simulated dataset (a
    capture's own work is a fraction of a job's start-up), one for a measured one, named after
    it, so that a new batch of recordings runs only its own pages (captures_per_job in
    common.smk)."""
    input:
        unpack(lambda w: captures(w.dataset, captures=LOOP_PAGES[w.dataset][w.page])),
        library=library_sources("characterise_page"),
    output:
        rows="results/{dataset}/characterise/page_{page}.json",
        figure=report(
            "figures/{dataset}/characterise/loops_{page}.png",
            caption="../report/characterise_loops.rst",
            category="{dataset}",
            subcategory="Characterisation",
        ),
    log:
        "logs/{dataset}/characterise_page/{page}.log",
    benchmark:
        "benchmarks/out/{dataset}/characterise_page/{page}.tsv"
    wildcard_constraints:
        page=r"[A-Za-z0-9_]+",  # a number, or the capture of a page of one
    threads: 1
    resources:
        **resources_for("stream"),
    params:
        pdf=FIGURE_PDF,
        title=lambda w: loop_page_title(w.dataset, w.page),
        scalings=lambda w: channel_scalings(DATASETS[w.dataset]),
        periods=lambda w: protocol_periods(w.dataset, LOOP_PAGES[w.dataset][w.page]),
        settle_s=config["characterise"]["settle_s"],
        min_hold_s=config["characterise"]["min_hold_s"],
        cycle_rules=config["characterise"]["cycles"],
        hysteresis=config["characterise"]["hysteresis"],
    script:
        "../scripts/characterise_page.py"


rule characterise:
    """The dataset's characterisation table, one row per capture in catalogue order, from its
    loop pages' rows; each capture's hysteresis model's parameters; and the actuator and its
    sensors as the manifest describes them."""
    input:
        pages=lambda w: expand(
            rules.characterise_page.output.rows, dataset=w.dataset, page=LOOP_PAGES[w.dataset]
        ),
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("characterise"),
    output:
        table=report(
            "results/{dataset}/characterise/summary.csv",
            caption="../report/characterise.rst",
            category="{dataset}",
            subcategory="Characterisation",
        ),
        instruments=report(
            "results/{dataset}/characterise/instruments.csv",
            caption="../report/instruments.rst",
            category="{dataset}",
            subcategory="Characterisation",
        ),
        model=report(
            "results/{dataset}/characterise/hysteresis_model.csv",
            caption="../report/hysteresis_model.rst",
            category="{dataset}",
            subcategory="Characterisation",
        ),
    log:
        "logs/{dataset}/characterise.log",
    benchmark:
        "benchmarks/out/{dataset}/characterise.tsv"
    threads: 1
    resources:
        **resources_for("medium"),
    script:
        "../scripts/characterise.py"


#: what the stage makes for rule all and the scorecard
CHARACTERISE_OUTPUTS = expand(rules.characterise.output, dataset=CHARACTERISE_DATASETS) + [
    f
    for d in CHARACTERISE_DATASETS
    for f in expand(rules.characterise_page.output.figure, dataset=d, page=LOOP_PAGES[d])
]
