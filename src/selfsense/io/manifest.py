"""Config, dataset manifests and the experiment catalogue: loading and one-line validation.

The JSON schemas are package data (``selfsense/io/schemas``): they are the library's contracts, so
an installed package (editable or not) has them. Snakemake's own ``validate`` fills their
defaults in the workflow; this module runs the same schemas first so that a bad document fails
with one line naming the file and the offending key, and expands the catalogue into concrete
experiments. The catalogue (``workflow/protocols``) belongs to the workflow and is found from
the folder it runs in (or given).
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from functools import cache, lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import jsonschema
import yaml

from selfsense.io.roles import catalogue_roles

SCHEMAS = resources.files("selfsense.io") / "schemas"
#: the experiment catalogue, relative to the folder the workflow (or a script run alone) runs in
PROTOCOLS = Path("workflow") / "protocols"
#: dataset names become paths: no separators, no dots at the start (matched whole: "$" alone
#: would let a trailing newline through)
DATASET_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]*")
#: protocol names too (workflow/protocols/<name>.yaml): the same rule
PROTOCOL_NAME = DATASET_NAME
#: experiment names become file names and Snakemake wildcards (no "-": the wildcard excludes it)
EXPERIMENT_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_]*")
#: YAML nested deeper than this is refused before it is built: libyaml's composer recurses in C,
#: and ≈ 100 000 levels overflow the stack (SIGSEGV) instead of raising
MAX_YAML_DEPTH = 100
#: and so is a manifest or config larger than this (they are a few kB)
MAX_YAML_BYTES = 4 << 20
#: and one whose nodes, aliases expanded, outnumber this: nine aliases of nine aliases of … make
#: 9⁹ nodes of 750 bytes, which every walk of the document (the finite-value check, the schema)
#: visits one by one. The largest shipped YAML, workflow/scorecard.yaml, has 7 579 (13× fewer)
MAX_YAML_NODES = 100_000


class ManifestError(ValueError):
    """A config, manifest or protocol that breaks its schema; one line naming file and key."""

    def __init__(self, message: str, key: str | None = None):
        super().__init__(message)
        self.key = key


def _shown(key: Any) -> str:
    """A key as an error line shows it: as written if a printable string (of a sane length),
    else quoted and escaped (a key of a hostile document may hold a line break)."""
    text = key if isinstance(key, str) and key.isprintable() else repr(key)
    return text if len(text) <= 60 else text[:57] + "..."


def _where(error: jsonschema.ValidationError) -> str:
    return ".".join(_shown(p) for p in error.absolute_path) or "(top level)"


def validate_document(doc: Any, schema_name: str, source: str | Path) -> None:
    """Validate ``doc`` against the schema <schema_name>; raise ManifestError on the first
    problem."""
    _check_finite(doc, source)
    error = jsonschema.exceptions.best_match(_validator(schema_name).iter_errors(doc))
    if error is None:
        return
    if error.validator == "additionalProperties":
        allowed = set(error.schema.get("properties", {}))
        extra = sorted(map(_shown, set(error.instance) - allowed))
        key = f"{_where(error)}.{extra[0]}" if error.absolute_path else extra[0]
        raise ManifestError(
            f"{source}: unknown key {key} (allowed: {', '.join(sorted(allowed))})", key
        )
    if error.validator == "required":
        raise ManifestError(f"{source}: {_where(error)}: {error.message}", _where(error))
    raise ManifestError(f"{source}: key {_where(error)}: {error.message}", _where(error))


@cache
def _validator(schema_name: str) -> jsonschema.Draft202012Validator:
    """The validator of a schema of the package, built once: the workflow's parse validates every
    manifest and protocol against the same few."""
    return jsonschema.Draft202012Validator(load_yaml(SCHEMAS / schema_name))


def _check_finite(doc: Any, source: str | Path, where: str = "") -> None:
    """No NaN or infinity anywhere: JSON Schema's bounds let NaN through (every comparison with
    NaN is false), and no physical quantity, rate or range of ours is infinite."""
    if isinstance(doc, float) and not math.isfinite(doc):
        key = where or "(top level)"
        raise ManifestError(f"{source}: key {key}: {doc} is not a finite number", key)
    items = (
        doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    )
    for k, v in items:
        _check_finite(v, source, f"{where}.{_shown(k)}" if where else _shown(k))


class _DuplicateKey(Exception):
    """A mapping's key given twice (raised while constructing; load_yaml names the file)."""

    def __init__(self, key: Any, line: int):
        super().__init__(key, line)
        self.key, self.line = key, line


class _Loader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):
    """YAML 1.1 reads 25.1e6 as a string; physical parameters need YAML 1.2's floats.

    libyaml's parser where PyYAML has it: every job reads the manifests and protocols, and the
    pure-Python parser takes ≈ 0.3 s for them.

    A key given twice in one mapping is refused (PyYAML keeps the last silently): each mapping is
    checked once, before merge keys (``<<: *anchor``) bring in the keys its own may override.
    """

    def __init__(self, stream: Any):
        super().__init__(stream)
        self._checked: set[int] = set()

    def flatten_mapping(self, node: yaml.MappingNode) -> None:
        # construct_mapping flattens every mapping first, and flattening recurses into the
        # merged ones: so every mapping passes here before its merged keys are added
        if id(node) not in self._checked:
            self._checked.add(id(node))
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge" or not isinstance(
                    key_node, yaml.ScalarNode
                ):
                    continue
                key = self.construct_object(key_node)
                try:
                    if key in seen:
                        raise _DuplicateKey(key, key_node.start_mark.line + 1)
                    seen.add(key)
                except TypeError:  # unhashable: the constructor refuses it itself
                    continue
        super().flatten_mapping(node)


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def _expanded_size(text: str, path: str | Path) -> None:
    """Refuse, from the parser's events alone (nothing composed yet), a document nested deeper
    than MAX_YAML_DEPTH or with more than MAX_YAML_NODES nodes, both counted with every alias
    replaced by the node it names, as a walk of the loaded document sees them."""
    nodes = 0  # nodes so far, aliases expanded
    aliased = False
    #: anchor → (nodes, height) of its node, once complete
    anchors: dict[str, tuple[int, int]] = {}
    #: the collections open: [nodes before it, its anchor, its tallest child's height]
    open_: list[list[Any]] = []

    def count(size: int) -> None:
        nonlocal nodes
        nodes += size
        if nodes > MAX_YAML_NODES:
            raise ManifestError(
                f"{path}: expands to more than {MAX_YAML_NODES} nodes through YAML aliases"
                if aliased
                else f"{path}: more than {MAX_YAML_NODES} nodes, more than a manifest or "
                "config can need"
            )

    def child(height: int) -> None:
        if open_:
            open_[-1][2] = max(open_[-1][2], height)

    for event in yaml.parse(text, Loader=_Loader):
        if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            if len(open_) >= MAX_YAML_DEPTH:
                raise ManifestError(f"{path}: nested deeper than {MAX_YAML_DEPTH} levels")
            open_.append([nodes, event.anchor, 0])
            count(1)
        elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            start, anchor, tallest = open_.pop()
            if anchor is not None:
                anchors[anchor] = (nodes - start, tallest + 1)
            child(tallest + 1)
        elif isinstance(event, yaml.ScalarEvent):
            if event.anchor is not None:
                anchors[event.anchor] = (1, 0)
            count(1)
            child(0)
        elif isinstance(event, yaml.AliasEvent):
            if any(frame[1] == event.anchor for frame in open_):
                raise ManifestError(
                    f"{path}: alias *{event.anchor} at line {event.start_mark.line + 1} is "
                    "inside the node it names (a structure that contains itself)"
                )
            size, height = anchors.get(event.anchor, (1, 0))  # undefined: the composer says so
            if len(open_) + height > MAX_YAML_DEPTH:
                raise ManifestError(
                    f"{path}: nested deeper than {MAX_YAML_DEPTH} levels through YAML aliases"
                )
            aliased = True
            count(size)
            child(height)


def load_yaml(path: str | Path) -> Any:
    """A YAML file (YAML 1.2 floats), its size, nesting and node count (aliases expanded)
    bounded before it is built, a key given twice refused."""
    try:
        text = (
            path if hasattr(path, "read_text") else Path(path)
        ).read_text()  # a file or package data
    except FileNotFoundError:
        raise ManifestError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as err:
        raise ManifestError(f"{path}: unreadable ({type(err).__name__}: {err})") from None
    if len(text) > MAX_YAML_BYTES:
        raise ManifestError(
            f"{path}: {len(text)} bytes, more than a manifest or config can need "
            f"({MAX_YAML_BYTES} at most)"
        )
    try:
        _expanded_size(text, path)  # events only: nothing is composed yet
        return yaml.load(text, Loader=_Loader)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        line = f" at line {mark.line + 1}" if mark else ""
        raise ManifestError(f"{path}: not valid YAML{line}") from None
    except _DuplicateKey as err:
        key = _shown(err.key)
        raise ManifestError(f"{path}: key {key} given twice (line {err.line})", key) from None
    except ManifestError:
        raise
    except Exception as err:  # PyYAML's constructors raise whatever they meet
        # a scalar its tag cannot be built from (!!timestamp 2024-02-30, an empty !!int, an !!int
        # of 5000 digits): ValueError, IndexError, …
        raise ManifestError(f"{path}: not valid YAML ({type(err).__name__})") from None


def check_dataset_name(name: str, source: str | Path) -> None:
    if not (isinstance(name, str) and DATASET_NAME.fullmatch(name)):
        raise ManifestError(
            f"{source}: dataset name {name!r} must be letters, digits, '_' or '-' "
            "(no path separators or '..')",
            "datasets",
        )


def protocol_catalogue(directory: str | Path = PROTOCOLS) -> list[str]:
    """The protocols the catalogue folder has (its <name>.yaml files' names; none is read)."""
    folder = Path(directory)
    if not folder.is_dir():
        return []
    return sorted(
        p.stem for p in folder.glob("*.yaml") if PROTOCOL_NAME.fullmatch(p.stem) and p.is_file()
    )


def check_protocol_name(
    name: Any, source: str | Path, directory: str | Path | None = PROTOCOLS
) -> None:
    """A manifest's ``protocols:`` entry names workflow/protocols/<name>.yaml: a plain name (no
    path separators or '..', so no file outside the catalogue is ever opened) that the catalogue
    in ``directory`` has (not checked with ``directory=None``). Nothing of any file is quoted."""
    catalogue = protocol_catalogue(directory) if directory is not None else []
    has = f"the catalogue has {', '.join(catalogue)}" if catalogue else "no catalogue here"
    if not (isinstance(name, str) and PROTOCOL_NAME.fullmatch(name)):
        raise ManifestError(
            f"{source}: protocols: {name!r} is not a protocol name "
            f"(letters, digits, _ and -; {has})",
            "protocols",
        )
    if directory is not None and name not in catalogue:
        raise ManifestError(
            f"{source}: protocols: {name!r} is not in the catalogue {directory} ({has})",
            "protocols",
        )


def check_experiment_name(name: str, source: str | Path) -> None:
    if not (isinstance(name, str) and EXPERIMENT_NAME.fullmatch(name)):
        raise ManifestError(
            f"{source}: key experiments: experiment name {name!r} must be letters, digits "
            "or '_' (it becomes a file name and a Snakemake wildcard)",
            "experiments",
        )


def validate_config(
    config: Mapping[str, Any], source: str | Path, overrides: Mapping[str, Any] | None = None
) -> None:
    """Validate the merged config. A fault in a key that ``--config`` set is blamed on
    ``--config``, not on the config files."""
    try:
        validate_document(config, "config.schema.yaml", source)
        for name in config["datasets"]:
            check_dataset_name(name, source)
    except ManifestError as err:
        if overrides and _sets(overrides, err.key):
            raise ManifestError(f"--config{str(err)[len(str(source)) :]}", err.key) from None
        raise


def _sets(overrides: Mapping[str, Any], key: str | None) -> bool:
    """Whether the --config overrides set (a part of) the dotted key."""
    node: Any = overrides
    for part in (key or "").split("."):
        if not isinstance(node, Mapping) or part not in node:
            return False
        node = node[part]
    return bool(key)


def load_config(path: str | Path) -> dict:
    """config.yaml validated, with the schema's defaults filled in (as the workflow sees it)."""
    config = load_yaml(path)
    validate_config(config, path)
    _fill_defaults(config, load_yaml(SCHEMAS / "config.schema.yaml"))
    return config


def _fill_defaults(doc: dict, schema: Mapping[str, Any]) -> None:
    for key, sub in schema.get("properties", {}).items():
        if key not in doc and "default" in sub:
            doc[key] = (
                sub["default"] if not isinstance(sub["default"], dict) else dict(sub["default"])
            )
        if isinstance(doc.get(key), dict) and sub.get("type") == "object":
            _fill_defaults(doc[key], sub)


def schema_default(schema_name: str, keys: Sequence[str]) -> Any:
    """The default the schema <schema_name> gives the key at ``keys`` (a dotted key's parts),
    through nested objects' properties; KeyError where it gives none. A dataset manifest that
    leaves out a twin variant's key holds this default, the term off (docs/twin.md,
    "Variants")."""
    node: Any = _validator(schema_name).schema  # loaded once: a member's draws ask per unknown
    for key in keys:
        node = node["properties"][key]
    return node["default"]


def load_dataset(raw_dir: str | Path, name: str) -> dict:
    """The manifest raw/<name>/dataset.yaml, validated; its name must match its folder."""
    path = Path(raw_dir) / name / "dataset.yaml"
    if not path.exists():
        raise ManifestError(f"{path}: unknown dataset {name!r} (no manifest)")
    manifest = load_yaml(path)
    validate_document(manifest, "dataset.schema.yaml", path)
    if manifest["name"] != name:
        raise ManifestError(
            f"{path}: key name: {manifest['name']!r} does not match its folder {name!r}"
        )
    for channel, (lo, hi) in manifest["daq"]["ranges"].items():
        if not lo < hi:
            raise ManifestError(
                f"{path}: key daq.ranges.{channel}: [{lo:g}, {hi:g}] must be [low, high] "
                f"with low < high (the ADC's full scale)",
                f"daq.ranges.{channel}",
            )
    # the names' form always; the catalogue where the workflow's folder has one (expand_protocols
    # checks again against the catalogue it reads)
    catalogue = PROTOCOLS if PROTOCOLS.is_dir() else None
    for protocol in manifest["protocols"]:
        check_protocol_name(protocol, path, catalogue)
    for experiment in manifest.get("experiments", ()):
        check_experiment_name(experiment, path)
    return manifest


def require_keys(
    manifest: Mapping[str, Any], keys: Sequence[str], source: str | Path, why: str
) -> None:
    """Keys (dotted) an analysis computes with and the schema leaves optional: the first one
    absent stops with one line naming the file, the key and the analysis, before anything runs."""
    for key in keys:
        node: Any = manifest
        for part in key.split("."):
            if not isinstance(node, Mapping) or part not in node:
                raise ManifestError(
                    f"{source}: key {key} is missing: {why} computes with it "
                    "(src/selfsense/io/schemas/dataset.schema.yaml)",
                    key,
                )
            node = node[part]


#: a protocol's Eq 15 setting ``{R: identified, c: identified}``: the operator runs Eq 15 with the
#: R and c the pipeline identified (:func:`selfsense.twin.bender.identified_compensation`), as the
#: paper ran it with its own identification (Eq 12), never with the R and c the twin is built with
IDENTIFIED = "identified"


def needs_identification(entry: Mapping[str, Any] | None) -> bool:
    """Whether a protocol's compensation takes Eq 15's R and c from the identification."""
    return bool(entry) and IDENTIFIED in (entry.get("R"), entry.get("c"))


def channel_scalings(manifest: Mapping[str, Any]) -> dict[str, str]:
    """Per channel recorded through a factor (``sensors.<channel>.scale``, set by ``selfsense
    import --scale/--gain``: the logged column times the factor is the channel), a short label
    for table headers and figure axes, e.g. ``{"U": "20 × logged (gain)"}``; empty when none."""
    sensors = manifest.get("sensors") or {}
    return {
        channel: f"{float(sensor['scale']):g} × logged ({sensor.get('scale_kind', 'scale')})"
        for channel, sensor in sensors.items()
        if isinstance(sensor, Mapping) and "scale" in sensor
    }


def load_manifest(path: str | Path) -> dict:
    """A manifest by its path, raw/<name>/dataset.yaml, validated as :func:`load_dataset` does
    (the rules pass the manifest's path)."""
    path = Path(path)
    return load_dataset(path.parent.parent, path.parent.name)


@dataclass(frozen=True)
class Experiment:
    """One capture to make (simulated) or read (measured)."""

    name: str
    chapter: str
    protocol: Mapping[str, Any]  # quantity, segments, and the optional keys below
    load_stiffness: float = 0.0
    control: str = "open_loop"
    #: the bender's feedforward setting (Ronkanen catalogue), as the protocol gives it
    compensation: Mapping[str, Any] | None = None
    #: the parts it plays in the stages (``selfsense.io.roles``): the catalogue's ``roles:``, or
    #: those a manifest's ``roles:`` maps onto it
    roles: frozenset[str] = frozenset()
    #: [Hz] the drive frequency the thesis ran it at (its catalogue entry's first segment, before
    #: a campaign's overrides), by which the tables name it: the smoke campaign runs slow sines
    #: faster, and a lab's own run takes it from the catalogue run it follows
    nominal_hz: float | None = None


def protocol_duration(protocol: Mapping[str, Any]) -> float:
    """How long a protocol drives the bench [s]: its warm-up, then its segments ``repeat`` times."""
    per_pass = sum(float(segment["duration"]) for segment in protocol["segments"])
    return float(protocol.get("warmup", 0.0)) + int(protocol.get("repeat", 1)) * per_pass


def expand_protocols(
    protocol_names: list[str],
    campaign: str,
    directory: str | Path = PROTOCOLS,
    source: str | Path | None = None,
    overrides: Mapping[str, float] | None = None,
) -> dict[str, Experiment]:
    """The experiment catalogue for a campaign: sets expanded to <name>_s<k>, smoke overrides
    applied. Every name is checked (:func:`check_protocol_name`, blamed on ``source``, the
    manifest, if given) before any file is opened. ``overrides`` ({"<protocol>:<dotted key>":
    value}, a manifest's ``protocol_overrides``) replace values of the files first."""
    for chapter in protocol_names:
        check_protocol_name(chapter, source or directory, directory)
    by_chapter = _overrides_by_protocol(overrides or {}, protocol_names, source or directory)
    experiments: dict[str, Experiment] = {}
    for chapter in protocol_names:
        path = Path(directory) / f"{chapter}.yaml"
        # a copy: the experiments hold parts of it, and a caller may change them
        doc = copy.deepcopy(_protocol_document(str(path), path.stat().st_mtime_ns))
        if chapter in by_chapter:
            for key, value in by_chapter[chapter].items():
                _replace(
                    doc, key, value, f"{source or path}: key protocol_overrides.{chapter}:{key}"
                )
            held = hashlib.sha256(
                json.dumps([doc, sorted(by_chapter[chapter].items())], sort_keys=True).encode()
            ).digest()
            if held not in _HELD:
                _validate_overridden(doc, chapter, by_chapter[chapter], source or path, path)
                if len(_HELD) < 4096:
                    _HELD.add(held)
        for name, entry in doc["experiments"].items():
            entry = dict(entry)
            smoke = entry.pop("smoke", {})
            repeated = "sets" in entry  # names stay <name>_s<k> in every campaign
            if campaign == "smoke":
                entry |= smoke
            sets = int(entry.pop("sets", 1))
            names = [f"{name}_s{k}" for k in range(1, sets + 1)] if repeated else [name]
            nominal = doc["experiments"][name]["segments"][0].get("frequency")
            for index, n in enumerate(names):
                experiments[n] = Experiment(
                    name=n,
                    chapter=chapter,
                    protocol={
                        k: entry[k]
                        for k in ("quantity", "segments", "repeat", "warmup")
                        if k in entry
                    },
                    load_stiffness=float(entry.get("load_stiffness", 0.0)),
                    control=entry.get("control", "open_loop"),
                    compensation=entry.get("compensation"),
                    roles=catalogue_roles(entry.get("roles", ()), index == 0, f"{path}: {name}"),
                    nominal_hz=None if nominal is None else float(nominal),
                )
    return experiments


def catalogue(
    manifest: Mapping[str, Any], campaign: str, source: str | Path | None = None
) -> dict[str, Experiment]:
    """A dataset's experiment catalogue: its protocols expanded for the campaign, with its
    ``protocol_overrides`` (an envelope member's drawn levels and record lengths)."""
    return expand_protocols(
        manifest["protocols"], campaign, source=source, overrides=manifest.get("protocol_overrides")
    )


@lru_cache(maxsize=64)
def _protocol_document(path: str, mtime_ns: int) -> Any:
    """A protocol file, read and validated once per version (every envelope member expands the
    same files)."""
    doc = load_yaml(path)
    validate_document(doc, "protocol.schema.yaml", path)
    return doc


def _overrides_by_protocol(
    overrides: Mapping[str, float], protocol_names: Sequence[str], source: Any
) -> dict[str, dict[str, float]]:
    """{protocol: {dotted key: value}} of ``protocol_overrides``, each naming a protocol the
    dataset runs."""
    grouped: dict[str, dict[str, float]] = {}
    for location, value in overrides.items():
        chapter, _, key = location.partition(":")
        if chapter not in protocol_names or not key:
            raise ManifestError(
                f"{source}: key protocol_overrides.{location}: not <protocol>:<dotted key> of a "
                f"protocol the dataset runs ({', '.join(protocol_names)})",
                "protocol_overrides",
            )
        grouped.setdefault(chapter, {})[key] = value
    return grouped


def _replace(doc: Any, dotted: str, value: float, where: str) -> None:
    """Set the number at a dotted key of a protocol document (a list's element by its index:
    0 to its length − 1, digits only, so that "-5", "first" or "9" of a 2-element list is one line
    naming the key, not an IndexError or AttributeError)."""

    def child(node: Any, key: str) -> Any:
        if isinstance(node, list):
            if not (_LIST_INDEX.fullmatch(key) and int(key) < len(node)):
                n = len(node)
                has = f"has {n} element{'' if n == 1 else 's'} (0 to {n - 1})" if n else "is empty"
                raise ManifestError(
                    f"{where}: {key[:40]!r} is not an index of the list there, which {has}",
                    "protocol_overrides",
                )
            return node[int(key)]
        if isinstance(node, Mapping) and key in node:
            return node[key]
        raise ManifestError(f"{where}: the protocol has no such key", "protocol_overrides")

    *parents, last = dotted.split(".")
    node = doc
    for key in parents:
        node = child(node, key)
    held = child(node, last) if isinstance(node, list) else node.get(last)
    if not isinstance(held, (int, float)) or isinstance(held, bool):
        raise ManifestError(f"{where}: the protocol holds no number there", "protocol_overrides")
    node[int(last) if isinstance(node, list) else last] = value


#: the overridden protocol documents this process has held to the schema and found valid (the
#: sha256 of their JSON): every job of an in-process member expands its manifest again (≈ 65 ms)
_HELD: set[bytes] = set()


#: a list's index in a protocol override's dotted key: digits only (str.isdigit() also takes "²",
#: which int() refuses)
_LIST_INDEX = re.compile(r"[0-9]+")


def _validate_overridden(
    doc: Any, chapter: str, overrides: Mapping[str, Any], source: Any, protocol: Path
) -> None:
    """The protocol document with a manifest's overrides applied, held to the protocol schema's
    limits again (durations, counts, types: the file alone was checked when it was read, so a
    drawn ``duration: 1e12`` or ``-5`` would otherwise reach the twin). The first problem is one
    line naming the manifest and the override's key."""
    for key, value in overrides.items():
        _check_finite(value, source, f"protocol_overrides.{chapter}:{key}")
    # only the experiments overridden: validating a whole protocol (ch7's) costs ≈ 10 ms, and an
    # envelope's members are expanded at the workflow's parse
    touched = {k.split(".")[1] for k in overrides if k.startswith("experiments.") and "." in k[12:]}
    if all(k.startswith("experiments.") for k in overrides) and touched <= set(doc["experiments"]):
        doc = doc | {"experiments": {name: doc["experiments"][name] for name in touched}}
    errors = list(_validator("protocol.schema.yaml").iter_errors(doc))
    if not errors:
        return

    def dotted(error: jsonschema.ValidationError) -> str:
        return ".".join(str(p) for p in error.absolute_path)

    def causes(error: jsonschema.ValidationError) -> Iterator[jsonschema.ValidationError]:
        yield error
        for sub in error.context or ():
            yield from causes(sub)

    # an override replaces a number, so each of the schema's complaints is at an override's key
    # or at a parent of it (compensation's oneOf of R and c, an experiment's allOf, whose failure
    # also makes its properties "unevaluated"): the deepest one at or above an override names it
    found = [
        (len(dotted(e)), e, k)
        for e in (c for error in errors for c in causes(error))
        for k in overrides
        if e.validator != "unevaluatedProperties"
        and (k == dotted(e) or k.startswith(f"{dotted(e)}."))
    ]
    if found:
        _, error, key = max(found, key=lambda t: t[0])
    else:
        error, key = jsonschema.exceptions.best_match(errors), " and ".join(overrides)
    raise ManifestError(
        f"{source}: key protocol_overrides.{chapter}:{key}: {error.message} (a limit of the "
        f"protocol schema, src/selfsense/io/schemas/protocol.schema.yaml)",
        "protocol_overrides",
    )
