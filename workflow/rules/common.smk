# Config and manifest validation in one place, and the lookups every rule file uses.
import ast
import threading
from functools import cache
from pathlib import Path

from snakemake.utils import validate

from selfsense.io.manifest import PROTOCOLS, SCHEMAS, expand_protocols, load_dataset, protocol_duration, validate_config

# One-line errors first (file and key, or --config), then Snakemake's validate to fill the schema
# defaults. --configfile files override config.yaml; Snakemake lists them before it in
# workflow.configfiles
validate_config(config, " + ".join(dict.fromkeys(str(f) for f in reversed(workflow.configfiles))) or "config",
                dict(workflow.config_settings.config))  # --config alone (overwrite_config has the files too)
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
    a file's nodes, need no visit (ast.walk's visit of them was a quarter of finding the imports)."""
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


def report_figure(name, subcategory):
    """Output figures/<dataset>/<name>.png, filed in the report under its dataset with the caption
    workflow/report/<name>.rst."""
    return report(f"figures/{{dataset}}/{name}.png", caption=f"../report/{name}.rst", category="{dataset}",
                  subcategory=subcategory)


RAW = Path(config["raw_dir"])
DATASETS = {name: load_dataset(RAW, name) for name in config["datasets"]}
SIMULATED = [n for n, m in DATASETS.items() if m["source"] == "simulated"]
MEASURED = [n for n in DATASETS if n not in SIMULATED]


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
