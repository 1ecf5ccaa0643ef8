# Config and manifest validation in one place, and the lookups every rule file uses.
import ast
from functools import cache
from pathlib import Path

from snakemake.utils import validate

from selfsense.manifest import expand_protocols, load_dataset, validate_config

# One-line errors first (file and key), then Snakemake's validate to fill the schema defaults.
# --configfile files override config.yaml; Snakemake lists them before it in workflow.configfiles
validate_config(config, " + ".join(dict.fromkeys(str(f) for f in reversed(workflow.configfiles))) or "config")
validate(config, "../schemas/config.schema.yaml")

#: where the selfsense package's source lives (the README's install is editable: this is the code
#: that runs)
LIBRARY = Path("src")


@cache
def _imported_files(path):
    """The selfsense package's files that the Python file at path imports, anywhere in its code
    (function-level imports too), each with the __init__.py of the packages on the way."""
    path = Path(path)
    package = path.parent.relative_to(LIBRARY).parts if path.is_relative_to(LIBRARY) else ()
    dotted = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            dotted += [tuple(a.name.split(".")) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else ()
            source = base + (tuple(node.module.split(".")) if node.module else ())
            dotted += [source] + [source + (a.name,) for a in node.names]  # a name may be a submodule
    files = set()
    for parts in (d for d in dotted if d[:1] == ("selfsense",)):
        for k in range(1, len(parts) + 1):
            where = LIBRARY.joinpath(*parts[:k])
            if (where / "__init__.py").exists():
                files.add(where / "__init__.py")
            elif where.with_suffix(".py").exists():
                files.add(where.with_suffix(".py"))
    return files


def library_sources(script):
    """Every selfsense file a rule's script runs, found by following imports from
    workflow/scripts/<script>.py: as rule inputs, an edit to the library reruns exactly the rules
    whose code it changes (Snakemake's code trigger sees only the script itself)."""
    seen, todo = set(), [Path("workflow/scripts") / f"{script}.py"]
    while todo:
        for f in _imported_files(todo.pop()) - seen:
            seen.add(f)
            todo.append(f)
    return sorted(str(f) for f in seen)


RAW = Path(config["raw_dir"])
DATASETS = {name: load_dataset(RAW, name) for name in config["datasets"]}
SIMULATED = [n for n, m in DATASETS.items() if m["source"] == "simulated"]


def _experiments(name):
    manifest = DATASETS[name]
    catalogue = expand_protocols(manifest["protocols"], config["campaign"])
    if manifest["source"] == "measured" and "experiments" in manifest:
        missing = [e for e in manifest["experiments"] if not (RAW / name / f"{e}.nc").exists()]
        if missing:
            raise ValueError(f"{RAW / name / 'dataset.yaml'}: experiment {missing[0]} is listed "
                             f"without a capture {RAW / name / (missing[0] + '.nc')}")
        return {e: catalogue.get(e) for e in manifest["experiments"]}
    return catalogue


EXPERIMENTS = {name: _experiments(name) for name in DATASETS}


wildcard_constraints:
    dataset=r"[A-Za-z0-9][A-Za-z0-9_-]*",
    experiment=r"[A-Za-z0-9_]+",


def closed_loop(dataset):
    return [e for e, x in EXPERIMENTS[dataset].items() if x is not None and x.control == "closed_loop"]


def captures(dataset, prefix=""):
    """Capture paths of a dataset, optionally only experiments whose name starts with prefix."""
    return [str(RAW / dataset / f"{e}.nc") for e in EXPERIMENTS[dataset] if e.startswith(prefix)]


def protocol_file(dataset, experiment):
    """The catalogue file an experiment comes from: a capture depends on its own protocol only."""
    return f"workflow/protocols/{EXPERIMENTS[dataset][experiment].chapter}.yaml"


def has_channels(dataset, *channels):
    return set(channels) <= set(DATASETS[dataset]["daq"]["channels"])


def experiment_frequency(name):
    """Drive frequency [Hz] from a catalogue name such as ch5_sine_0p1hz."""
    token = next((t for t in name.split("_") if t.endswith("hz")), None)
    return float(token[:-2].replace("p", ".")) if token else None


def sines(dataset, prefix):
    """{frequency [Hz]: experiment} for the experiments named <prefix><f>hz."""
    return {experiment_frequency(e): e for e in EXPERIMENTS[dataset] if e.startswith(prefix)}


def drive_frequency(dataset, experiment):
    """The drive frequency [Hz] the protocol ran: the smoke campaign speeds up the slow sines, so
    it differs from the name's."""
    run = EXPERIMENTS[dataset][experiment]
    return run.protocol["segments"][0]["frequency"] if run is not None else experiment_frequency(experiment)


# ---------------------------------------------------------------- stage acquire (its rules: acquire.smk)
def acquire_outputs():
    return [f"results/{d}/qc/captures.csv" for d in DATASETS]


# ---------------------------------------------------------------- stage ripple (its rules: ripple.smk)
CH3_SERIES = {"10 Hz": "ch3_sine_10hz", "1 Hz": "ch3_sine_1hz", "0.1 Hz": "ch3_sine_0p1hz"}


CH3_FIGURES = ["fig_3_3", "fig_3_4", "fig_3_7", "fig_3_9", "fig_3_10", "fig_3_11", "fig_3_12",
               "fig_3_13", "fig_3_14"]


def ripple_datasets():
    """Datasets whose DAQ records the ripple channels (the others skip this stage)."""
    return [d for d in DATASETS if has_channels(d, "Ur", "Ir", "U", "I", "x_laser") and "ripple" in DATASETS[d]["daq"]]


def ch3_datasets():
    return [d for d in ripple_datasets() if set(CH3_SERIES.values()) <= set(EXPERIMENTS[d])]


def ch3_figure_names(dataset):
    return CH3_FIGURES + (["fig_3_2", "fig_3_np_study"] if "twin" in DATASETS[dataset] else [])


def ripple_outputs():
    out = []
    for d in ripple_datasets():
        out += [f"results/{d}/ch3/table_3_1.csv", f"results/{d}/ch3/table_3_2.csv"]
    for d in ch3_datasets():
        out += [f"results/{d}/ch3/hysteresis.csv"]
        out += [f"figures/{d}/{name}.png" for name in ch3_figure_names(d)]
        if "twin" in DATASETS[d]:
            out += [f"results/{d}/twin/ce_recovery.csv", f"results/{d}/twin/ce_np_study.csv"]
    return out


# ---------------------------------------------------------------- stage identify (its rules: identify.smk)
CH4_FIGURES = ["fig_4_2", "fig_4_3", "fig_4_4", "fig_4_5", "fig_4_6", "fig_4_7", "fig_4_8"]


CH4_TABLES = ["sets", "table_4_1", "table_4_2", "table_4_3", "hysteresis_voltage"]


def ch4_sets(dataset):
    return [e for e in EXPERIMENTS[dataset] if e.startswith("ch4_sine_")]


def identify_datasets():
    """Datasets with the ripple channels, the Chapter 4 sets and the static stiffness test."""
    return [d for d in ripple_datasets() if ch4_sets(d)
            and {"ch4_static_free", "ch4_static_blocked"} <= set(EXPERIMENTS[d])]


def identify_outputs():
    out = []
    for d in identify_datasets():
        out += [f"results/{d}/ch4/{t}.csv" for t in CH4_TABLES + ["static_stiffness"]]
        out += [f"results/{d}/ch4/model.json"] + [f"figures/{d}/{f}.png" for f in CH4_FIGURES]
        if "twin" in DATASETS[d]:
            out.append(f"results/{d}/twin/model_recovery.csv")
    return out


# ---------------------------------------------------------------- stage gamma (its rules: gamma.smk)
GAMMA_TABLES = {"table_5_1": "table_5_1.csv", "anova": "table_5_2_anova.csv",
                "coefficients": "table_5_2_coefficients.csv", "basis": "gamma_basis.csv"}


GAMMA_RUN = "ch5_sine_0p1hz"  # Γ is fitted on the 0.1 Hz run (Tables 5.1, 5.2)


def gamma_datasets():
    return [d for d in ripple_datasets() if GAMMA_RUN in EXPERIMENTS[d]]


def gamma_outputs():
    return [f"results/{d}/ch5/{f}" for d in gamma_datasets() for f in list(GAMMA_TABLES.values()) + ["gamma.json"]]


# ---------------------------------------------------------------- stage observer (its rules: observer.smk)
CH5_FIGURES = ["fig_5_1", "fig_5_2", "fig_5_4", "fig_5_5", "fig_5_6", "fig_5_7", "fig_5_8", "fig_5_10", "fig_5_12",
               "fig_5_13", "fig_5_14"]


TABLE_5_4_HZ = (0.01, 0.1, 1.0, 10.0, 50.0, 100.0)


def charge_sines(dataset):
    return {f: e for f, e in sines(dataset, "ch5_sine_").items() if f >= 10}


def observed_sines(dataset):
    return {f: e for f, e in sines(dataset, "ch5_sine_").items() if f in TABLE_5_4_HZ}


def observer_datasets():
    return [d for d in gamma_datasets() if charge_sines(d) and "ch5_creep" in EXPERIMENTS[d]
            and len(observed_sines(d)) == len(TABLE_5_4_HZ)]


def frequency_response_datasets():
    """Datasets with the identified model (Chapter 4) and the stepped-sine sweep ch5_sweep."""
    return [d for d in identify_datasets() if EXPERIMENTS[d].get("ch5_sweep") is not None]


def observer_outputs():
    out = []
    for d in frequency_response_datasets():
        out += [f"results/{d}/ch5/{t}.csv" for t in ("frequency_response", "resonance")]
        out += [f"figures/{d}/fig_5_3.png"]
    for d in observer_datasets():
        out += [f"results/{d}/ch5/{t}.csv" for t in ("charge_sensing", "table_5_3", "table_5_4", "creep",
                                                     "observer_study")]
        out += [f"figures/{d}/{f}.png" for f in CH5_FIGURES + ["fig_5_observer_study"]]
    return out


# ---------------------------------------------------------------- stage control (its rules: control.smk)
CH6_TABLES = ["table_6_1", "table_6_2", "p3", "tracking"]


CH6_FIGURES = ["fig_6_2", "fig_6_3", "fig_6_4", "fig_6_5", "fig_6_6", "fig_6_7", "fig_6_8"]


def ch6_runs(dataset):
    return [e for e in EXPERIMENTS[dataset] if e.startswith("ch6_")]


def control_datasets():
    return [d for d in observer_datasets() if closed_loop(d) and d in identify_datasets()]


def control_outputs():
    out = []
    for d in control_datasets():
        out += [f"results/{d}/ch6/{t}.csv" for t in CH6_TABLES + ["audit"]]
        out += [f"figures/{d}/{f}.png" for f in CH6_FIGURES]
    return out


# ---------------------------------------------------------------- stage thermal (its rules: thermal.smk)
CH7_COUPLED = ["ch7_freq_100hz", "ch7_freq_50hz", "ch7_mixed_ae"]


CH7_CHECKS = ["ch7_heat_cool", "ch7_mixed_voltage"]


THERMAL_TABLES = ["per_run", "table_7_1", "freq_trend", "volt_trend", "prediction"]


GAMMA_T_TABLES = {"table_7_2": "table_7_2.csv", "anova": "table_7_3_anova.csv",
                  "coefficients": "table_7_3_coefficients.csv"}


def thermal_datasets():
    return [d for d in observer_datasets() if d in identify_datasets() and sines(d, "ch7_freq_")
            and {"ch7_volt_150hz", *CH7_CHECKS, *CH7_COUPLED} <= set(EXPERIMENTS[d]) and has_channels(d, "T_mid")]


def thermal_outputs():
    out = []
    for d in thermal_datasets():
        out += [f"results/{d}/ch7/{t}.csv" for t in THERMAL_TABLES + ["coupled", "frequency_effect"]]
        out += [f"results/{d}/ch7/{v}" for v in GAMMA_T_TABLES.values()]
        out += [f"figures/{d}/fig_7_{n}.png" for n in (1, 2, 3, 5, 6, 7, 8, 9, 10, 11, 12)]
        if "twin" in DATASETS[d]:
            out.append(f"results/{d}/twin/thermal_recovery.csv")
    return out


# ---------------------------------------------------------------- stage powerloss (its rules: powerloss.smk)
POWERLOSS = "results/{dataset}/powerloss"


RONKANEN_FIGURES = {n: f"fig_ronkanen_{n}" for n in range(2, 12)}  # paper figure: file name


#: the open-loop comparison: {kind: {control: experiment}}
RONKANEN_PAIRS = {kind: {control: f"rk_{kind}_{control}" for control in ("current", "voltage")}
                  for kind in ("decay", "repeat", "drift")}


#: Fig 3, 4, 5 (and 6): the ±300 nA ramps with too large, too small and ideal compensation
RONKANEN_VELOCITY_RAMPS = ["rk_ramp_300na_10g", "rk_ramp_300na_1g", "rk_ramp_300na_2g"]


def powerloss_datasets():
    """Datasets whose DAQ records the current drive and that run the Ronkanen catalogue."""
    return [d for d in DATASETS
            if has_channels(d, "U", "I", "i_cmd", "x_disp") and "ronkanen" in DATASETS[d]["protocols"]]


def powerloss_outputs():
    out = []
    for d in powerloss_datasets():
        out += [f"results/{d}/powerloss/{t}.csv"
                for t in ("ramps", "table_1", "identified", "table_2", "performance", "repeatability")]
        out += [f"figures/{d}/{name}.png" for name in RONKANEN_FIGURES.values()]
        if "twin" in DATASETS[d]:
            out.append(f"results/{d}/powerloss/recovery.csv")
    return out


def first_segment_end(dataset, experiment):
    """When an experiment's first segment ends [s]: where the hold starts (Figs 2, 11)."""
    protocol = EXPERIMENTS[dataset][experiment].protocol
    return float(protocol.get("warmup", 0.0)) + float(protocol["segments"][0]["duration"])


def pair_captures(wildcards):
    """{"<kind>_<control>": capture} of the current-vs-voltage comparison runs."""
    return {f"{kind}_{control}": str(RAW / wildcards.dataset / f"{e}.nc")
            for kind, pair in RONKANEN_PAIRS.items() for control, e in pair.items()}


def ronkanen_report(path, caption):
    return report(path, caption=f"../report/ronkanen_{caption}.rst", category="{dataset}",
                  subcategory="Ronkanen 2002")


# ---------------------------------------------------------------- stage stages (its rules: stages.smk)
STAGES = (  # (stage, datasets it runs for, what it needs)
    ("ripple (Ch. 3)", ripple_datasets, "ripple channels Ur, Ir with U, I, x_laser and a folding plan (daq.ripple)"),
    ("identify (Ch. 4)", identify_datasets, "ripple stage, Chapter 4 sine sets and the static stiffness tests"),
    ("gamma (Ch. 5)", gamma_datasets, "ripple stage and the 0.1 Hz run ch5_sine_0p1hz"),
    ("observer (Ch. 5)", observer_datasets, "gamma stage, the Table 5.4 sines, 10–300 Hz sines and ch5_creep"),
    ("frequency response (Ch. 5, Fig 5.3)", frequency_response_datasets, "identify stage and the stepped-sine sweep ch5_sweep"),
    ("control (Ch. 6)", control_datasets, "observer and identify stages and closed-loop runs"),
    ("thermal (Ch. 7)", thermal_datasets, "observer and identify stages, the Chapter 7 runs and T_mid"),
    ("powerloss (Ronkanen)", powerloss_datasets, "U, I, i_cmd, x_disp channels and the ronkanen catalogue"),
)


def stage_rows(dataset):
    return [{"stage": name, "runs": dataset in which(), "needs": needs} for name, which, needs in STAGES]


# ---------------------------------------------------------------- report (report.smk)
from selfsense.manifest import load_yaml

from selfsense.scorecard import applicable, parse_registry, tables_read


SCORECARD_REGISTRY = "workflow/scorecard.yaml"


# parsed once here so that a bad registry stops the workflow with one line before anything runs
SCORECARD = parse_registry(load_yaml(SCORECARD_REGISTRY), SCORECARD_REGISTRY)


def report_outputs():
    return [f"results/{d}/scorecard.csv" for d in DATASETS] + ["results/scorecard_summary.rst"]


def stage_outputs():
    """Everything the stages promise to make (each stage's *_outputs(), as rule all collects them)."""
    return set(acquire_outputs() + ripple_outputs() + identify_outputs() + gamma_outputs()
               + observer_outputs() + control_outputs() + thermal_outputs() + powerloss_outputs())


def scorecard_tables(dataset):
    """The registry's tables that some stage makes for this dataset: the scorecard reads (and
    reruns after) exactly these; the registry's other entries show as "not reproduced yet"."""
    made = stage_outputs()
    wanted = [f"results/{dataset}/{t}" for t in tables_read(applicable(SCORECARD, DATASETS[dataset]))]
    return [t for t in wanted if t in made]
