"""The validation's runs as workflow members, in resumable batches, and the tables they leave.

The declaration (workflow/validation.yaml) fixes the waves: wave 1 a maximin Latin hypercube of
``waves.first.runs`` points over the declared prior (the unit cube of workflow/unknowns.yaml's
prior quantiles, every unknown of the dataset that can vary but its noise seed), and
``replicates.points`` of them run ``replicates.seeds`` times in all; each run its own noise seed
(the seed is noise, not a factor). Later waves are a maximin subset of the prior candidates the
earlier waves' emulators of the common targets leave, written as a design table by the workflow
(:func:`selfsense.envelope.judgement.next_wave`). Every random number comes from
:func:`selfsense.envelope.history_matching.streams`, as :func:`run_waves` takes them.

Each run is a member, ``<name>~NNN`` (numbered over all waves in run order), whose manifest is
the envelope's (:func:`selfsense.envelope.design.member_manifest`: the dataset's with the run's
values set in place, its seed as the manifest's), run by the same rules as any dataset. Runs go
in batches of ``batch`` members, in run order: wave 1's replicate points first, then their
replicates, then the other points, so that any first batch of 20 or more measures the noise. A
batch done leaves four small tables (:func:`batch_tables`): members × inputs (the unit cube and
the seed), the plan (the same draws as values), members × rows (every emergent row of the
declaration) and members × targets (every common target: the calibration signatures, the
printed facts, the qualitative facts). A batch whose tables exist, under results/ or in the
committed snapshot, is done: it is never drawn again (:func:`check_done` refuses tables that are
not the current draw's), and the verdicts are made from the tables alone.

Pure functions apart from reading a done batch's inputs table (:func:`check_done`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from selfsense.envelope.design import (
    MEMBER_MARK,
    check_names,
    manifest_sha256,
    member_manifest,
    physical,
    quantile,
)
from selfsense.envelope.history_matching import maximin_latin_hypercube, streams
from selfsense.envelope.unknowns import Unknown
from selfsense.envelope.verdicts import member_values, row_key
from selfsense.io.manifest import ManifestError, validate_document

#: what a run's targets must name for it to need the validation's members
VALIDATION_WORD = "validat"
#: a batch's tables, by what they hold (file names under <folder>/wave<w>/batch<bb>/)
TABLES = {
    "inputs": "inputs.csv",  # members × inputs: the unit cube, the seed
    "plan": "plan.csv",  # the same draws as the manifests hold them
    "rows": "rows.csv",  # members × emergent rows
    "targets": "targets.csv",  # members × common targets
}
#: the first columns of the inputs table, before one per varied unknown
RUN_COLUMNS = ["member", "wave", "point", "replicate", "seed", "campaign"]
MEMBER = "member"
#: a wave's design table (later waves): one row a run
DESIGN = "design.csv"


@dataclass(frozen=True)
class Plan:
    """config.yaml's ``validation:`` section: which runs of the declared waves this workflow
    makes, in which batches, with which stages."""

    dataset: str
    name: str
    waves: int  # how many of the declared waves to run
    members: int  # at most this many runs of each wave (0: the declared sizes)
    batch: int  # members per batch
    batches: int  # batches made by one run (0: every batch not yet done)
    stages: Sequence[str] = field(default_factory=tuple)
    variants: bool = False  # the declared variants' keys join the prior (one wave of its own)
    joins: Sequence[str] = field(default_factory=tuple)  # ensembles whose runs join the verdicts

    @classmethod
    def from_config(cls, section: Mapping[str, Any], source: str = "config.yaml") -> Plan:
        """The plan of config.yaml's ``validation:`` section (bounded by the config schema): its
        names whole dataset names of at most :data:`MAX_NAME` characters, else one line naming
        ``source`` and the key."""
        check_names(section, "validation", source)
        return cls(
            dataset=section["dataset"],
            name=section.get("name") or f"{section['dataset']}_validation",
            waves=int(section["waves"]),
            members=int(section["members"]),
            batch=int(section["batch"]),
            batches=int(section["batches"]),
            stages=tuple(section["stages"]),
            variants=bool(section.get("variants", False)),
            joins=tuple(section.get("joins", ())),
        )

    def record(self) -> dict[str, Any]:
        """The plan as plain data (a rule's param): ``Plan(**it)`` is the plan again."""
        return asdict(self) | {"stages": list(self.stages), "joins": list(self.joins)}


#: the model with every variant off, and the one with every variant's keys free
TODAY = "today's twin"
ALL = "all variants"


@dataclass(frozen=True)
class Model:
    """A model of the bench: its name and the inputs it holds ({unknown: unit value})."""

    name: str
    fixed: Mapping[str, float]


def variant_models(
    prior: Sequence[Unknown], groups: Mapping[str, Mapping[str, Any]], held: Sequence[Unknown]
) -> list[Model]:
    """Today's twin, each variant group of ``groups`` (the declaration's ``variants.groups``)
    alone, and all of them, over ``prior`` (the variant validation's unknowns) and ``held`` (the
    unknowns the groups hold, which the base validation varies)."""
    keys = {g: [u.id for u in prior if u.variant and u.group == g] for g in groups}
    by_id = {u.id: u for u in [*prior, *held]}
    off = {k: quantile(by_id[k].nominal, by_id[k]) for ks in keys.values() for k in ks}
    at_nominal = {h.id: quantile(h.nominal, h) for h in held}
    out = [Model(TODAY, off)]
    for g, spec in groups.items():
        others = {k: v for k, v in off.items() if k not in keys[g]}
        out.append(Model(g, others | {h: at_nominal[h] for h in spec.get("holds", ())}))
    out.append(Model(ALL, at_nominal))
    return out


def asked(targets: Iterable[str], name: str) -> bool:
    """Whether a run's targets need the validation's members: `validate`, a file under
    results/validation/, or one of its members (``<name>~003``, a cluster job's wildcards)."""
    return any(VALIDATION_WORD in t or f"{name}{MEMBER_MARK}" in t for t in targets)


def member_name(name: str, number: int) -> str:
    """A validation member's dataset name: ``pi_p885_validation~003`` (numbered from 1)."""
    return f"{name}{MEMBER_MARK}{number:03d}"


def varied(
    unknowns: Sequence[Unknown],
    dataset: str,
    variants: Mapping[str, Mapping[str, Any]] | None = None,
) -> tuple[list[Unknown], Unknown | None]:
    """(the declared prior, the noise seed): the dataset's unknowns a file holds, but the one at
    the manifest's ``seed`` (the seed is noise, drawn per run), and that one. The twin's variants
    are not in the prior: each is a model of its own, held off and compared as a whole. With
    ``variants`` (the declaration's ``variants.groups``) those groups' keys join the prior and
    the unknowns each ``holds`` leave it (held at their nominal); a group that is no variant of
    the dataset, or a held unknown not in its prior, is one line naming the key."""
    variants = variants or {}
    own = [u for u in unknowns if dataset in u.datasets and not u.in_model]
    groups = {u.group for u in own if u.variant}
    held = {h for g in variants.values() for h in g.get("holds", ())}
    for name, group in variants.items():
        where = f"workflow/validation.yaml: key variants.groups.{name}"
        if name not in groups:
            raise ManifestError(f"{where}: no variant group of {dataset} in unknowns.yaml", where)
        base = {u.id for u in own if not u.variant}
        for h in group.get("holds", ()):
            if h not in base:
                raise ManifestError(f"{where}.holds: {h} is not in the prior of {dataset}", where)
    own = [u for u in own if (u.group in variants if u.variant else u.id not in held)]
    seed = next((u for u in own if u.paths == ("seed",)), None)
    return [u for u in own if u is not seed], seed


@dataclass(frozen=True)
class Runs:
    """One wave's runs in run order: design point, replicate (0 for its first run), noise seed,
    the point in the unit cube (runs × unknowns), and the global number of its first run."""

    wave: int
    point: np.ndarray
    replicate: np.ndarray
    seed: np.ndarray
    unit: np.ndarray
    first: int = 0

    def __len__(self) -> int:
        return len(self.point)

    def head(self, n: int) -> Runs:
        """The first ``n`` runs (all with 0)."""
        n = len(self) if n <= 0 else min(n, len(self))
        return Runs(
            self.wave,
            self.point[:n],
            self.replicate[:n],
            self.seed[:n],
            self.unit[:n],
            self.first,
        )


def first_wave(waves: Mapping[str, Any], d: int) -> Runs:
    """Wave 1 of the declaration's ``waves`` over ``d`` unknowns: the maximin Latin hypercube
    and its replicates, seeds as :func:`run_waves` gives them (design runs first, then each
    round of replicates), in run order (see module)."""
    drawn, first = streams(int(waves["seed"])), waves["first"]
    n, reps = int(first["runs"]), first["replicates"]
    points, rounds = min(int(reps["points"]), n), max(int(reps["seeds"]) - 1, 0)
    design = maximin_latin_hypercube(n, d, drawn.design, int(first["maximin_candidates"]))
    order = [(i, 0, i) for i in range(points)]
    order += [(i, r + 1, n + r * points + i) for r in range(rounds) for i in range(points)]
    order += [(i, 0, i) for i in range(points, n)]
    point, replicate, index = (np.array(c, dtype=int) for c in zip(*order))
    return Runs(1, point, replicate, drawn.runs[index].astype(np.int64), design[point], 0)


def wave_from_design(wave: int, design: pd.DataFrame, ids: Sequence[str], first: int) -> Runs:
    """A later wave's runs from its design table (:func:`design_table`)."""
    return Runs(
        wave,
        design["point"].to_numpy(dtype=int),
        design["replicate"].to_numpy(dtype=int),
        design["seed"].to_numpy(dtype=np.int64),
        design[list(ids)].to_numpy(dtype=float),
        first,
    )


def design_table(runs: Runs, ids: Sequence[str]) -> pd.DataFrame:
    """A wave's runs as its design table: point, replicate, seed, one column per unknown."""
    table = pd.DataFrame({"point": runs.point, "replicate": runs.replicate, "seed": runs.seed})
    return pd.concat([table, pd.DataFrame(runs.unit, columns=list(ids))], axis=1)


def runs_of_later_wave(
    design: np.ndarray, replicates: Mapping[str, Any], seeds: np.ndarray, wave: int, first: int
) -> Runs:
    """A later wave's runs: the design's points, ``replicates.points`` of them run
    ``replicates.seeds`` times in all, replicate points first (as wave 1), seeds from
    ``seeds`` (the waves' stream from the run numbered ``first``)."""
    n = len(design)
    points = min(int(replicates["points"]), n)
    rounds = max(int(replicates["seeds"]) - 1, 0)
    order = [(i, 0) for i in range(points)]
    order += [(i, r + 1) for r in range(rounds) for i in range(points)]
    order += [(i, 0) for i in range(points, n)]
    point, replicate = (np.array(c, dtype=int) for c in zip(*order)) if order else ([], [])
    point, replicate = np.asarray(point, dtype=int), np.asarray(replicate, dtype=int)
    index = first + np.arange(len(point))
    return Runs(wave, point, replicate, seeds[index].astype(np.int64), design[point], first)


@dataclass(frozen=True)
class Batch:
    """``wave<w>/batch<bb>``: its members (names) and their rows of the wave's runs."""

    id: str
    wave: int
    members: tuple[str, ...]
    rows: np.ndarray  # indices into the wave's runs


def batches(runs: Runs, name: str, size: int) -> list[Batch]:
    """The wave's runs cut into batches of ``size`` members, in run order."""
    out = []
    for b, start in enumerate(range(0, len(runs), size), start=1):
        rows = np.arange(start, min(start + size, len(runs)))
        members = tuple(member_name(name, runs.first + int(i) + 1) for i in rows)
        out.append(Batch(f"wave{runs.wave}/batch{b:02d}", runs.wave, members, rows))
    return out


def run_frame(
    runs: Runs, rows: np.ndarray, name: str, ids: Sequence[str], campaign: str
) -> pd.DataFrame:
    """members × inputs of the runs ``rows``: the run columns, then the unit cube."""
    table = pd.DataFrame(
        {
            MEMBER: [member_name(name, runs.first + int(i) + 1) for i in rows],
            "wave": runs.wave,
            "point": runs.point[rows],
            "replicate": runs.replicate[rows],
            "seed": runs.seed[rows],
            "campaign": campaign,
        }
    )
    return pd.concat([table, pd.DataFrame(runs.unit[rows], columns=list(ids))], axis=1)


def plan_frame(
    inputs: pd.DataFrame, prior: Sequence[Unknown], manifests: Mapping[str, Mapping[str, Any]]
) -> pd.DataFrame:
    """The plan: each member's value of every varied unknown (12 significant digits, as the
    manifest holds it), its seed and its manifest's sha256."""
    values = {
        u.id: [float(f"{v:.12g}") for v in physical(inputs[u.id].to_numpy(), u)] for u in prior
    }
    plan = pd.DataFrame({MEMBER: inputs[MEMBER], "seed": inputs["seed"], **values})
    plan["manifest sha256"] = [manifest_sha256(manifests[m]) for m in plan[MEMBER]]
    return plan


def manifests(
    base: Mapping[str, Any],
    inputs: pd.DataFrame,
    prior: Sequence[Unknown],
    seed: Unknown | None,
    stages: Sequence[str],
) -> dict[str, dict[str, Any]]:
    """Every member's manifest (validated as a dataset manifest): the dataset's with the run's
    values set in place and its noise seed as the manifest's seed."""
    varied_ = [*prior, *([seed] if seed is not None else [])]
    out = {}
    values = {u.id: physical(inputs[u.id].to_numpy(), u) for u in prior}
    for k, name in enumerate(inputs[MEMBER]):
        point = {u.id: float(f"{values[u.id][k]:.12g}") for u in prior}
        if seed is not None:
            point[seed.id] = float(inputs["seed"].iloc[k])
        manifest = member_manifest(base, varied_, point, name, stages)
        manifest["description"] = (
            f"Validation member {name} of {base['name']}: wave {inputs['wave'].iloc[k]}, "
            f"design point {inputs['point'].iloc[k]}, replicate {inputs['replicate'].iloc[k]} "
            f"(workflow/validation.yaml's waves over workflow/unknowns.yaml). "
            + base["description"].strip()
        )
        validate_document(manifest, "dataset.schema.yaml", f"the manifest of member {name}")
        out[str(name)] = manifest
    return out


def check_done(folder: str | Path, expected: pd.DataFrame) -> None:
    """A done batch's inputs table (``folder``/inputs.csv) holds the members, seeds, campaign
    and unit-cube points drawn now (``expected``, :func:`run_frame`); else one line naming the
    file: its tables come from another draw (workflow/validation.yaml, workflow/unknowns.yaml
    or the campaign changed), and a batch is never drawn again in place."""
    path = Path(folder) / TABLES["inputs"]
    found = pd.read_csv(path)
    why = ""
    if list(found.columns) != list(expected.columns):
        why = "its columns (the varied unknowns) are not the current declaration's"
    elif list(found[MEMBER]) != list(expected[MEMBER]):
        why = "its members are not the batch's"
    elif list(found["campaign"].astype(str)) != list(expected["campaign"].astype(str)):
        why = f"it was made on campaign {found['campaign'].iloc[0]!r}"
    elif not (found["seed"].to_numpy() == expected["seed"].to_numpy()).all():
        why = "its seeds are not the current draw's"
    else:
        unit = [c for c in expected.columns if c not in RUN_COLUMNS]
        if not np.allclose(found[unit].to_numpy(float), expected[unit].to_numpy(float), atol=1e-9):
            why = "its points are not the current draw's"
    if why:
        raise ManifestError(
            f"{path}: {why}: a batch done is never drawn again; move its folder away to run it "
            "under the current draw"
        )


def locate_value(locate: Mapping[str, Any], tables: Mapping[str, pd.DataFrame]) -> float:
    """The number a target's ``locate`` names in a member's tables (relative path → table):
    ``column`` one name or several, ``where`` selecting rows (numbers compared as numbers),
    ``reduce: max`` over every selected cell, else exactly one; times ``scale``. NaN where the
    table, a column or the row is missing or the cell is empty (a stage that gave no value)."""
    table = tables.get(locate["table"])
    if table is None:
        return math.nan
    columns = locate["column"] if isinstance(locate["column"], list) else [locate["column"]]
    where = dict(locate.get("where", {}))
    if any(c not in table.columns for c in [*columns, *where]):
        return math.nan
    match = np.ones(len(table), dtype=bool)
    for key, wanted in where.items():
        if isinstance(wanted, (int, float)) and not isinstance(wanted, bool):
            numbers = pd.to_numeric(table[key], errors="coerce").to_numpy(dtype=float)
            match &= np.isclose(numbers, wanted, rtol=1e-9, atol=0.0)
        else:
            match &= (table[key].astype(str) == str(wanted)).to_numpy()
    cells = table.loc[match, columns].apply(pd.to_numeric, errors="coerce").to_numpy(float)
    if locate.get("reduce") == "max":
        finite = cells[np.isfinite(cells)]
        value = float(finite.max()) if finite.size else math.nan
    else:
        value = float(cells[0, 0]) if cells.shape == (1, 1) else math.nan
    return value * float(locate.get("scale", 1.0))


#: rows.csv's column of why a member gave no value (the step that failed), empty where it ran
FAILED_COLUMN = "failed"
#: the file of a member's folder its one job notes a failed step in, in place of its results
FAILED = "failed.txt"


def batch_tables(
    inputs: pd.DataFrame,
    cards: Mapping[str, pd.DataFrame],
    tables: Mapping[str, Mapping[str, pd.DataFrame]],
    row_keys: Sequence[str],
    targets: Sequence[tuple[str, Mapping[str, Any]]],
    failed: Mapping[str, str] | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(members × rows, members × targets) of a batch: each member's reproduced value of every
    emergent row (``row_keys``, :func:`row_key`) from its scorecard, and of every common target
    (``targets``: (id, locate)) from its tables (NaN where it gave none). A member of ``failed``
    ({member: the step that failed}) has no scorecard or tables: its values are NaN and rows.csv's
    :data:`FAILED_COLUMN` names the step."""
    failed = dict(failed or {})
    members = list(inputs[MEMBER])
    ran = {m: cards[m] for m in members if m not in failed}
    rows = member_values(ran, row_keys).reindex(members)
    rows[FAILED_COLUMN] = [failed.get(m, "") for m in members]
    values = {
        tid: [math.nan if m in failed else locate_value(loc, tables[m]) for m in members]
        for tid, loc in targets
    }
    target_frame = pd.DataFrame(values, index=pd.Index(members, name=MEMBER))
    return rows.rename_axis(index=MEMBER).reset_index(), target_frame.reset_index()


def ensemble_tables(
    *kinds: Sequence[pd.DataFrame], ids: Sequence[str], nominal: Mapping[str, float]
) -> list[pd.DataFrame]:
    """Every batch's tables of each kind (members × inputs, × rows, × targets; this
    validation's and those it joins) as one table a kind, the inputs over ``ids``
    (:func:`over_inputs`); a row or target column a batch lacks is empty."""
    inputs, *others = [pd.concat(list(frames), ignore_index=True) for frames in kinds]
    return [over_inputs(inputs, ids, nominal), *others]


def over_inputs(inputs: pd.DataFrame, ids: Sequence[str], nominal: Mapping[str, float]):
    """members × inputs over the unknowns ``ids``: the run columns, then each unknown, empty
    where a run's validation did not vary it, there at its ``nominal`` unit value (the value
    its manifest held)."""
    table = inputs.reindex(columns=[*RUN_COLUMNS, *ids])
    table = table.fillna({name: float(value) for name, value in nominal.items() if name in ids})
    empty = [name for name in ids if table[name].isna().any()]
    if empty:
        raise ManifestError(
            f"validation tables: some runs hold no value of {empty[0]} and it has no nominal",
            "validation.joins",
        )
    return table


def stamps(declaration: str | Path, unknowns: str | Path) -> dict[str, str]:
    """What every output of the validation's provenance names: the declaration's and the
    unknowns' sha256 and the commit."""
    from selfsense.envelope.unknowns import unknowns_hash
    from selfsense.envelope.validation import validation_hash
    from selfsense.io.provenance import commit

    return {
        "validation_sha256": validation_hash(declaration),
        "unknowns_sha256": unknowns_hash(unknowns),
        "commit": commit(),
    }


def row_keys(declaration) -> list[str]:
    """The declaration's rows as the tables name them (``<source> · <quantity>``)."""
    return [row_key(r.source, r.quantity) for r in declaration.rows]


# --- the workflow's view: what is done, what this run makes -------------------------------------


@dataclass(frozen=True)
class Validation:
    """The validation as one workflow run sees it: the plan, the unknowns varied (ids), every
    batch of the known waves with the folder its tables are in (None: not made yet), the
    batches this run makes, their members' manifests, the wave whose design this run makes
    (None: none), and the tables the declaration's targets read in a member's results."""

    plan: Plan
    ids: tuple[str, ...] = ()
    batches: tuple[Batch, ...] = ()
    done: Mapping[str, str] = field(default_factory=dict)
    selected: tuple[str, ...] = ()
    inputs: Mapping[str, pd.DataFrame] = field(default_factory=dict)
    plans: Mapping[str, pd.DataFrame] = field(default_factory=dict)
    manifests: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    design_wave: int | None = None
    designs: Mapping[int, str] = field(default_factory=dict)
    targets: tuple[tuple[str, Mapping[str, Any]], ...] = ()
    rows: tuple[str, ...] = ()
    first: int = 0  # the number of runs of the waves before the design this run makes
    prior: tuple[Unknown, ...] = ()  # the unknowns varied (``ids``'s)
    held: tuple[Unknown, ...] = ()  # unknowns a variant holds that the joined runs vary
    joined: tuple[str, ...] = ()  # the done batches' folders of the validations joined
    groups: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)  # variants varied

    @property
    def judged(self) -> tuple[str, ...]:
        """The inputs the verdicts are made over: the unknowns varied, then those held."""
        return (*self.ids, *(u.id for u in self.held))

    def models(self) -> list[dict[str, Any]]:
        """The models a variant validation judges (:func:`variant_models`) as plain data (a
        rule's param: ``Model(**it)`` is the model again); none for a validation of today's
        twin."""
        if not self.groups:
            return []
        return [asdict(m) for m in variant_models(self.prior, self.groups, self.held)]

    def model(self) -> dict[str, Any]:
        """What the verdicts read of the model judged (rule validation_verdicts' param): the
        inputs, each one's nominal as a unit value, and those held there (every variant's
        keys free: a variant validation's verdicts are all the variants')."""
        every = (*self.prior, *self.held)
        return {
            "ids": list(self.judged),
            "nominal": {u.id: quantile(u.nominal, u) for u in every},
            "fixed": {u.id: quantile(u.nominal, u) for u in self.held},
        }

    @property
    def tables(self) -> list[str]:
        """The tables (relative to results/<member>/) the common targets read."""
        return list(dict.fromkeys(loc["table"] for _, loc in self.targets))

    def batch(self, batch_id: str) -> Batch:
        return next(b for b in self.batches if b.id == batch_id)

    def folder(self, batch_id: str, results: str) -> str:
        """Where a batch's tables are: a done batch's folder, else the one this run writes."""
        return self.done.get(batch_id, f"{results}/{batch_id}")


def undrawn(plan: Plan) -> Validation:
    """The validation of a run that asks for none of it: its plan alone, nothing read."""
    return Validation(plan)


def _has_tables(folder: Path) -> bool:
    return all((folder / name).is_file() for name in TABLES.values())


def draw(
    plan: Plan,
    declaration,
    base: Mapping[str, Any],
    unknowns: Sequence[Unknown],
    campaign: str,
    results: str | Path,
    snapshot: str | Path,
    named: Iterable[str] = (),
) -> Validation:
    """The validation of this run: the declared waves' runs as far as their designs exist (wave
    1 always; a later one once its design table was made, under ``results`` or the committed
    ``snapshot``), each capped at ``plan.members``, in batches; a batch whose tables exist in
    either place is done (and checked to be the current draw's, :func:`check_done`), the first
    ``plan.batches`` of the others (all with 0) are made by this run, with the members in
    ``named`` (a target naming one) drawn too. When every batch of the last known wave is done
    and ``plan.waves`` asks for more, the next wave's design is this run's to make."""
    if declaration.dataset != plan.dataset:
        raise ManifestError(
            f"config.yaml: key validation.dataset: {plan.dataset} is not the dataset "
            f"workflow/validation.yaml declares ({declaration.dataset})",
            "validation.dataset",
        )
    settings = declaration.settings
    if plan.variants and not settings["variants"]:
        raise ManifestError(
            "config.yaml: key validation.variants: workflow/validation.yaml declares no variants",
            "validation.variants",
        )
    groups = settings["variants"].get("groups", {}) if plan.variants else {}
    declared = 1 if plan.variants else int(settings["waves"]["stop"]["max_waves"])
    if plan.waves > declared:
        raise ManifestError(
            f"config.yaml: key validation.waves: {plan.waves} is more than the {declared} waves "
            "workflow/validation.yaml declares",
            "validation.waves",
        )
    prior, seed = varied(unknowns, plan.dataset, groups)
    ids = tuple(u.id for u in prior)
    holds = {h for g in groups.values() for h in g.get("holds", ())}
    held = tuple(u for u in varied(unknowns, plan.dataset)[0] if u.id in holds)
    results, snapshot = Path(results), Path(snapshot)
    joined = tuple(b for name in plan.joins for b in joined_batches(snapshot.parent, name))
    wave_one = settings["variants"] if plan.variants else settings["waves"]
    waves = [first_wave(wave_one, len(ids)).head(plan.members)]
    designs: dict[int, str] = {}
    design_wave = None
    all_batches: list[Batch] = []
    done: dict[str, str] = {}
    frames: dict[str, pd.DataFrame] = {}
    w = 1
    while True:
        runs = waves[-1]
        for b in batches(runs, plan.name, plan.batch):
            all_batches.append(b)
            frames[b.id] = run_frame(runs, b.rows, plan.name, ids, campaign)
            for place in (results / b.id, snapshot / b.id):
                if _has_tables(place):
                    check_done(place, frames[b.id])
                    done[b.id] = str(place)
                    break
        complete = all(b.id in done for b in all_batches if b.wave == w)
        if w >= plan.waves or not complete or not len(runs):
            break
        w += 1
        found = [p / f"wave{w}" / DESIGN for p in (results, snapshot)]
        found = [p for p in found if p.is_file()]
        first = sum(len(r) for r in waves)
        if not found:
            design_wave = w
            break
        designs[w] = str(found[0])
        table = pd.read_csv(found[0])
        waves.append(wave_from_design(w, table, ids, first).head(plan.members))
    pending = [b.id for b in all_batches if b.id not in done]
    selected = tuple(pending if plan.batches == 0 else pending[: plan.batches])
    wanted = {m for b in all_batches if b.id in selected for m in b.members} | set(named)
    inputs = {b: frames[b] for b in selected}
    member_rows = pd.concat(
        [frames[b.id][frames[b.id][MEMBER].isin(wanted)] for b in all_batches], ignore_index=True
    )
    drawn = manifests(base, member_rows, prior, seed, plan.stages) if len(member_rows) else {}
    plans = {b: plan_frame(inputs[b], prior, drawn) for b in selected}
    return Validation(
        plan=plan,
        ids=ids,
        batches=tuple(all_batches),
        done=done,
        selected=selected,
        inputs=inputs,
        plans=plans,
        manifests=drawn,
        design_wave=design_wave,
        designs=designs,
        targets=tuple((t.id, dict(t.locate)) for t in declaration.targets),
        rows=tuple(row_keys(declaration)),
        first=sum(len(r) for r in waves),
        prior=tuple(prior),
        held=held,
        joined=joined,
        groups=groups,
    )


def joined_batches(validations: Path, name: str) -> list[str]:
    """The done batches' folders of the committed validation ``name`` (under ``validations``,
    docs/snapshot/validation/), in run order; none is one line naming the key."""
    found = sorted(p.parent for p in (validations / name).glob("wave*/batch*/inputs.csv"))
    done = [str(f) for f in found if _has_tables(f)]
    if not done:
        raise ManifestError(
            f"config.yaml: key validation.joins: {name} has no committed batch under "
            f"{validations / name}",
            "validation.joins",
        )
    return done
