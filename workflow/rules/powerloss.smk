# Stage "powerloss" (Ronkanen 2002): R from the static hold, the loss impedance from the ramps
# (Table 1), the impedance models (Table 2), and compensated current control against open-loop
# voltage control (Section 7, Figures 2–11). Datasets take part when their DAQ records the
# current drive and they run the Ronkanen catalogue; the others skip the stage.

from selfsense.chapters.figure_names import RONKANEN as RONKANEN_FIGURES

POWERLOSS = "results/{dataset}/powerloss"

RONKANEN_REPORT = {"category": "{dataset}", "subcategory": "Ronkanen 2002"}  # where the report files them

#: the open-loop comparison: {"<kind>_<control>": experiment}
RONKANEN_PAIRS = {f"{kind}_{control}": f"rk_{kind}_{control}"
                  for kind in ("decay", "repeat", "drift") for control in ("current", "voltage")}

#: Fig 3, 4, 5 (and 6): the ±300 nA ramps with too large, too small and ideal compensation
RONKANEN_VELOCITY_RAMPS = ["rk_ramp_300na_10g", "rk_ramp_300na_1g", "rk_ramp_300na_2g"]

#: datasets whose DAQ records the current drive and that run the Ronkanen catalogue
POWERLOSS_DATASETS = [d for d in DATASETS
                      if has_channels(d, "U", "I", "i_cmd", "x_disp") and "ronkanen" in DATASETS[d]["protocols"]]

#: when each run's first segment ends [s]: where its hold starts (Figs 2, 11)
FIRST_SEGMENT_END = {d: {e: float(x.protocol.get("warmup", 0.0)) + float(x.protocol["segments"][0]["duration"])
                         for e, x in EXPERIMENTS[d].items() if x is not None} for d in POWERLOSS_DATASETS}


rule powerloss_identify:
    """R from the static hold (Section 4), X and a from every ramp (Table 1, Section 5)."""
    input:
        unpack(lambda w: captures(w.dataset, hold="rk_static_hold",
                                  ramps=[e for e in EXPERIMENTS[w.dataset] if e.startswith("rk_ramp_")])),
        library=library_sources("powerloss_identify"),
    output:
        ramps=report(f"{POWERLOSS}/ramps.csv", caption="../report/ronkanen_ramps.rst", **RONKANEN_REPORT),
        table_1=report(f"{POWERLOSS}/table_1.csv", caption="../report/ronkanen_table_1.rst", **RONKANEN_REPORT),
        identified=report(f"{POWERLOSS}/identified.csv", caption="../report/ronkanen_identified.rst",
                          **RONKANEN_REPORT),
    params:
        hold_start=lambda w: FIRST_SEGMENT_END[w.dataset]["rk_static_hold"],
        velocity_window=2.0,
    log:
        "logs/{dataset}/powerloss_identify.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_identify.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=10,
    script:
        "../scripts/powerloss_identify.py"


rule powerloss_table_2:
    """Table 2: models (7)–(11) fitted to the paper's Table 1 and to the identified impedances."""
    input:
        table_1=f"{POWERLOSS}/table_1.csv",
        identified=f"{POWERLOSS}/identified.csv",
        library=library_sources("powerloss_table_2"),
    output:
        table=report(f"{POWERLOSS}/table_2.csv", caption="../report/ronkanen_table_2.rst", **RONKANEN_REPORT),
    log:
        "logs/{dataset}/powerloss_table_2.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_table_2.tsv"
    threads: 1
    resources:
        mem_mb=300,
        runtime=5,
    script:
        "../scripts/powerloss_table_2.py"


rule powerloss_performance:
    """Hysteresis, drift, repeatability and max error: current vs open-loop voltage control."""
    input:
        unpack(lambda w: captures(w.dataset, **RONKANEN_PAIRS)),
        identified=f"{POWERLOSS}/identified.csv",
        library=library_sources("powerloss_performance"),
    output:
        performance=report(f"{POWERLOSS}/performance.csv", caption="../report/ronkanen_performance.rst",
                           **RONKANEN_REPORT),
        repeatability=report(f"{POWERLOSS}/repeatability.csv", caption="../report/ronkanen_repeatability.rst",
                             **RONKANEN_REPORT),
    params:
        drift_start=lambda w: FIRST_SEGMENT_END[w.dataset]["rk_drift_current"],
        drift_duration=120.0,
    log:
        "logs/{dataset}/powerloss_performance.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_performance.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=10,
    script:
        "../scripts/powerloss_performance.py"


rule powerloss_figures:
    """Figures 2–11 of the paper from the captures and the identified constants."""
    input:
        unpack(lambda w: captures(w.dataset, hold="rk_static_hold", ramps=RONKANEN_VELOCITY_RAMPS,
                                  **RONKANEN_PAIRS)),
        table_1=f"{POWERLOSS}/table_1.csv",
        table_2=f"{POWERLOSS}/table_2.csv",
        identified=f"{POWERLOSS}/identified.csv",
        library=library_sources("powerloss_figures"),
    output:
        **{name: report(f"figures/{{dataset}}/{name}.png", caption=f"../report/ronkanen_fig_{n}.rst", **RONKANEN_REPORT)
           for n, name in RONKANEN_FIGURES.items()},
    params:
        velocity_window=2.0,
        drift_start=lambda w: FIRST_SEGMENT_END[w.dataset]["rk_drift_current"],
    log:
        "logs/{dataset}/powerloss_figures.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_figures.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=10,
    script:
        "../scripts/powerloss_figures.py"


rule powerloss_recovery:
    """Identified R, a, X and c against the twin's true parameters (twin validation)."""
    input:
        unpack(lambda w: captures(w.dataset, capture="rk_static_hold")),
        identified=f"{POWERLOSS}/identified.csv",
        table_1=f"{POWERLOSS}/table_1.csv",
        table_2=f"{POWERLOSS}/table_2.csv",
        library=library_sources("powerloss_recovery"),
    output:
        table=report(f"{POWERLOSS}/recovery.csv", caption="../report/ronkanen_recovery.rst", **RONKANEN_REPORT),
    log:
        "logs/{dataset}/powerloss_recovery.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_recovery.tsv"
    threads: 1
    resources:
        mem_mb=300,
        runtime=5,
    script:
        "../scripts/powerloss_recovery.py"


rule powerloss_truth:
    """Section 7's results from the sensor and from the twin's true displacement, and the sensor's
    share (twin validation: it reads /truth)."""
    input:
        unpack(lambda w: captures(w.dataset, **RONKANEN_PAIRS)),
        identified=f"{POWERLOSS}/identified.csv",
        library=library_sources("powerloss_truth"),
    output:
        report(f"{POWERLOSS}/performance_truth.csv", caption="../report/ronkanen_performance_truth.rst", **RONKANEN_REPORT),
    params:
        drift_start=rules.powerloss_performance.params.drift_start,
        drift_duration=rules.powerloss_performance.params.drift_duration,
    log:
        "logs/{dataset}/powerloss_truth.log",
    benchmark:
        "benchmarks/out/{dataset}/powerloss_truth.tsv"
    threads: 1
    resources:
        mem_mb=config["resources"]["analysis_mem_mb"],
        runtime=10,
    script:
        "../scripts/powerloss_truth.py"


#: what the stage makes for rule all and the scorecard: its rules' outputs, for the datasets each runs for
POWERLOSS_OUTPUTS = (
    expand([*rules.powerloss_identify.output, *rules.powerloss_table_2.output, *rules.powerloss_performance.output,
            *rules.powerloss_figures.output], dataset=POWERLOSS_DATASETS)
    + expand([*rules.powerloss_recovery.output, *rules.powerloss_truth.output], dataset=[d for d in POWERLOSS_DATASETS if d in SIMULATED])
)
