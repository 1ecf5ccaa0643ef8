# Config and manifest validation in one place, and the lookups every rule file uses.
from pathlib import Path

from snakemake.utils import validate

from selfsense.manifest import expand_protocols, load_dataset, validate_config

# One-line errors first (file and key), then Snakemake's validate to fill the schema defaults.
# --configfile files override config.yaml; Snakemake lists them before it in workflow.configfiles
validate_config(config, " + ".join(dict.fromkeys(str(f) for f in reversed(workflow.configfiles))) or "config")
validate(config, "../schemas/config.schema.yaml")

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
