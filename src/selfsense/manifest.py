"""Config, dataset manifests and the experiment catalogue: loading and one-line validation.

The JSON schemas live in workflow/schemas/. Snakemake's own ``validate`` fills their defaults in
the workflow; this module runs the same schemas first so that a bad document fails with one line
naming the file and the offending key, and expands the catalogue into concrete experiments.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import jsonschema
import yaml

ROOT = Path(__file__).resolve().parents[2]
SCHEMAS = ROOT / "workflow" / "schemas"
PROTOCOLS = ROOT / "workflow" / "protocols"
#: dataset names become paths: no separators, no dots at the start
DATASET_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]*$")


class ManifestError(ValueError):
    """A config, manifest or protocol that breaks its schema; one line naming file and key."""


def _where(error: jsonschema.ValidationError) -> str:
    return ".".join(str(p) for p in error.absolute_path) or "(top level)"


def validate_document(doc: Any, schema_name: str, source: str | Path) -> None:
    """Validate ``doc`` against workflow/schemas/<schema_name>; raise ManifestError on the first problem."""
    schema = load_yaml(SCHEMAS / schema_name)
    validator = jsonschema.Draft202012Validator(schema)
    error = jsonschema.exceptions.best_match(validator.iter_errors(doc))
    if error is None:
        return
    if error.validator == "additionalProperties":
        allowed = set(error.schema.get("properties", {}))
        extra = sorted(set(error.instance) - allowed)
        key = f"{_where(error)}.{extra[0]}" if error.absolute_path else extra[0]
        raise ManifestError(f"{source}: unknown key {key} (allowed: {', '.join(sorted(allowed))})")
    if error.validator == "required":
        raise ManifestError(f"{source}: {_where(error)}: {error.message}")
    raise ManifestError(f"{source}: key {_where(error)}: {error.message}")


class _Loader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):
    """YAML 1.1 reads 25.1e6 as a string; physical parameters need YAML 1.2's floats.

    libyaml's parser where PyYAML has it: every job reads the manifests and protocols, and the
    pure-Python parser takes ≈ 0.3 s for them.
    """


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def load_yaml(path: str | Path) -> Any:
    path = Path(path)
    try:
        with open(path) as fh:
            return yaml.load(fh, Loader=_Loader)
    except FileNotFoundError:
        raise ManifestError(f"{path}: no such file") from None
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        line = f" at line {mark.line + 1}" if mark else ""
        raise ManifestError(f"{path}: not valid YAML{line}") from None


def check_dataset_name(name: str, source: str | Path) -> None:
    if not DATASET_NAME.match(name):
        raise ManifestError(f"{source}: dataset name {name!r} must be letters, digits, '_' or '-' "
                            "(no path separators or '..')")


def validate_config(config: Mapping[str, Any], source: str | Path) -> None:
    validate_document(config, "config.schema.yaml", source)
    for name in config["datasets"]:
        check_dataset_name(name, source)


def load_config(path: str | Path) -> dict:
    """config.yaml validated, with the schema's defaults filled in (as the workflow sees it)."""
    config = load_yaml(path)
    validate_config(config, path)
    _fill_defaults(config, load_yaml(SCHEMAS / "config.schema.yaml"))
    return config


def _fill_defaults(doc: dict, schema: Mapping[str, Any]) -> None:
    for key, sub in schema.get("properties", {}).items():
        if key not in doc and "default" in sub:
            doc[key] = sub["default"] if not isinstance(sub["default"], dict) else dict(sub["default"])
        if isinstance(doc.get(key), dict) and sub.get("type") == "object":
            _fill_defaults(doc[key], sub)


def load_dataset(raw_dir: str | Path, name: str) -> dict:
    """The manifest raw/<name>/dataset.yaml, validated; its name must match its folder."""
    path = Path(raw_dir) / name / "dataset.yaml"
    if not path.exists():
        raise ManifestError(f"{path}: unknown dataset {name!r} (no manifest)")
    manifest = load_yaml(path)
    validate_document(manifest, "dataset.schema.yaml", path)
    if manifest["name"] != name:
        raise ManifestError(f"{path}: key name: {manifest['name']!r} does not match its folder {name!r}")
    return manifest


@dataclass(frozen=True)
class Experiment:
    """One capture to make (simulated) or read (measured)."""

    name: str
    chapter: str
    protocol: Mapping[str, Any]  # quantity, segments, and the optional keys below
    load_stiffness: float = 0.0
    control: str = "open_loop"


def expand_protocols(protocol_names: list[str], campaign: str) -> dict[str, Experiment]:
    """The experiment catalogue for a campaign: sets expanded to <name>_s<k>, smoke overrides applied."""
    experiments: dict[str, Experiment] = {}
    for chapter in protocol_names:
        path = PROTOCOLS / f"{chapter}.yaml"
        doc = load_yaml(path)
        validate_document(doc, "protocol.schema.yaml", path)
        for name, entry in doc["experiments"].items():
            entry = dict(entry)
            smoke = entry.pop("smoke", {})
            repeated = "sets" in entry  # names stay <name>_s<k> in every campaign
            if campaign == "smoke":
                entry |= smoke
            sets = int(entry.pop("sets", 1))
            names = [f"{name}_s{k}" for k in range(1, sets + 1)] if repeated else [name]
            for n in names:
                experiments[n] = Experiment(
                    name=n, chapter=chapter,
                    protocol={k: entry[k] for k in ("quantity", "segments", "repeat", "warmup") if k in entry},
                    load_stiffness=float(entry.get("load_stiffness", 0.0)),
                    control=entry.get("control", "open_loop"),
                )
    return experiments
