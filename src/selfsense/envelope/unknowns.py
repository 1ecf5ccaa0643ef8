"""The envelope's declared unknowns (workflow/unknowns.yaml): loading, checking, provenance.

The twin is one plausible bench. What the sources leave open (damping, the ripple's wander, the
instruments' noise within their data sheets, P1's levels, record lengths, the calibration's free
parameters within what its signatures allow, …) is declared in one file, each quantity with the
value used today, the range a plausible bench may take and the source of that range, before any
envelope result exists: ranges come from sources, never from the results they would move.

:func:`load_unknowns` validates the file against ``schemas/unknowns.schema.yaml`` and then makes
the checks a schema cannot: every range in order with its nominal inside, ids unique, and every
location the entry names present in its file (the dataset manifest, or a protocol of the
catalogue) with the nominal as its value (a twin variant's key the manifest leaves out: the
dataset schema's default, the term off), so a declaration cannot drift from the bench it
describes. Each refusal is one line naming the file and the entry's id. :func:`unknowns_hash` is
the file's sha256, for the provenance of everything drawn from it. It reads files and writes
none.
"""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from selfsense.io.manifest import (
    PROTOCOL_NAME,
    ManifestError,
    load_dataset,
    load_yaml,
    schema_default,
    validate_document,
)

#: the datasets an entry may name, and what "both" stands for
DATASETS = ("pi_p885", "tokin_nb40")
#: a location in a protocol of the catalogue: protocols/<name>.yaml:<dotted key>
PROTOCOL_PATH = re.compile(r"protocols/(?P<name>[^/:]+)\.yaml:(?P<key>.+)")
#: a value the twin's code fixes and no file holds yet
MODEL_PREFIX = "model:"
#: nominal and file value agree when equal to this relative precision (YAML floats round-trip
#: exactly; this only forgives 2.0e-4 written as 0.0002 through a different decimal path)
REL_TOL = 1e-12


@dataclass(frozen=True)
class Unknown:
    """One declared unknown: where its value lives, the value used today, the span a plausible
    bench may take (``low``–``high``, drawn as ``kind``) and why."""

    id: str
    dataset: str  # pi_p885 | tokin_nb40 | both
    group: str  # its family: the envelope varies whole groups
    paths: tuple[str, ...]  # every location that holds the value (set together)
    nominal: float
    low: float
    high: float
    kind: str  # uniform (a plain range) | loguniform | integer | normal
    unit: str
    affects: tuple[str, ...]
    source: str
    derivation: str = ""
    note: str = ""
    where: str = ""  # the source file that fixes a model:<name> value
    mean: float | None = None  # normal only
    sd: float | None = None  # normal only
    #: a term of the twin's physics off today: a model variant, not a draw of the prior
    variant: bool = False

    @property
    def datasets(self) -> tuple[str, ...]:
        """The datasets whose manifests (and protocols) use it."""
        return DATASETS if self.dataset == "both" else (self.dataset,)

    @property
    def in_model(self) -> bool:
        """Whether the twin's code, not a file, fixes it (the envelope cannot set it yet)."""
        return all(p.startswith(MODEL_PREFIX) for p in self.paths)


def unknowns_hash(path: str | Path) -> str:
    """sha256 of the file's bytes: every envelope member records it, so a result names the exact
    declaration it was drawn from (a comment changed is a different declaration)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def load_unknowns(
    path: str | Path, root: str | Path | None = None, raw_dir: str | Path | None = None
) -> tuple[Unknown, ...]:
    """The unknowns of ``path`` (workflow/unknowns.yaml), validated and checked against the files
    they name.

    ``root`` is the workflow's folder (the one holding workflow/ and raw/; by default the folder
    above the file's own), ``raw_dir`` the datasets' folder (default <root>/raw). A location is
    looked up in raw/<dataset>/dataset.yaml, or in <root>/workflow/protocols/<name>.yaml.
    """
    path = Path(path)
    root = path.resolve().parent.parent if root is None else Path(root)
    raw_dir = root / "raw" if raw_dir is None else Path(raw_dir)
    doc = load_yaml(path)
    try:
        validate_document(doc, "unknowns.schema.yaml", path)
    except ManifestError as err:
        raise _named(err, doc, path) from None
    files = _Files(root, raw_dir, path)
    unknowns = []
    for i, entry in enumerate(doc["unknowns"]):
        unknown = _parse(entry, f"{path}: key unknowns.{i} ({entry['id']})")
        files.check(unknown, f"{path}: key unknowns.{i}.path ({unknown.id})")
        unknowns.append(unknown)
    ids = [u.id for u in unknowns]
    twice = sorted({i for i in ids if ids.count(i) > 1})
    if twice:
        raise ManifestError(f"{path}: unknown id {twice[0]!r} is declared twice", "unknowns")
    return tuple(unknowns)


#: the schema's refusals of "exactly one of range and distribution" (the message's tail), in words
RANGE_OR_DISTRIBUTION = {
    "'range' is a required property": "needs a range [low, high] or a distribution",
    "False schema does not allow": "gives both a range and a distribution: give one",
}


def _named(err: ManifestError, doc: Any, source: Path) -> ManifestError:
    """A schema refusal inside unknowns.<i> with the entry's id beside its index (the id is what
    a reader searches the file for), and the range-or-distribution rule said in words."""
    match = re.match(r"unknowns\.(\d+)", err.key or "")
    entries = doc.get("unknowns") if isinstance(doc, Mapping) else None
    try:
        uid = entries[int(match.group(1))].get("id") if match else None
    except (TypeError, IndexError, AttributeError):
        uid = None
    if not isinstance(uid, str):
        return err
    text = str(err)
    for said, meant in RANGE_OR_DISTRIBUTION.items():
        if said in text:
            text = text[: text.index(said)] + meant
    at = text.find(match.group(0), len(str(source)))
    end = at + len(match.group(0))
    while end < len(text) and text[end] not in " :":  # the rest of the dotted key
        end += 1
    return ManifestError(f"{text[:end]} ({uid}){text[end:]}", err.key)


def _parse(entry: Mapping[str, Any], where: str) -> Unknown:
    """One entry as an :class:`Unknown`, its span in order and its nominal inside it."""
    paths = (entry["path"],) if isinstance(entry["path"], str) else tuple(entry["path"])
    affects = (entry["affects"],) if isinstance(entry["affects"], str) else tuple(entry["affects"])
    nominal = entry["nominal"]
    mean = sd = None
    if "range" in entry:
        kind, (low, high) = "uniform", entry["range"]
        key = "range"
    else:
        dist = entry["distribution"]
        kind, low, high = dist["kind"], dist["low"], dist["high"]
        key = "distribution"
        mean, sd = dist.get("mean"), dist.get("sd")
    if not low < high:
        raise ManifestError(
            f"{where}: {key} [{low:g}, {high:g}] must be [low, high] with low < high", key
        )
    if kind == "loguniform" and not low > 0:
        raise ManifestError(f"{where}: a loguniform distribution needs low > 0, not {low:g}", key)
    if kind == "integer" and not all(float(v).is_integer() for v in (low, high, nominal)):
        raise ManifestError(f"{where}: an integer distribution needs whole low, high and nominal")
    if kind == "normal" and not low <= mean <= high:
        raise ManifestError(f"{where}: the normal's mean {mean:g} is outside [{low:g}, {high:g}]")
    if not low <= nominal <= high:
        raise ManifestError(
            f"{where}: nominal {nominal:g} is outside its {key} [{low:g}, {high:g}] "
            "(the value used today must be a plausible bench)",
            key,
        )
    if any(p.startswith(MODEL_PREFIX) for p in paths) and not entry.get("where"):
        raise ManifestError(
            f"{where}: a model: path needs `where:`, the source file that fixes the value", "where"
        )
    return Unknown(
        id=entry["id"],
        dataset=entry["dataset"],
        group=entry["group"],
        paths=paths,
        nominal=nominal,
        low=low,
        high=high,
        kind=kind,
        unit=entry["unit"],
        affects=affects,
        source=entry["source"].strip(),
        derivation=entry.get("derivation", "").strip(),
        note=entry.get("note", "").strip(),
        where=entry.get("where", ""),
        mean=mean,
        sd=sd,
        variant=bool(entry.get("variant", False)),
    )


class _Files:
    """The files the entries point into, each read (and validated) once."""

    def __init__(self, root: Path, raw_dir: Path, source: Path):
        self.root, self.raw_dir, self.source = root, raw_dir, source
        self.cache: dict[tuple[str, str], Any] = {}

    def manifest(self, dataset: str) -> Any:
        if ("raw", dataset) not in self.cache:
            self.cache["raw", dataset] = load_dataset(self.raw_dir, dataset)
        return self.cache["raw", dataset]

    def protocol(self, name: str) -> Any:
        if ("protocol", name) not in self.cache:
            self.cache["protocol", name] = load_yaml(
                self.root / "workflow" / "protocols" / f"{name}.yaml"
            )
        return self.cache["protocol", name]

    def check(self, unknown: Unknown, where: str) -> None:
        """Every location of ``unknown`` holds its nominal; a model: path's source file exists."""
        for location in unknown.paths:
            if location.startswith(MODEL_PREFIX):
                if not (self.root / unknown.where).is_file():
                    raise ManifestError(
                        f"{where}: {location}: its `where:` {unknown.where} is not a file", "where"
                    )
                continue
            match = PROTOCOL_PATH.fullmatch(location)
            if match:
                name = match.group("name")
                if not PROTOCOL_NAME.fullmatch(name):
                    raise ManifestError(f"{where}: {location}: {name!r} is not a protocol name")
                files = [(f"workflow/protocols/{name}.yaml", self.protocol(name))]
                key = match.group("key")
            else:
                files = [(f"raw/{d}/dataset.yaml", self.manifest(d)) for d in unknown.datasets]
                key = location
            for file, doc in files:
                look = _lookup if match else _manifest_value
                value = look(doc, key.split("."), f"{where}: {location}: {file}")
                if not _equal(value, unknown.nominal):
                    raise ManifestError(
                        f"{where}: {file} holds {value!r} at {key}, not the nominal "
                        f"{unknown.nominal:g}"
                    )


def _lookup(doc: Any, keys: Sequence[str], where: str) -> Any:
    """The value at a dotted key (a list's element by its index)."""
    node = doc
    for depth, key in enumerate(keys):
        if isinstance(node, Mapping) and key in node:
            node = node[key]
        elif isinstance(node, list) and key.isdigit() and int(key) < len(node):
            node = node[int(key)]
        else:
            raise ManifestError(f"{where} has no key {'.'.join(keys[: depth + 1])}")
    return node


def _manifest_value(doc: Any, keys: Sequence[str], where: str) -> Any:
    """The value at a dotted key of a dataset manifest: the dataset schema's default where the
    manifest leaves the key out and the schema gives one (a twin variant's term off)."""
    try:
        return _lookup(doc, keys, where)
    except ManifestError as missing:
        try:
            return schema_default("dataset.schema.yaml", keys)
        except (KeyError, TypeError):
            raise missing from None


def _equal(value: Any, nominal: float) -> bool:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    return math.isclose(value, nominal, rel_tol=REL_TOL, abs_tol=0.0)
