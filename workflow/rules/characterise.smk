# Stage "characterise": what the channels allow, whatever the protocol. Every capture with a drive
# voltage U and a displacement (x_laser or x_disp) of a dataset whose DAQ records both: stroke,
# gains, the x–U loop's width and nonlinearity, creep after a held step, and with the current the
# charge–position slope and the q–U loop; a loop figure per capture and a table per dataset.

# from the capture contract, not selfsense.characterise: that imports matplotlib, ≈ 0.5 s of every
# Snakemake start (each dry run, each cluster job)
from selfsense.capture import DISPLACEMENT

#: datasets whose DAQ records a drive voltage and a displacement
CHARACTERISE_DATASETS = [d for d in DATASETS
                         if has_channels(d, "U") and any(has_channels(d, x) for x in DISPLACEMENT)]


rule characterise:
    """Every capture of the dataset streamed once: the characterisation table (one row per capture),
    the actuator and its sensors, and the loops (x–U, and q–U with the current), a page per six
    captures. One job per dataset: a capture's own work is a fraction of a job's start-up."""
    input:
        unpack(lambda w: captures(w.dataset, capture=list(EXPERIMENTS[w.dataset]))),
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("characterise"),
    output:
        table=report("results/{dataset}/characterise/summary.csv", caption="../report/characterise.rst",
                     category="{dataset}", subcategory="Characterisation"),
        instruments=report("results/{dataset}/characterise/instruments.csv", caption="../report/instruments.rst",
                           category="{dataset}", subcategory="Characterisation"),
        figures=report(directory("figures/{dataset}/characterise"), patterns=["{name}.png"],
                       caption="../report/characterise_loops.rst", category="{dataset}",
                       subcategory="Characterisation"),
    params:
        settle_s=0.1,  # x after a step is read this long after it (the stack's mechanics settle in ms)
        min_hold_s=1.0,  # a shorter final hold is no creep test
    log:
        "logs/{dataset}/characterise.log",
    benchmark:
        "benchmarks/out/{dataset}/characterise.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=30,
    script:
        "../scripts/characterise.py"


#: what the stage makes for rule all and the scorecard
CHARACTERISE_OUTPUTS = expand(rules.characterise.output, dataset=CHARACTERISE_DATASETS)
