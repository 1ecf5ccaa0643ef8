# Stage "characterise": what the channels allow, whatever the protocol. Every capture with a drive
# voltage U and a displacement (x_laser or x_disp) of a dataset whose DAQ records both: stroke,
# gains, the x–U loop's width and nonlinearity, creep after a held step, and with the current the
# charge–position slope and the q–U loop; a loop figure per capture and a table per dataset.

from selfsense.characterise import DISPLACEMENT

#: datasets whose DAQ records a drive voltage and a displacement
CHARACTERISE_DATASETS = [d for d in DATASETS
                         if has_channels(d, "U") and any(has_channels(d, x) for x in DISPLACEMENT)]


rule characterise:
    """One capture's stroke, gains, loop width, nonlinearity, creep (and q–U) and its loop figure."""
    input:
        unpack(lambda w: captures(w.dataset, capture=w.experiment)),
        library=library_sources("characterise"),
    output:
        row="results/{dataset}/characterise/{experiment}.json",
        figure=report("figures/{dataset}/loop_{experiment}.png", caption="../report/characterise_loop.rst",
                      category="{dataset}", subcategory="Characterisation"),
    params:
        settle_s=0.1,  # x after a step is read this long after it (the stack's mechanics settle in ms)
        min_hold_s=1.0,  # a shorter final hold is no creep test
    log:
        "logs/{dataset}/characterise/{experiment}.log",
    benchmark:
        "benchmarks/out/{dataset}/characterise/{experiment}.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=20,
    script:
        "../scripts/characterise.py"


rule characterise_table:
    """The dataset's characterisation table (one row per capture), and its actuator and sensors."""
    input:
        rows=lambda w: [f"results/{w.dataset}/characterise/{e}.json" for e in EXPERIMENTS[w.dataset]],
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("characterise_table"),
    output:
        table=report("results/{dataset}/characterise/summary.csv", caption="../report/characterise.rst",
                     category="{dataset}", subcategory="Characterisation"),
        instruments=report("results/{dataset}/characterise/instruments.csv", caption="../report/instruments.rst",
                           category="{dataset}", subcategory="Characterisation"),
    log:
        "logs/{dataset}/characterise_table.log",
    benchmark:
        "benchmarks/out/{dataset}/characterise_table.tsv"
    threads: 1
    resources:
        mem_mb=300,
        runtime=5,
    script:
        "../scripts/characterise_table.py"


#: what the stage makes for rule all and the scorecard
CHARACTERISE_OUTPUTS = expand(rules.characterise_table.output, dataset=CHARACTERISE_DATASETS) + [
    f"figures/{d}/loop_{e}.png" for d in CHARACTERISE_DATASETS for e in EXPERIMENTS[d]]
