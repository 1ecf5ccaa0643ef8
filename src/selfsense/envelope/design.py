"""The reproduction envelope's design and members: which unknowns vary, the sampling plan, each
member's manifest.

An envelope member is the nominal dataset with every varied unknown (workflow/unknowns.yaml) set
to one draw: a dataset of its own, ``<dataset>~NN``, whose manifest this module writes, run by the
same rules as the nominal one (docs/envelope.md). Draws come from SALib: Morris trajectories
(Morris 1991; Campolongo, Cariboni, Saltelli 2007) over groups of unknowns, which both spread the
members over the declared ranges and say which group moves which number (μ*, σ of the elementary
effects), or a Latin hypercube (McKay, Beckman, Conover 1979) for the spread alone. Designs are
drawn in the unit hypercube and mapped through each unknown's distribution, so μ* is per unit of
an unknown's declared range and comparable between groups.

Pure functions apart from :func:`write_member_manifest`.
"""

from __future__ import annotations

import copy
import hashlib
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from selfsense.envelope.unknowns import MODEL_PREFIX, PROTOCOL_PATH, Unknown
from selfsense.io.manifest import DATASET_NAME, ManifestError, schema_default, validate_document
from selfsense.io.provenance import atomic_path

#: between a dataset's name and a member's number: pi_p885~07
MEMBER_MARK = "~"
#: the sampling methods an envelope may use
METHODS = ("morris", "latin")
#: the most members (trajectories' and spread's) one design may draw: the config schema's bound
#: on each, and on their sum here (the schema says why)
MAX_MEMBERS = 500
#: an envelope's and its dataset's names: a dataset's, matched whole (a trailing newline too),
#: at most this long (<name>~NN and results/envelope/<name>/ stay short file names)
MAX_NAME = 64
#: what a run's targets must name for it to need the members (see :func:`members_asked`)
ENVELOPE_WORD = "envelope"
#: the plan's column holding the sha256 of each member's manifest as rule envelope_member writes it
MANIFEST_SHA = "manifest sha256"


def check_names(section: Mapping[str, Any], key: str, source: str) -> None:
    """A config section's ``dataset`` (required) and ``name`` (optional) whole dataset names of
    at most :data:`MAX_NAME` characters; else one line naming ``source`` and the key."""
    for name in ("dataset", "name"):
        value = section.get(name) or ""
        if (name == "dataset" or value) and not (
            DATASET_NAME.fullmatch(value) and len(value) <= MAX_NAME
        ):
            raise ManifestError(
                f"{source}: key {key}.{name}: {value[:MAX_NAME]!r}"
                f"{'…' if len(value) > MAX_NAME else ''} is not a name of letters, digits, "
                f"'_' and '-' of at most {MAX_NAME} characters",
                f"{key}.{name}",
            )


@dataclass(frozen=True)
class Design:
    """An envelope's sampling design (config.yaml's ``envelope:``)."""

    dataset: str
    members: int
    method: str  # morris | latin
    seed: int
    levels: int  # Morris grid levels
    #: the groups of unknowns varied (each unknown's ``group``), each one factor for Morris
    groups: Sequence[str]
    #: the stages a member runs (the nominal run's others are not varied)
    stages: Sequence[str]
    #: what its members (<name>~NN) and its outputs (results/envelope/<name>/) are named after
    name: str
    #: the chapters whose emergent rows it judges (empty: every chapter)
    chapters: Sequence[str] = ()
    #: Morris only: Latin hypercube members drawn after the trajectories, whose values alone
    #: give the percentiles (0: the trajectories' members give them)
    spread: int = 0

    @classmethod
    def from_config(cls, section: Mapping[str, Any], source: str = "config.yaml") -> Design:
        """The design of config.yaml's ``envelope:`` section (validated by the config schema):
        the one reading of that section; the workflow passes the result on as
        :meth:`record`, and every output keeps that record in its provenance. Its names must be
        whole dataset names of at most :data:`MAX_NAME` characters, and it may draw at most
        :data:`MAX_MEMBERS` members in all; else one line naming ``source`` and the key."""
        check_names(section, "envelope", source)
        spread = int(section.get("spread", 0)) if section["method"] == "morris" else 0
        if int(section["members"]) + spread > MAX_MEMBERS:
            raise ManifestError(
                f"{source}: key envelope.spread: {section['members']} members and {spread} more "
                f"for the spread are more than the {MAX_MEMBERS} one design may draw",
                "envelope.spread",
            )
        return cls(
            name=section.get("name") or section["dataset"],
            dataset=section["dataset"],
            members=int(section["members"]),
            method=section["method"],
            seed=int(section["seed"]),
            levels=int(section["levels"]),
            groups=list(section["groups"]),
            stages=list(section["stages"]),
            chapters=[str(c) for c in section.get("chapters", ())],
            spread=spread,
        )

    def record(self) -> dict[str, Any]:
        """The design as plain data (a rule's param, a provenance's ``design``): ``Design(**it)``
        is the design again."""
        return asdict(self)

    def judges(self, chapter: Any) -> bool:
        """Whether the design judges the emergent rows of ``chapter`` (every chapter's when it
        names none)."""
        return not self.chapters or str(chapter) in self.chapters


def check_chapters(design: Design, known: Sequence[str], source: str = "config.yaml") -> None:
    """Every chapter the design judges is one some emergent row has (``known``, the registry's):
    a chapter no row has would judge nothing and give an empty envelope."""
    unknown = [c for c in design.chapters if c not in set(map(str, known))]
    if unknown:
        raise ManifestError(
            f"{source}: key envelope.chapters: {unknown[0]!r} is no chapter of the scorecard's "
            f"emergent rows ({', '.join(dict.fromkeys(map(str, known)))})",
            "envelope.chapters",
        )


def members_asked(targets: Iterable[str]) -> bool:
    """Whether a run's targets (Snakemake's target rules, files and jobs) need the envelope's
    members: a rule or file of the envelope (``envelope``, ``results/envelope/…``) or of a member
    (``results/pi_p885~07/…``, a cluster job's ``simulate:dataset=pi_p885~07``). A run asking for
    none of them, the default run among them, never draws the members."""
    return any(ENVELOPE_WORD in t or MEMBER_MARK in t for t in targets)


def member_name(dataset: str, number: int) -> str:
    """A member's dataset name: ``pi_p885~07`` (numbered from 1)."""
    return f"{dataset}{MEMBER_MARK}{number:02d}"


def is_member(name: str) -> bool:
    """Whether a dataset name is an envelope member's."""
    return MEMBER_MARK in name


def varied_unknowns(
    unknowns: Sequence[Unknown], design: Design, source: str = "config.yaml"
) -> list[Unknown]:
    """The unknowns the design varies: the design's dataset's, of its groups, in the groups'
    order, except those fixed in the twin's code (``model:``), which cannot vary yet. A group
    with nothing of the dataset's that can vary is refused in one line."""
    own = [u for u in unknowns if design.dataset in u.datasets]
    chosen: list[Unknown] = []
    for group in design.groups:
        members = [u for u in own if u.group == group and not u.in_model]
        if not members:
            known = sorted({u.group for u in own if not u.in_model})
            raise ManifestError(
                f"{source}: key envelope.groups: {group!r} is no group of {design.dataset}'s "
                f"unknowns that can vary (workflow/unknowns.yaml: {', '.join(known)})"
            )
        chosen += members
    return chosen


def held_unknowns(unknowns: Sequence[Unknown], design: Design) -> list[Unknown]:
    """The dataset's unknowns the design holds at their nominal (every envelope output says
    which): those of groups it does not vary, and those fixed in the twin's code."""
    varied = {u.id for u in varied_unknowns(unknowns, design)}
    return [u for u in unknowns if design.dataset in u.datasets and u.id not in varied]


def problem(varied: Sequence[Unknown], design: Design) -> dict[str, Any]:
    """SALib's problem: every varied unknown on [0, 1] (its distribution's quantile), with its
    group for Morris."""
    spec: dict[str, Any] = {
        "num_vars": len(varied),
        "names": [u.id for u in varied],
        "bounds": [[0.0, 1.0]] * len(varied),
    }
    if design.method == "morris":
        spec["groups"] = [u.group for u in varied]
    return spec


def trajectories(design: Design) -> int:
    """Morris's r: how many trajectories of (groups + 1) members the design's members hold."""
    return design.members // (len(design.groups) + 1)


def member_roles(design: Design, names: Sequence[str]) -> tuple[list[str], list[str]]:
    """(screened, spread): of the members ``names`` (in the plan's order), those Morris's
    screening reads (its trajectories; none for a Latin hypercube) and those whose values give
    the percentiles (a Morris design's ``spread`` members when it has them, else every member)."""
    names = list(names)
    if design.method != "morris":
        return [], names
    if not design.spread:
        return names, names
    n = trajectories(design) * (len(design.groups) + 1)
    return names[:n], names[n:]


def _latin_hypercube(spec: Mapping[str, Any], n: int, seed: int) -> np.ndarray:
    """``n`` rows of SALib's Latin hypercube over ``spec``'s unknowns (its Morris groups, if any,
    do not apply)."""
    from SALib.sample import latin

    return latin.sample({k: v for k, v in spec.items() if k != "groups"}, n, seed=seed)


def unit_design(varied: Sequence[Unknown], design: Design) -> np.ndarray:
    """The members' draws in the unit hypercube (members × unknowns), from SALib.

    Morris: r = members // (groups + 1) trajectories (at least 2 for σ), each moving one group at
    a time by Δ on a ``levels``-level grid, then the design's ``spread`` rows of a Latin
    hypercube; a Latin hypercube: ``members`` rows, one per stratum of every unknown."""
    # SALib's samplers imported where they are used: the workflow draws the plan when it is
    # parsed, and Morris's brings scipy.spatial with it
    spec = problem(varied, design)
    if design.method == "morris":
        from SALib.sample import morris as morris_sampling

        r = trajectories(design)
        if r < 2:
            need = 2 * (len(design.groups) + 1)
            raise ManifestError(
                f"config.yaml: key envelope.members: {design.members} members are fewer than "
                f"two Morris trajectories of {len(design.groups)} groups: at least {need}"
            )
        grid = morris_sampling.sample(spec, r, num_levels=design.levels, seed=design.seed)
        if not design.spread:
            return grid
        return np.vstack([grid, _latin_hypercube(spec, design.spread, design.seed)])
    if design.method == "latin":
        return _latin_hypercube(spec, design.members, design.seed)
    raise ManifestError(
        f"config.yaml: key envelope.method: {design.method!r} is not one of {', '.join(METHODS)}"
    )


def physical(u: np.ndarray, unknown: Unknown) -> np.ndarray:
    """Quantiles ``u`` in [0, 1] as values of ``unknown``: its range drawn uniformly, a
    loguniform range uniformly in log, an integer range as whole numbers (each equally likely),
    a normal truncated to its range."""
    u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    low, high = unknown.low, unknown.high
    if unknown.kind == "uniform":
        return low + u * (high - low)
    if unknown.kind == "loguniform":
        return np.exp(math.log(low) + u * (math.log(high) - math.log(low)))
    if unknown.kind == "integer":
        return np.minimum(low + np.floor(u * (high - low + 1)), high)
    if unknown.kind == "normal":
        from scipy import stats  # here: the workflow draws its plan when parsed, rarely normals

        a, b = (low - unknown.mean) / unknown.sd, (high - unknown.mean) / unknown.sd
        return stats.truncnorm.ppf(u, a, b, loc=unknown.mean, scale=unknown.sd)
    raise ManifestError(f"workflow/unknowns.yaml: {unknown.id}: no draw for kind {unknown.kind}")


def quantile(value: float, unknown: Unknown) -> float:
    """The unit value :func:`physical` takes to ``value`` (an integer's: the middle of its
    cell), its inverse."""
    low, high = unknown.low, unknown.high
    if unknown.kind == "uniform":
        return float((value - low) / (high - low))
    if unknown.kind == "loguniform":
        return float(math.log(value / low) / math.log(high / low))
    if unknown.kind == "integer":
        return float((value - low + 0.5) / (high - low + 1))
    if unknown.kind == "normal":
        from scipy import stats

        a, b = (low - unknown.mean) / unknown.sd, (high - unknown.mean) / unknown.sd
        return float(stats.truncnorm.cdf(value, a, b, loc=unknown.mean, scale=unknown.sd))
    raise ManifestError(f"workflow/unknowns.yaml: {unknown.id}: no draw for kind {unknown.kind}")


def sampling_plan(varied: Sequence[Unknown], design: Design) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(plan, unit): the members' values of every varied unknown, and the same draws in the unit
    hypercube (what Morris's analysis reads), indexed by member name."""
    unit = unit_design(varied, design)
    names = [member_name(design.name, k + 1) for k in range(len(unit))]
    ids = [u.id for u in varied]
    unit_frame = pd.DataFrame(unit, index=pd.Index(names, name="member"), columns=ids)
    # 12 significant digits: a protocol's 0.5 s, not 0.49999999999999994, in a member's manifest
    plan = pd.DataFrame(
        {u.id: [float(f"{v:.12g}") for v in physical(unit[:, j], u)] for j, u in enumerate(varied)},
        index=unit_frame.index,
    )
    return plan, unit_frame


def member_manifest(
    base: Mapping[str, Any],
    varied: Sequence[Unknown],
    values: Mapping[str, float],
    name: str,
    stages: Sequence[str],
) -> dict[str, Any]:
    """The nominal manifest with one member's draws: a file location set in place, a protocol's
    in ``protocol_overrides`` (keyed <protocol>:<dotted key>), only the design's stages run."""
    manifest = copy.deepcopy(dict(base))
    manifest["name"] = name
    manifest["description"] = (
        f"Envelope member {name} of {base['name']}: its manifest with the draws of "
        f"{len(varied)} unknowns (workflow/unknowns.yaml). " + base["description"].strip()
    )
    overrides = dict(manifest.get("protocol_overrides", {}))
    for unknown in varied:
        value = float(values[unknown.id])
        value = int(round(value)) if unknown.kind == "integer" else value
        for location in unknown.paths:
            match = PROTOCOL_PATH.fullmatch(location)
            if match:
                overrides[f"{match.group('name')}:{match.group('key')}"] = value
            elif not location.startswith(MODEL_PREFIX):
                _set(manifest, location.split("."), value, f"{base['name']}: {location}")
    if overrides:
        manifest["protocol_overrides"] = overrides
    manifest["stages"] = list(stages)
    return manifest


def _set(doc: Any, keys: Sequence[str], value: float, where: str) -> None:
    """Set a manifest's value at a dotted key; a key it leaves out that the dataset schema gives a
    default (a twin variant's, off by default) is written with the sections above it."""
    try:
        schema_default("dataset.schema.yaml", keys)
        optional = True
    except (KeyError, TypeError):
        optional = False
    node = doc
    for key in keys[:-1]:
        if optional and isinstance(node, dict):
            node = node.setdefault(key, {})
        else:
            node = node[int(key)] if isinstance(node, list) else node[key]
    last = keys[-1]
    if isinstance(node, list):
        node[int(last)] = value
    elif last in node or optional:
        node[last] = value
    else:
        raise ManifestError(f"{where}: the manifest has no such key")


def manifest_text(manifest: Mapping[str, Any]) -> str:
    """A member's manifest as its raw/<member>/dataset.yaml holds it."""
    return yaml.safe_dump(dict(manifest), sort_keys=False, allow_unicode=True, width=100)


def manifest_sha256(manifest: Mapping[str, Any]) -> str:
    """The sha256 of :func:`manifest_text`: the plan's record of what each member runs."""
    return hashlib.sha256(manifest_text(manifest).encode("utf-8")).hexdigest()


def write_member_manifest(manifest: Mapping[str, Any], path: str | Path) -> None:
    """A member's raw/<member>/dataset.yaml, written whole or not at all."""
    with atomic_path(path) as tmp:
        tmp.write_text(manifest_text(manifest), encoding="utf-8")


def check_member_manifests(drawn: Envelope, raw_dir: str | Path, plan: str | Path) -> None:
    """Every member manifest under ``raw_dir`` is the one its row of ``plan`` (the plan.csv an
    earlier run wrote) records, or the one drawn now: a manifest edited by hand would be
    simulated while the plan keeps the draw, so it is refused in one line naming the file."""
    plan = Path(plan)
    recorded = (
        pd.read_csv(plan, index_col="member")[MANIFEST_SHA]
        if plan.is_file()
        else pd.Series(dtype=str)
    )
    for name, manifest in drawn.manifests.items():
        path = Path(raw_dir) / name / "dataset.yaml"
        if not path.is_file():
            continue
        sha = hashlib.sha256(path.read_bytes()).hexdigest()
        if sha != recorded.get(name) and sha != manifest_sha256(manifest):
            raise ManifestError(
                f"{path}: differs from its draw ({MANIFEST_SHA} in {plan}): an envelope member's "
                "manifest is written by rule envelope_member from the plan; remove the file to "
                "have it written again"
            )


@dataclass(frozen=True)
class Envelope:
    """An envelope as the workflow runs it: its design, what varies and what is held, the
    members' draws and manifests (empty when the design's dataset is not among the run's)."""

    design: Design
    varied: tuple[Unknown, ...]
    held: tuple[Unknown, ...]
    plan: pd.DataFrame
    unit: pd.DataFrame
    manifests: Mapping[str, Mapping[str, Any]]


def undrawn(design: Design) -> Envelope:
    """The envelope of a run that asks for no member (:func:`members_asked`): its design alone,
    no unknowns read, nothing drawn."""
    empty = pd.DataFrame()
    return Envelope(design, (), (), empty, empty, {})


def envelope(
    design: Design,
    datasets: Mapping[str, Mapping[str, Any]],
    unknowns: Sequence[Unknown],
) -> Envelope:
    """The envelope of ``design`` over the run's ``datasets`` (their manifests): every member's
    manifest, validated as a dataset manifest."""
    varied = varied_unknowns(unknowns, design)
    held = held_unknowns(unknowns, design)
    base = datasets.get(design.dataset)
    if base is None:
        empty = pd.DataFrame()
        return Envelope(design, tuple(varied), tuple(held), empty, empty, {})
    if base["source"] != "simulated":
        raise ManifestError(
            f"config.yaml: key envelope.dataset: {design.dataset} is measured: an envelope "
            "varies the twin that makes a simulated dataset"
        )
    plan, unit = sampling_plan(varied, design)
    manifests = {}
    for name, values in plan.iterrows():
        manifest = member_manifest(base, varied, values, str(name), design.stages)
        validate_document(manifest, "dataset.schema.yaml", f"the manifest of member {name}")
        manifests[str(name)] = manifest
    plan[MANIFEST_SHA] = [manifest_sha256(m) for m in manifests.values()]
    return Envelope(design, tuple(varied), tuple(held), plan, unit, manifests)
