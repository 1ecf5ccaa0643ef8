# Config and manifest validation in one place, the stage plan, and every helper and name the rule
# files use: the rule files (workflow/rules/*.smk) hold rules and the *_OUTPUTS lists of what they
# make, nothing else, so no rule file depends on another's module-level names.
import ast
import json
import os
import re
import sys
import threading
from functools import cache
from pathlib import Path

from snakemake.utils import validate

from selfsense.chapters import figure_names
from selfsense.chapters.figure_names import loop_pages
from selfsense.methods.cycles import protocol_period
from selfsense.io.manifest import (
    PROTOCOLS,
    SCHEMAS,
    catalogue,
    channel_scalings,
    load_dataset,
    load_yaml,
    needs_identification,
    protocol_duration,
    validate_config,
)
from selfsense.scorecard.calibration import load_targets
from selfsense.scorecard.card import dataset_tables
from selfsense.scorecard.registry import applicable, parse_registry
from selfsense.envelope.design import (
    Design,
    check_chapters,
    check_member_manifests,
    envelope,
    members_asked,
    undrawn,
)
from selfsense.envelope.unknowns import load_unknowns
from selfsense.envelope import campaign as validation_campaign
from selfsense.envelope.validation import load_validation
from selfsense import stages
from selfsense.io import roles

# One-line errors first (file and key, or --config), then Snakemake's validate to fill the schema
# defaults. --configfile files override config.yaml; Snakemake lists them before it in
# workflow.configfiles
CONFIG_SOURCE = (
    " + ".join(dict.fromkeys(str(f) for f in reversed(workflow.configfiles))) or "config"
)
validate_config(
    config, CONFIG_SOURCE, dict(workflow.config_settings.config)
)  # --config alone (overwrite_config has the files too)
validate(config, str(SCHEMAS / "config.schema.yaml"))


def cancel_rescheduling_timers():
    """Cancel the scheduler's pending re-scheduling timers (profiles/default/config.yaml): they are
    not daemon threads, so the interpreter would wait for each before exiting."""
    for thread in threading.enumerate():
        if isinstance(thread, threading.Timer):
            thread.cancel()


onsuccess:
    cancel_rescheduling_timers()


onerror:
    cancel_rescheduling_timers()


#: where the selfsense package's source lives in the checkout: its files are the rules' `library`
#: inputs (the README's install is editable, so this is also the code that runs)
LIBRARY = Path("src")


def _statements(body):
    """Every statement in body, nested ones too: imports are statements, so the expressions, most of
    a file's nodes, need no visit (ast.walk's visit of them was a quarter of finding the imports).
    """
    for node in body:
        yield node
        for field in ("body", "orelse", "finalbody", "handlers", "cases"):
            yield from _statements(getattr(node, field, None) or ())


@cache
def _imported_files(path):
    """The selfsense package's files that the Python file at path imports, anywhere in its code
    (function-level imports too), each with the __init__.py of the packages on the way."""
    path = Path(path)
    package = path.parent.relative_to(LIBRARY).parts if path.is_relative_to(LIBRARY) else ()
    dotted = []
    for node in _statements(ast.parse(path.read_text(), str(path)).body):
        if isinstance(node, ast.Import):
            dotted += [tuple(a.name.split(".")) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else ()
            source = base + (tuple(node.module.split(".")) if node.module else ())
            dotted += [source] + [
                source + (a.name,) for a in node.names
            ]  # a name may be a submodule
    files = set()
    for parts in (d for d in dotted if d[:1] == ("selfsense",)):
        for k in range(1, len(parts) + 1):
            where = LIBRARY.joinpath(*parts[:k])
            if (where / "__init__.py").exists():
                files.add(where / "__init__.py")
            elif where.with_suffix(".py").exists():
                files.add(where.with_suffix(".py"))
    return files


def _followed(script):
    seen, todo = set(), [script]
    while todo:
        for f in _imported_files(todo.pop()) - seen:
            seen.add(f)
            todo.append(f)
    return sorted(str(f) for f in seen)


SCRIPTS = Path("workflow/scripts")
#: every script's library files, kept between runs while no Python file of the library or the
#: scripts changes: following the imports was a tenth of every `snakemake` start (a dry run, and
#: each SLURM job's two)
LIBRARY_SOURCES = Path(".snakemake/selfsense/library_sources.json")


@cache
def _library_sources():
    files = sorted([*LIBRARY.rglob("*.py"), *SCRIPTS.glob("*.py")])
    stamp = [[str(f), s.st_mtime_ns, s.st_size] for f, s in zip(files, map(Path.stat, files))]
    try:
        kept = json.loads(LIBRARY_SOURCES.read_text())
        if kept["stamp"] == stamp:
            return kept["sources"]
    except (OSError, ValueError, KeyError, TypeError):
        pass  # none yet, or unreadable: follow the imports again
    sources = {f.stem: _followed(f) for f in SCRIPTS.glob("*.py")}
    LIBRARY_SOURCES.parent.mkdir(parents=True, exist_ok=True)
    part = LIBRARY_SOURCES.with_name(f".{LIBRARY_SOURCES.name}.{os.getpid()}")
    part.write_text(json.dumps({"stamp": stamp, "sources": sources}))
    os.replace(part, LIBRARY_SOURCES)  # two runs starting at once each write it whole
    return sources


def library_sources(script):
    """Every selfsense file a rule's script runs, found by following imports from
    workflow/scripts/<script>.py: as rule inputs, an edit to the library reruns exactly the rules
    whose code it changes (Snakemake's code trigger sees only the script itself)."""
    return _library_sources()[script]


def report_figure(name, subcategory):
    """Output figures/<dataset>/<name>.png, filed in the report under its dataset with the caption
    workflow/report/<name>.rst."""
    return report(
        f"figures/{{dataset}}/{name}.png",
        caption=f"../report/{name}.rst",
        category="{dataset}",
        subcategory=subcategory,
    )


def report_tables(folder, tables, subcategory):
    """Outputs results/<dataset>/<folder>/<t>.csv, one for each of ``tables``, filed in the report
    under their dataset with the captions workflow/report/<t>.rst."""
    return {
        t: report(
            f"results/{{dataset}}/{folder}/{t}.csv",
            caption=f"../report/{t}.rst",
            category="{dataset}",
            subcategory=subcategory,
        )
        for t in tables
    }


def resources_for(size):
    """A rule's resources (mem_mb [MB], runtime [min]): the named job size of config.yaml's
    resources: section (docs/configuration.md). Every rule takes its resources from here, so a
    site changes one size, not each rule; profiles/slurm turns them into sbatch --mem and -t."""
    return dict(config["resources"][size])


RAW = Path(config["raw_dir"])
DATASETS = {name: load_dataset(RAW, name) for name in config["datasets"]}
# every figure rule's param: a PDF beside each PNG (save_figure)
FIGURE_PDF = config["figures"]["pdf"]

# ---- The envelope (workflow/rules/envelope.smk): its members are datasets of their own,
# <dataset>~NN, each the envelope dataset's manifest with one draw of the unknowns, run by the
# same rules as any dataset. They are in DATASETS for the rules, in no list rule all or the
# report's summary reads (NOMINAL): only `snakemake envelope` asks for them, so they are drawn
# (and their manifests checked against the plan) only when a target names the envelope or a
# member; any other run's parse pays for none of it, whatever the envelope's size.
NOMINAL = list(DATASETS)
UNKNOWNS = "workflow/unknowns.yaml"
# the design read from config here, once: the envelope rules take it as their param
ENVELOPE_DESIGN = Design.from_config(config["envelope"], CONFIG_SOURCE)
ENVELOPE_FOLDER = f"results/envelope/{ENVELOPE_DESIGN.name}"


def requested_targets():
    """The run's target rules, files and jobs (a cluster job's --target-jobs), from its command
    line: Snakemake hands them to the workflow only after the Snakefile is parsed, and whether the
    members are datasets must be known while it is. None when the command line is not
    Snakemake's (the API): then every target may be asked."""
    from snakemake.cli import get_argument_parser  # built already by this run: no cost

    try:
        args = get_argument_parser().parse_known_args(sys.argv[1:])[0]
    except SystemExit:
        return None
    return [str(t) for t in (*args.targets, *(args.target_jobs or ()))]


TARGETS = requested_targets()
if TARGETS is None or members_asked(TARGETS):
    ENVELOPE = envelope(ENVELOPE_DESIGN, DATASETS, load_unknowns(UNKNOWNS, raw_dir=RAW))
    check_member_manifests(ENVELOPE, RAW, f"{ENVELOPE_FOLDER}/plan.csv")
else:
    ENVELOPE = undrawn(ENVELOPE_DESIGN)
DATASETS |= ENVELOPE.manifests

# ---- The validation (workflow/rules/validation.smk): workflow/validation.yaml's waves, each run a
# member as the envelope's (<name>~NNN, rule envelope_member writes its manifest), in batches whose
# tables are kept under results/validation/<name>/ (or committed under docs/snapshot/validation/).
# A batch whose tables exist is done and a source from then on: no rule makes it again, none of
# its members joins the DAG. Drawn only when a target names the validation or one of its members.
VALIDATION_DECLARATION = "workflow/validation.yaml"
VALIDATION_PLAN = validation_campaign.Plan.from_config(config["validation"], CONFIG_SOURCE)
VALIDATION_FOLDER = f"results/validation/{VALIDATION_PLAN.name}"
SNAPSHOT = "docs/snapshot"
VALIDATION_SNAPSHOT = f"{SNAPSHOT}/validation/{VALIDATION_PLAN.name}"
if TARGETS is None or validation_campaign.asked(TARGETS, VALIDATION_PLAN.name):
    if VALIDATION_PLAN.dataset not in DATASETS:
        raise ValueError(
            f"config.yaml: key validation.dataset: {VALIDATION_PLAN.dataset} is not among "
            f"datasets ({', '.join(NOMINAL)})"
        )
    VALIDATION = validation_campaign.draw(
        VALIDATION_PLAN,
        load_validation(VALIDATION_DECLARATION),
        DATASETS[VALIDATION_PLAN.dataset],
        load_unknowns(UNKNOWNS, raw_dir=RAW),
        config["campaign"],
        VALIDATION_FOLDER,
        VALIDATION_SNAPSHOT,
        named=re.findall(rf"{re.escape(VALIDATION_PLAN.name)}~\d+", " ".join(TARGETS or ())),
    )
    check_member_manifests(VALIDATION, RAW, f"{VALIDATION_FOLDER}/plan.csv")
else:
    VALIDATION = validation_campaign.undrawn(VALIDATION_PLAN)
DATASETS |= VALIDATION.manifests
#: every member (the envelope's and the validation's): its manifest, and whose member it is
MEMBERS = {**ENVELOPE.manifests, **VALIDATION.manifests}
MEMBER_BASE = dict.fromkeys(ENVELOPE.manifests, ENVELOPE.design.dataset) | dict.fromkeys(
    VALIDATION.manifests, VALIDATION_PLAN.dataset
)


def envelope_inputs(wildcards):
    """Rule envelope's inputs: the nominal scorecard, every member's, the plan; one line if the
    envelope's dataset is not among the run's."""
    base = ENVELOPE.design.dataset
    if base not in NOMINAL:
        raise ValueError(
            f"config.yaml: key envelope.dataset: {base} is not among datasets "
            f"({', '.join(NOMINAL)})"
        )
    return {
        "nominal": f"results/{base}/scorecard.csv",
        "plan": f"{ENVELOPE_FOLDER}/plan.csv",
        "unit": f"{ENVELOPE_FOLDER}/unit.csv",
        "members": member_inputs(ENVELOPE.manifests),
    }


def nominal(*outputs):
    """The outputs of the run's own datasets, without the envelope members'."""
    return [o for group in outputs for o in group if not any(f"/{m}/" in o for m in MEMBERS)]


SIMULATED = [n for n, m in DATASETS.items() if m["source"] == "simulated"]
MEASURED = [n for n in DATASETS if n not in SIMULATED]


def _experiments(name):
    manifest = DATASETS[name]
    experiments = catalogue(manifest, config["campaign"], RAW / name / "dataset.yaml")
    if manifest["source"] == "measured" and "experiments" in manifest:
        missing = [e for e in manifest["experiments"] if not (RAW / name / f"{e}.nc").exists()]
        if missing:
            raise ValueError(
                f"{RAW / name / 'dataset.yaml'}: experiment {missing[0]} is listed "
                f"without a capture {RAW / name / (missing[0] + '.nc')}"
            )
        listed = {e: experiments.get(e) for e in manifest["experiments"]}
        return roles.assign_roles(
            listed, experiments, manifest.get("roles", {}), str(RAW / name / "dataset.yaml")
        )
    return roles.assign_roles(
        experiments, experiments, manifest.get("roles", {}), str(RAW / name / "dataset.yaml")
    )


EXPERIMENTS = {name: _experiments(name) for name in DATASETS}


#: what a dataset's name may be (the manifest's name, a folder under raw_dir); an envelope
#: member's adds ~ and its number
DATASET_NAME = r"[A-Za-z0-9][A-Za-z0-9_-]*"


wildcard_constraints:
    dataset=DATASET_NAME + r"(~[0-9]+)?",
    experiment=r"[A-Za-z0-9_]+",


def capture_contract(dataset):
    """What rule check_capture holds a measured capture to (selfsense.io.contract reads these
    parts of the manifest, and nothing else): the DAQ (fs, channels, ranges, the ripple's
    folding plan), each sensor's units and the factor its channel was logged through (scale,
    scale_kind: every capture of the dataset was imported with it), the protocols (the
    attributes the Ronkanen runs need). As JSON with sorted keys, a param of the rule: the check
    re-runs when these change, not when the list of experiments grows (the manifest is an
    ancient() input). Not the sensors' descriptions (type, range, resolution): the report's."""
    manifest = DATASETS[dataset]
    sensors = {
        channel: {k: v for k, v in sensor.items() if k in ("units", "scale", "scale_kind")}
        for channel, sensor in manifest.get("sensors", {}).items()
    }
    checked = {
        "daq": manifest["daq"],
        "sensors": {c: s for c, s in sensors.items() if s},
        "protocols": manifest["protocols"],
    }
    return json.dumps(checked, sort_keys=True)


def captures(dataset, **runs):
    """A rule's capture inputs, each with its QC report: {name: raw/<dataset>/<experiment>.nc (a
    list for a list of experiments)} plus "qc", the reports rule check_capture writes for measured
    captures and the twin's rules for the captures they write. Both fail on a bad capture, so
    nothing that reads one runs after it (not even under --keep-going) and a bad capture stops
    with their one-line error."""
    inputs, reports = {}, []
    for name, experiments in runs.items():
        one = isinstance(experiments, str)
        paths = [str(RAW / dataset / f"{e}.nc") for e in ([experiments] if one else experiments)]
        inputs[name] = paths[0] if one else paths
        reports += [f"results/{dataset}/qc/{Path(c).stem}.json" for c in paths]
    return inputs | {"qc": reports}


def protocol_file(dataset, experiment):
    """The catalogue file an experiment comes from: a capture depends on its own protocol only."""
    return str(PROTOCOLS / f"{EXPERIMENTS[dataset][experiment].chapter}.yaml")


def drive_frequency(dataset, experiment):
    """The drive frequency [Hz] the protocol ran: the smoke campaign speeds up the slow sines, so
    it differs from the catalogue's nominal one."""
    return EXPERIMENTS[dataset][experiment].protocol["segments"][0]["frequency"]


def longest_first(wildcards):
    """A simulation's priority, its capture's length in thousands of samples: the longest are
    simulated first, open or closed loop; started last, one of them would keep a core busy alone
    at the end of the run (an envelope member's closed loops run last of all)."""
    return samples(wildcards.dataset, wildcards.experiment) // 1000


def samples(dataset, experiment):
    """How many samples an experiment's capture holds (its fast channels)."""
    protocol = EXPERIMENTS[dataset][experiment].protocol
    return int(protocol_duration(protocol) * DATASETS[dataset]["daq"]["fs"])


# ---- The stage plan (selfsense.stages): which stages run for each dataset and, for the skipped
# ones, what the dataset lacks. Rule stage_plan writes it (results/<dataset>/stages.csv), and the
# *_DATASETS lists below, which gate every rule file, are derived from it and from nothing else.
# A dataset without the channels or experiments a stage needs skips it with a stated reason, it
# does not crash. A stage that runs checks here, before any job, that the manifest has the keys
# it computes with (one line naming the file and the key).

STAGE_PLANS = {d: stages.plan_stages(DATASETS[d], EXPERIMENTS[d]) for d in DATASETS}
for _d, _plan in STAGE_PLANS.items():
    stages.check_manifest_keys(DATASETS[_d], _plan, RAW / _d / "dataset.yaml")


def datasets_running(stage):
    """The datasets the stage (a key of selfsense.stages.STAGES) runs for, in config order."""
    return [d for d in DATASETS if STAGE_PLANS[d].runs(stage)]


def simulated(datasets):
    """Those of the datasets the twin made: only they have a /truth to verify against."""
    return [d for d in datasets if d in SIMULATED]


def with_twin(datasets):
    """Those of the datasets whose manifest describes a twin (its mechanics, for model studies)."""
    return [d for d in datasets if "twin" in DATASETS[d]]


CHARACTERISE_DATASETS = datasets_running("characterise")
RIPPLE_DATASETS = datasets_running("ripple")
CH3_DATASETS = datasets_running("ch3")
IDENTIFY_DATASETS = datasets_running("identify")
GAMMA_DATASETS = datasets_running("gamma")
OBSERVER_DATASETS = datasets_running("observer")
FREQUENCY_RESPONSE_DATASETS = datasets_running("frequency_response")
CONTROL_DATASETS = datasets_running("control")
THERMAL_DATASETS = datasets_running("thermal")
POWERLOSS_DATASETS = datasets_running("powerloss")


#: {dataset: the experiments whose captures it has or the workflow can make}: the captures'
#: table and the characterise stage read these (a simulated dataset's closed-loop runs need the
#: control stage)
CAPTURES = {d: stages.captures_made(DATASETS[d], EXPERIMENTS[d], STAGE_PLANS[d]) for d in DATASETS}


# ---- Characterise: the loop figures' pages


def captures_per_job(dataset):
    """How many captures one characterise_page job takes (config characterise.captures_per_job):
    a simulated dataset's catalogue is fixed, a measured one grows by batches."""
    return config["characterise"]["captures_per_job"][DATASETS[dataset]["source"]]


#: {dataset: {page: its experiments}} of the loop figures: a page is a characterise_page job
LOOP_PAGES = {d: loop_pages(CAPTURES[d], captures_per_job(d)) for d in CHARACTERISE_DATASETS}


def protocol_periods(dataset, experiments):
    """{experiment: its drive's period [s]} of those experiments whose protocol gives one (a
    param of their page's job: only its own captures, so that a new batch changes no earlier
    page's params); the others' is found from their drive."""
    runs = {e: EXPERIMENTS[dataset].get(e) for e in experiments}
    periods = {e: protocol_period(run.protocol) for e, run in runs.items() if run is not None}
    return {e: p for e, p in periods.items() if p is not None}


def loop_page_title(dataset, page):
    """A loop figure page's title. A param of its job, so it never holds what a new batch changes
    (the number of pages of a measured dataset); a page of one capture has its name on its panel."""
    if captures_per_job(dataset) == 1:
        return dataset
    if dataset in SIMULATED:
        return f"{dataset} ({int(page)} of {len(LOOP_PAGES[dataset])})"
    return f"{dataset}, page {int(page)}"


# ---- What the rules make: the names of their tables and figures (figure_names: written once)

CH3_FIGURES, CH3_MODEL_FIGURE = figure_names.CH3, figure_names.CH3_MODEL
CH4_TABLES = ["sets", "table_4_1", "table_4_2", "table_4_3", "hysteresis_voltage"]
CH4_FIGURES = figure_names.CH4
GAMMA_TABLES = {
    "table_5_1": "table_5_1.csv",
    "anova": "table_5_2_anova.csv",
    "coefficients": "table_5_2_coefficients.csv",
    "anova_j5": "table_5_2_anova_j5.csv",
    "coefficients_j5": "table_5_2_coefficients_j5.csv",
    "basis": "gamma_basis.csv",
}
CH5_FIGURES, FREQUENCY_RESPONSE_FIGURE = figure_names.CH5, figure_names.CH5_SWEEP
OBSERVER_STUDY_FIGURE, ERROR_BUDGET_FIGURE = figure_names.CH5_STUDY, figure_names.CH5_BUDGET
CH6_TABLES = ["table_6_1", "p1_summary", "table_6_2", "p3", "tracking"]
CH6_FIGURES = figure_names.CH6
THERMAL_TABLES = ["per_run", "table_7_1", "freq_trend"]
THERMAL_FIGURES = figure_names.CH7_THERMAL
THERMAL_CHECK_TABLES = ["volt_trend", "prediction"]
THERMAL_CHECK_FIGURES = figure_names.CH7_CHECKS
GAMMA_T_FIGURE, FREQUENCY_FIGURE, DIAGRAM_FIGURE = (
    figure_names.CH7_GAMMA_T,
    figure_names.CH7_FREQUENCY,
    figure_names.CH7_DIAGRAM,
)
GAMMA_T_TABLES = {
    "table_7_2": "table_7_2.csv",
    "anova": "table_7_3_anova.csv",
    "coefficients": "table_7_3_coefficients.csv",
    "order": "gamma_t_order.csv",
}
COUPLED_FIGURES = figure_names.CH7_COUPLED
RONKANEN_FIGURES = figure_names.RONKANEN
POWERLOSS = "results/{dataset}/powerloss"
RONKANEN_REPORT = {"category": "{dataset}", "subcategory": "Ronkanen 2002"}  # the report's place


# ---- Runs by role (selfsense.io.roles): which run plays which part is the catalogue's roles:, or
# the manifest's; the rules read runs only through these, never by name


def role_runs(dataset, role):
    """The dataset's runs of a role (a role of several runs: in catalogue order)."""
    return roles.runs(EXPERIMENTS[dataset], role)


def role_run(dataset, role):
    """The dataset's one run of a role (a rule of a stage that needs it, so it has one)."""
    return roles.run(EXPERIMENTS[dataset], role)


def role_paths(pattern, role):
    """An input function: pattern (with {dataset} and {run}) for each run of the role."""
    return lambda w: [pattern.format(dataset=w.dataset, run=e) for e in role_runs(w.dataset, role)]


def role_path(pattern, role):
    """An input function: pattern (with {dataset} and {run}) for the role's one run."""
    return lambda w: pattern.format(dataset=w.dataset, run=role_run(w.dataset, role))


def by_frequency(dataset, role):
    """{nominal drive frequency [Hz]: run} of the dataset's runs of a role."""
    return roles.by_frequency(EXPERIMENTS[dataset], role)


def coupled_runs(dataset):
    """The runs of Figures 7.10–7.12's coupled estimation, in the figures' order."""
    return [role_run(dataset, f"thermal.coupled_{name}") for name in figure_names.CH7_COUPLED]


def protocols_of(dataset, experiments):
    """{experiment: its protocol} (a rule's param: their reference, P1's tests)."""
    return {e: dict(EXPERIMENTS[dataset][e].protocol) for e in experiments}


#: {dataset: {frequency [Hz]: experiment}} of the 10–300 Hz sines a0 is fitted on (Eq 5.3)
CHARGE_SINES = {d: stages.charge_sines(EXPERIMENTS[d]) for d in DATASETS}

#: {dataset: {frequency [Hz]: experiment}} of the sines the observer is evaluated on (Table 5.4)
OBSERVED_SINES = {d: stages.observed_sines(EXPERIMENTS[d]) for d in DATASETS}

#: {dataset: {experiment: Table 5.4 frequency [Hz], None for the creep run}} of every open-loop run
#: the observer is evaluated on
OBSERVED_RUNS = {
    d: {e: f for f, e in OBSERVED_SINES[d].items()} | dict.fromkeys(role_runs(d, "observer.creep"))
    for d in DATASETS
}

#: {dataset: the closed-loop experiments} (audited against the estimate their loop logged)
CLOSED_LOOP = {d: stages.closed_loop(EXPERIMENTS[d]) for d in DATASETS}

#: the closed-loop runs the twin simulates (rule simulate_closed_loop, not rule simulate)
SIMULATED_CLOSED_LOOP = sorted({e for d in SIMULATED for e in CLOSED_LOOP[d]})

#: {dataset: {run: its profile}} of the Chapter 6 runs, open and closed loop
CH6_RUNS = {d: stages.profile_runs(EXPERIMENTS[d]) for d in DATASETS}


def profile_pairs(dataset):
    """{profile: [open-loop run, closed-loop run]} of the Chapter 6 profiles (stages.PROFILES)."""
    return {p: [role_run(dataset, r) for r in pair] for p, pair in stages.PROFILES.items()}


#: {dataset: {run: its profile}} of the runs of Tables 6.1–6.2 whose tracking error the budget splits
TRACKED_RUNS = {
    d: stages.profile_runs(EXPERIMENTS[d], ("P1", "P2a", "P2b", "P2c", "P2d")) for d in DATASETS
}

#: {dataset: {experiment: Table 5.4 frequency [Hz] or None}} of every run the error budget splits:
#: the observer's and the closed loops' whose observer error Chapter 6 tabulates (ε_OCL: P1 in
#: Table 6.1, P2a–d in Table 6.2)
BUDGET_RUNS = {
    d: OBSERVED_RUNS[d] | dict.fromkeys(e for e in TRACKED_RUNS[d] if e in CLOSED_LOOP[d])
    for d in DATASETS
}

#: {dataset: the closed-loop runs the leak study simulates again} (Table 6.2's P2 profiles: seconds each)
LEAK_RUNS = {
    d: [e for e, p in TRACKED_RUNS[d].items() if p != "P1" and e in CLOSED_LOOP[d]]
    for d in DATASETS
}


def ronkanen_runs(dataset, parts):
    """{part: experiment} of the Ronkanen runs of parts ({part: role})."""
    return {part: role_run(dataset, role) for part, role in parts.items()}


def drive_span(dataset, role):
    """(start, end) [s] of the first segment of the role's run: its warm-up's end, where its
    hold starts (Figs 2, 11) or its heating ends (Chapter 7)."""
    protocol = EXPERIMENTS[dataset][role_run(dataset, role)].protocol
    start = float(protocol.get("warmup", 0.0))
    return [start, start + float(protocol["segments"][0]["duration"])]


def first_segment_end(dataset, role):
    """When the first segment of the role's run ends [s] (:func:`drive_span`)."""
    return drive_span(dataset, role)[1]


def identification_runs(dataset):
    """The captures R and the ramps' impedances are identified from (by powerloss_identify):
    {"hold": the static hold, "ramps": every ramp with its fixed trial impedance}."""
    return {
        "hold": role_run(dataset, "powerloss.hold"),
        "ramps": role_runs(dataset, "powerloss.ramp"),
    }


# ---- The twin's simulations: the runs simulated together, and those that need identified
# values (a closed loop, Eq 15's compensation)


def uses_identification(dataset, experiment):
    """Whether the run's protocol compensates with the identified R and c ({R: identified,
    c: identified}, Eq 15)."""
    run = EXPERIMENTS[dataset].get(experiment)
    return run is not None and needs_identification(run.compensation)


def simulated_together(protocols):
    """{name of its rule: (protocol, its runs, the simulated datasets they are made for)}: the runs of a
    protocol of config twin.together are one job, since each costs the twin's start-up (numba's
    compiled kernels loaded, about a second) many times over its simulation (Chapter 4's 22
    half-second sets: 2.5 s in one job, 24 s in 22). Datasets whose catalogues name different runs
    of it (another campaign's sets) get a rule each."""
    rules = {}
    for protocol in protocols:
        if not (PROTOCOLS / f"{protocol}.yaml").is_file():
            raise ValueError(
                f"{CONFIG_SOURCE}: key twin.together: {protocol!r} is no protocol "
                f"of {PROTOCOLS}"
            )
        by_runs = {}
        for d in SIMULATED:
            runs = tuple(e for e, run in EXPERIMENTS[d].items() if run.chapter == protocol)
            if runs:
                by_runs.setdefault(runs, []).append(d)
        for k, (runs, datasets) in enumerate(by_runs.items()):
            apart = [
                e
                for e in runs
                if any(e in CLOSED_LOOP[d] or uses_identification(d, e) for d in datasets)
            ]
            if apart:
                raise ValueError(
                    f"{CONFIG_SOURCE}: key twin.together: protocol {protocol}'s run "
                    f"{apart[0]} needs identified values (a closed loop, a "
                    "compensation): it is simulated on its own"
                )
            rules[f"simulate_{protocol}" + (f"_{k + 1}" if k else "")] = (protocol, runs, datasets)
    return rules


TOGETHER = simulated_together(config["twin"]["together"])
#: the runs simulated together: rule simulate leaves them to those rules
SIMULATED_TOGETHER = sorted({e for _, runs, _ in TOGETHER.values() for e in runs})


def identified_compensation(dataset, experiment):
    """The simulate job's inputs an Eq 15 run reads R and c from: the identification's
    identified.csv (R, from the static hold) and table_2.csv (c of model (10), from the ramps);
    none for every other run. The powerloss stage makes them, so a dataset that skips it cannot
    simulate such a run."""
    if not uses_identification(dataset, experiment):
        return {}
    if dataset not in POWERLOSS_DATASETS:
        raise ValueError(
            f"{protocol_file(dataset, experiment)}: {experiment} compensates with the identified R and "
            f"c, which the powerloss stage identifies; it is skipped for {dataset} "
            f"(results/{dataset}/stages.csv)"
        )
    folder = POWERLOSS.format(dataset=dataset)
    return {"identified": f"{folder}/identified.csv", "table_2": f"{folder}/table_2.csv"}


# the identification must not need itself: its captures are compensated with fixed settings only
for _d in POWERLOSS_DATASETS:
    for _e in [identification_runs(_d)["hold"], *identification_runs(_d)["ramps"]]:
        if uses_identification(_d, _e):
            raise ValueError(
                f"{protocol_file(_d, _e)}: {_e} compensates with the identified R and c, but they are "
                f"identified from it (by powerloss_identify): give it a fixed setting"
            )


# ---- The scorecard and the twin's calibration

SCORECARD_REGISTRY = "workflow/scorecard.yaml"

# parsed once here so that a bad registry stops the workflow with one line before anything runs
SCORECARD = parse_registry(load_yaml(SCORECARD_REGISTRY), SCORECARD_REGISTRY)
check_chapters(
    ENVELOPE.design, [e.chapter for e in SCORECARD if e.kind == "emergent"], CONFIG_SOURCE
)

#: the thesis's printed Γ (Table 5.2, j = 5) and Γ_T (Table 7.3, n = 5 with T) against ours, compared
#: as curves: per fit, the folder, the registry's source and coefficient names, the records compared
#: (the thesis's order and the order the pipeline uses), the temperatures (Table 7.1's T_ref), and the
#: run, ripple series and thermometers (Γ_T) each was fitted on, which rule gamma_truth refits
CURVES = {
    "gamma": {
        "folder": "ch5",
        "source": "Table 5.2",
        "coefficients": [f"b{i}" for i in range(6)],
        "g": None,
        "fits": {"thesis order": "gamma_j5.json", "our order": "gamma.json"},
        "temperatures": [0.0],
        "datasets": GAMMA_DATASETS,
        "role": "gamma.fit",
        "series": "ripple/{run}.nc",
        "power": None,
    },
    "gamma_t": {
        "folder": "ch7",
        "source": "Table 7.3",
        "coefficients": [f"bT{i}" for i in range(6)],
        "g": "g (temperature coefficient)",
        "fits": {"thesis order": "gamma_t_n5.json", "our order": "gamma_t.json"},
        "temperatures": [23.0],
        "datasets": THERMAL_DATASETS,
        "role": "thermal.gamma_t_fit",
        "series": "thermal/{run}_gamma.nc",
        "power": "thermal/{run}.nc",
    },
}


def curve_input(w, part):
    """One curve's (CURVES) file of a dataset: its run's series or power."""
    c = CURVES[w.fit]
    return f"results/{w.dataset}/{c[part].format(run=role_run(w.dataset, c['role']))}"


def curve_fits(w):
    """The Γ records of one curve (CURVES) of one dataset."""
    c = CURVES[w.fit]
    return [f"results/{w.dataset}/{c['folder']}/{f}" for f in c["fits"].values()]


@cache
def stage_outputs():
    """Everything the stages promise to make: each rule file's *_OUTPUTS, as rule all collects
    them. Called by input functions only, so when the DAG is built, after every rule file is
    included (no rule file depends on the order of the includes)."""
    return frozenset(
        ACQUIRE_OUTPUTS
        + RIPPLE_OUTPUTS
        + IDENTIFY_OUTPUTS
        + GAMMA_OUTPUTS
        + OBSERVER_OUTPUTS
        + CONTROL_OUTPUTS
        + THERMAL_OUTPUTS
        + POWERLOSS_OUTPUTS
        + CHARACTERISE_OUTPUTS
        + CURVE_OUTPUTS
        + VERIFY_OUTPUTS
    )


def scorecard_tables(dataset):
    """The registry's tables (and those its reference values are compared with) that some stage
    makes for the dataset: the scorecard reads (and reruns after) exactly these; the other entries
    show as "not reproduced yet". An envelope member's: its emergent and calibration rows' only
    (what the envelope reads)."""
    entries = applicable(SCORECARD, DATASETS[dataset])
    if dataset in ENVELOPE.manifests:  # the numbers' own tables, not those explaining them
        read = list(
            dict.fromkeys(
                e.locate.table
                for e in entries
                if e.kind in ("emergent", "calibration")
                and e.locate
                and ENVELOPE.design.judges(e.chapter)
            )
        )
    elif dataset in VALIDATION.manifests:  # every chapter's: the declaration folds them all
        read = list(
            dict.fromkeys(
                e.locate.table
                for e in entries
                if e.kind in ("emergent", "calibration") and e.locate
            )
        )
    else:
        read = dataset_tables(SCORECARD, DATASETS[dataset])
    return [t for t in (f"results/{dataset}/{t}" for t in read) if t in stage_outputs()]


def earlier_scorecards():
    """{dataset: its scorecard} of every other dataset under raw_dir whose scorecard an earlier
    run left in results/ (found now, when the workflow is parsed): the project-wide summary
    covers them beside this run's, as they are (this run makes none of them again)."""
    found = {}
    for folder in sorted(RAW.iterdir()) if RAW.is_dir() else ():
        card = Path("results") / folder.name / "scorecard.csv"
        if (
            folder.name not in DATASETS
            and re.fullmatch(DATASET_NAME, folder.name)
            and (folder / "dataset.yaml").is_file()
            and card.is_file()
        ):
            found[folder.name] = str(card)
    return found


EARLIER_SCORECARDS = earlier_scorecards()


TWIN_CALIBRATION_TARGETS = "workflow/twin_calibration.yaml"

# parsed once here so that a bad targets file stops the workflow with one line before anything runs
TWIN_CALIBRATION = load_targets(TWIN_CALIBRATION_TARGETS)

#: datasets the twin made of the thesis's stack: the targets are the thesis's numbers
CALIBRATED_DATASETS = [d for d in SIMULATED if DATASETS[d].get("model") == "stack"]


def calibration_tables(dataset):
    """The tables of the twin's calibration signatures that some stage makes for the dataset: the
    others are rows "not measured"."""
    return [
        t
        for t in (f"results/{dataset}/{t}" for t in TWIN_CALIBRATION.tables())
        if t in stage_outputs()
    ]


# ---- The validation's rules' inputs (workflow/rules/validation.smk)


def member_results(member):
    """What is read of a member, under results/<member>/: its scorecard, and a validation
    member's tables its common targets read (those its stages make)."""
    if member in ENVELOPE.manifests:
        return ["scorecard.csv"]
    made = stage_outputs()
    tables = [t for t in VALIDATION.tables if f"results/{member}/{t}" in made]
    return ["scorecard.csv", *tables]


def member_job(member):
    """Where a member run as one job keeps what is read of it, or None when its rules run as
    the jobs of any dataset (envelope.in_process, validation.in_process)."""
    envelope = member in ENVELOPE.manifests
    if not config["envelope" if envelope else "validation"]["in_process"]:
        return None
    return f"{ENVELOPE_FOLDER if envelope else VALIDATION_FOLDER}/members/{member}"


def member_failure(member):
    """The file a validation member's one job notes a failed step in (its bench's analysis
    failing is a result of the ensemble: the member gives no value), or None: an envelope
    member's failure fails its job."""
    return validation_campaign.FAILED if member in VALIDATION.manifests else None


def member_file(member, name):
    """Where a member's results/<member>/<name> is read: its one job's folder, or the rules'."""
    folder = member_job(member)
    return f"{folder or f'results/{member}'}/{name}"


def member_inputs(members):
    """The inputs that make members' results: their one jobs' folders, or the files themselves."""
    inputs = []
    for m in members:
        job = member_job(m)
        inputs += [job] if job else [f"results/{m}/{r}" for r in member_results(m)]
    return inputs


#: the folders under results/ of the members run as one job (rules member_steps and member), as
#: their wildcard's pattern
MEMBER_FOLDERS = "|".join(
    re.escape(f.removeprefix("results/")) for f in (ENVELOPE_FOLDER, VALIDATION_FOLDER)
)


def group_members(folder, group):
    """The members whose steps one job of member_steps makes, ``folder`` a path under results/;
    all the envelope's, or one validation batch's."""
    if f"results/{folder}" == ENVELOPE_FOLDER:
        return list(ENVELOPE.manifests)
    return VALIDATION.batch(group).members


def member_steps_file(member):
    """The steps file of a member's group (rule member_steps)."""
    if member in ENVELOPE.manifests:
        return f"{ENVELOPE_FOLDER}/steps/all.json"
    batch = next(b.id for b in VALIDATION.batches if member in b.members)
    return f"{VALIDATION_FOLDER}/steps/{batch}.json"


def member_read(wildcards):
    """Rule validation_batch's [member, name under results/<member>/, file] of each member's
    results."""
    members = VALIDATION.batch(wildcards.batch).members
    return [[m, r, member_file(m, r)] for m in members for r in member_results(m)]


def member_failures(wildcards):
    """Rule validation_batch's {member: where its one job notes a failed step} (none through the
    rules: there a failed step fails its job)."""
    members = VALIDATION.batch(wildcards.batch).members
    return {m: member_file(m, validation_campaign.FAILED) for m in members if member_job(m)}


def validation_batch_inputs(wildcards):
    """Rule validation_batch's inputs: what makes each member's results."""
    return {"results": member_inputs(VALIDATION.batch(wildcards.batch).members)}


RULE_FILES = sorted(str(f) for f in Path("workflow/rules").glob("*.smk"))


def workflow_sources():
    """Every file of the library, the scripts and the rules: what a member run in one process
    (rule member) runs, so an edit to any of them runs it again."""
    library = sorted({f for files in _library_sources().values() for f in files})
    return [*library, *map(str, sorted(SCRIPTS.glob("*.py"))), "Snakefile", *RULE_FILES]


def validation_tables(kinds, waves=None):
    """The batches' tables of kinds (inputs, plan, rows, targets), done and made by this run, of
    the waves given (None: all), in run order: where a done batch's are, or where this run
    writes them."""
    return [
        f"{VALIDATION.folder(b.id, VALIDATION_FOLDER)}/{validation_campaign.TABLES[k]}"
        for b in VALIDATION.batches
        if (b.id in VALIDATION.done or b.id in VALIDATION.selected)
        and (waves is None or b.wave in waves)
        for k in kinds
    ]


def validate_inputs(wildcards):
    """Rule validate's inputs: every batch's tables (done, or made by this run; the joined
    validations' committed ones first), the later waves' designs, and the next wave's when
    this run makes it."""
    designs = list(VALIDATION.designs.values())
    if VALIDATION.design_wave is not None:
        designs.append(f"{VALIDATION_FOLDER}/wave{VALIDATION.design_wave}/design.csv")

    def tables(kind):
        name = validation_campaign.TABLES[kind]
        return [f"{b}/{name}" for b in VALIDATION.joined] + validation_tables([kind])

    return {
        "units": tables("inputs"),
        "rows": tables("rows"),
        "targets": tables("targets"),
        "designs": designs,
    }


def validation_judges(wildcards):
    """Rule validation_review's other judges of the validation's rows, as committed under
    docs/snapshot/: the dataset's nominal scorecard and its envelopes' scorecards, those that
    exist."""
    dataset = VALIDATION_PLAN.dataset
    nominal = Path(SNAPSHOT) / f"scorecard_{dataset}.csv"
    envelopes = sorted(Path(SNAPSHOT, "envelope").glob(f"{dataset}*/scorecard.csv"))
    return {
        "nominal": [str(nominal)] if nominal.exists() else [],
        "envelopes": [str(p) for p in envelopes],
    }


def validation_wave_inputs(wildcards):
    """Rule validation_wave's inputs: the earlier waves' members × inputs and members × targets
    (never their rows: the waves are cut on the common targets only)."""
    earlier = range(1, int(wildcards.wave))
    return {
        "units": validation_tables(["inputs"], earlier),
        "targets": validation_tables(["targets"], earlier),
    }


#: what the declaration's loader reads besides the declaration and the registry: the signatures,
#: the protocols and the dataset's manifest
VALIDATION_SOURCES = [
    "workflow/twin_calibration.yaml",
    *sorted(str(p) for p in Path("workflow/protocols").glob("*.yaml")),
    str(RAW / VALIDATION_PLAN.dataset / "dataset.yaml"),
]
