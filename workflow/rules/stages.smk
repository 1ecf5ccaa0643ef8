# Which stages run for each dataset and, for the skipped ones, which of their needs this dataset
# lacks (a dataset without the channels or experiments an analysis needs skips it with a stated
# reason, it does not crash). A stage that runs checks here, before any job, that the manifest
# has the keys it computes with (one line naming the file and the key, not a KeyError mid-run).

from selfsense.io.manifest import require_keys


def _channels(d, *channels):
    return [f"channel {c}" for c in channels if not has_channels(d, c)]


def _runs(d, *runs):
    return [f"run {r}" for r in runs if r not in EXPERIMENTS[d]]


def _after(d, *stages):
    return [f"the {name} stage" for name, which in stages if d not in which]


STAGES = (  # (stage, datasets it runs for, what it needs, what a dataset lacks of it)
    ("characterise", CHARACTERISE_DATASETS, "channel U and a displacement x_laser or x_disp",
     lambda d: _channels(d, "U") + ([] if any(has_channels(d, x) for x in DISPLACEMENT)
                                    else ["a displacement channel x_laser or x_disp"])),
    ("ripple (Ch. 3)", RIPPLE_DATASETS, "ripple channels Ur, Ir with U, I, x_laser and a folding plan (daq.ripple)",
     lambda d: _channels(d, "Ur", "Ir", "U", "I", "x_laser")
     + ([] if "ripple" in DATASETS[d]["daq"] else ["daq.ripple"])),
    ("identify (Ch. 4)", IDENTIFY_DATASETS, "ripple stage, Chapter 4 sine sets and the static stiffness tests",
     lambda d: _after(d, ("ripple", RIPPLE_DATASETS)) + ([] if CH4_SETS[d] else ["runs ch4_sine_*"])
     + _runs(d, "ch4_static_free", "ch4_static_blocked")),
    ("gamma (Ch. 5)", GAMMA_DATASETS, "ripple stage and the 0.1 Hz run ch5_sine_0p1hz",
     lambda d: _after(d, ("ripple", RIPPLE_DATASETS)) + _runs(d, GAMMA_RUN)),
    ("observer (Ch. 5)", OBSERVER_DATASETS, "gamma stage, the Table 5.4 sines, 10–300 Hz sines and ch5_creep",
     lambda d: _after(d, ("gamma", GAMMA_DATASETS)) + ([] if CHARGE_SINES[d] else ["10–300 Hz runs ch5_sine_*"])
     + _runs(d, "ch5_creep") + [f"the {f:g} Hz run ch5_sine_*" for f in TABLE_5_4_HZ if f not in OBSERVED_SINES[d]]),
    ("frequency response (Ch. 5, Fig 5.3)", FREQUENCY_RESPONSE_DATASETS,
     "identify stage and the stepped-sine sweep ch5_sweep",
     lambda d: _after(d, ("identify", IDENTIFY_DATASETS))
     + ([] if EXPERIMENTS[d].get("ch5_sweep") is not None else ["run ch5_sweep (of the ch5 catalogue)"])),
    ("control (Ch. 6)", CONTROL_DATASETS, "observer and identify stages and closed-loop runs",
     lambda d: _after(d, ("observer", OBSERVER_DATASETS), ("identify", IDENTIFY_DATASETS))
     + ([] if CLOSED_LOOP[d] else ["closed-loop runs (of the ch6 catalogue)"])),
    ("thermal (Ch. 7)", THERMAL_DATASETS, "observer and identify stages, the Chapter 7 runs and T_mid",
     lambda d: _after(d, ("observer", OBSERVER_DATASETS), ("identify", IDENTIFY_DATASETS))
     + ([] if sines(d, "ch7_freq_") else ["runs ch7_freq_*"]) + _runs(d, "ch7_volt_150hz", *CH7_CHECKS, *CH7_COUPLED)
     + _channels(d, "T_mid")),
    ("powerloss (Ronkanen)", POWERLOSS_DATASETS, "U, I, i_cmd, x_disp channels and the ronkanen catalogue",
     lambda d: _channels(d, "U", "I", "i_cmd", "x_disp")
     + ([] if "ronkanen" in DATASETS[d]["protocols"] else ["protocols: ronkanen"])),
)

#: manifest keys each stage computes with that the schema leaves optional
STAGE_KEYS = (
    ("identify (Ch. 4)", IDENTIFY_DATASETS, ("actuator.moving_mass_kg", "actuator.dimensions_mm",
                                             "actuator.active_volume_mm3", "actuator.layer_thickness_um")),
    ("thermal (Ch. 7)", THERMAL_DATASETS, ("actuator.thermal",)),
)
for _stage, _which, _keys in STAGE_KEYS:
    for _d in _which:
        require_keys(DATASETS[_d], _keys, RAW / _d / "dataset.yaml", f"the {_stage} stage")


def stage_needs(d, needs, lacks, runs):
    """The needs column: what the stage needs, and for a skipped one what this dataset lacks."""
    return needs if runs else f"{needs}; this dataset lacks: {', '.join(lacks(d)) or 'the stages above'}"


rule stage_plan:
    """Which analyses run for a dataset and, for the skipped ones, what they would need."""
    input:
        manifest=RAW / "{dataset}" / "dataset.yaml",
        library=library_sources("stage_plan"),
    output:
        table=report("results/{dataset}/stages.csv", caption="../report/stages.rst", category="{dataset}",
                     subcategory="Stages"),
    params:
        rows=lambda w: [{"stage": name, "runs": w.dataset in which,
                         "needs": stage_needs(w.dataset, needs, lacks, w.dataset in which)}
                        for name, which, needs, lacks in STAGES],
    log:
        "logs/{dataset}/stage_plan.log",
    benchmark:
        "benchmarks/out/{dataset}/stage_plan.tsv"
    threads: 1
    resources:
        mem_mb=200,
        runtime=5,
    script:
        "../scripts/stage_plan.py"


STAGE_PLAN_OUTPUTS = expand(rules.stage_plan.output, dataset=DATASETS)
