"""The validation's declaration (workflow/validation.yaml): loading, checking, provenance.

The history matching conditions the twin's unknowns on what the thesis measured and judges each
fold of published numbers on the others. What it conditions on, how rows are held out, each
row's observation and discrepancy spread, the cutoff and the method's settings are declared in
one file before any result of the method exists, so that none of them can follow the results.

:func:`load_validation` validates the file against ``schemas/validation.schema.yaml`` and then
makes the checks a schema cannot: every emergent row of the registry (workflow/scorecard.yaml)
for the dataset in exactly one fold, every row a fold names present in the registry, classes and
calibration signatures that exist, captures that are experiments of the dataset's protocols and
that no two folds share (rows from one capture are one fold), a variance for every judged row and
target, and a registry "no verdict" row in an unjudged class (and only such rows). Each refusal is
one line naming the file and the key. The result carries every row and target on its transformed
scale, with its observation and discrepancy sd there: the method's modules take arrays from it and
read no file. :func:`validation_hash` is the file's sha256, for every output's provenance.
"""

from __future__ import annotations

import datetime
import hashlib
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from selfsense.io.manifest import ManifestError, load_dataset, load_yaml, validate_document
from selfsense.scorecard.registry import EMERGENT, Entry, applicable, last_digit, parse_registry
from selfsense.scorecard.scoring import band as registry_band

TRANSFORMS = ("identity", "log", "log1m")


@dataclass(frozen=True)
class Component:
    """One source of observation error: ``sd`` (the quantity's unit), ``rel`` (a fraction of its
    value), ``rounding`` (the printed last digit d: uniform over ±d/2, sd d/√12) or
    ``half_band`` (a calibration band's half-width over this number). One ``in_simulator`` is
    named but not added: the twin's instruments make it, so the replicates' spread carries it."""

    what: str
    source: str
    sd: float | None = None
    rel: float | None = None
    rounding: bool = False
    half_band: float | None = None
    in_simulator: str = ""

    def natural_sd(self, value: float, last: float, half_width: float) -> float:
        """The sd in the quantity's unit at ``value`` (0 when the simulator makes it)."""
        if self.in_simulator:
            return 0.0
        if self.sd is not None:
            return self.sd
        if self.rel is not None:
            return self.rel * abs(value)
        if self.rounding:
            return last / math.sqrt(12.0)
        return half_width / self.half_band


@dataclass(frozen=True)
class QuantityClass:
    """A kind of quantity: its transform, observation components and discrepancy sd (on the
    transformed scale, with its argument); ``judged`` False for rows the registry gives no
    verdict (then ``why`` says so and no spread is needed)."""

    id: str
    judged: bool = True
    transform: str = "identity"
    observation: tuple[Component, ...] = ()
    discrepancy_sd: float = 0.0
    argument: str = ""
    why: str = ""


@dataclass(frozen=True)
class Row:
    """One emergent registry row as the validation sees it.

    ``low``/``high`` are what the row asserts on the transformed scale: equal for a printed value,
    one infinite for a bound (the registry band's threshold, not the printed value); ``obs_sd``
    and ``md_sd`` its observation and discrepancy sd on that scale; ``band`` the registry band on
    that scale (what "uninformative" is judged against).
    """

    fold: str
    source: str
    quantity: str
    unit: str
    published: float
    cls: str
    transform: str
    low: float
    high: float
    obs_sd: float
    md_sd: float
    band: tuple[float, float]
    judged: bool
    condition: bool

    @property
    def key(self) -> tuple[str, str]:
        return self.source, self.quantity


@dataclass(frozen=True)
class Target:
    """A common target: what it asserts (``low``–``high`` on the transformed scale), its spreads
    there, the captures it is measured on, and where the twin's value is read."""

    id: str
    kind: str
    quantity: str
    unit: str
    cls: str
    transform: str
    low: float
    high: float
    obs_sd: float
    md_sd: float
    captures: tuple[str, ...]
    locate: Mapping[str, Any]
    source: str


@dataclass(frozen=True)
class Fold:
    """Rows held out together; ``left_out`` the common targets measured on its own captures,
    which its conditioning leaves out."""

    id: str
    name: str
    captures: tuple[str, ...]
    rows: tuple[Row, ...]
    left_out: tuple[str, ...] = ()


@dataclass(frozen=True)
class Declaration:
    version: int
    date: str
    dataset: str
    cutoff: float
    second_maximum_from: int
    classes: Mapping[str, QuantityClass]
    folds: tuple[Fold, ...]
    targets: tuple[Target, ...]
    settings: Mapping[str, Any] = field(default_factory=dict)  # waves, emulator, prediction, …

    @property
    def rows(self) -> tuple[Row, ...]:
        return tuple(r for f in self.folds for r in f.rows)

    def fold(self, fold_id: str) -> Fold:
        return next(f for f in self.folds if f.id == fold_id)


def validation_hash(path: str | Path) -> str:
    """sha256 of the file's bytes: every output of the method records it, so a verdict names the
    exact declaration it was made under (a comment changed is a different declaration)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def load_validation(
    path: str | Path,
    root: str | Path | None = None,
    registry: Sequence[Entry] | None = None,
    manifest: Mapping[str, Any] | None = None,
) -> Declaration:
    """The declaration of ``path`` (workflow/validation.yaml), validated and checked against the
    registry, the calibration signatures and the protocols' captures.

    ``root`` is the workflow's folder (by default the folder above the file's own): the registry
    is <root>/workflow/scorecard.yaml, the signatures <root>/workflow/twin_calibration.yaml, the
    protocols <root>/workflow/protocols/, the manifest <root>/raw/<dataset>/dataset.yaml.
    ``registry`` and ``manifest`` replace the files' (tests).
    """
    path = Path(path)
    root = path.resolve().parent.parent if root is None else Path(root)
    doc = load_yaml(path)
    try:
        validate_document(doc, "validation.schema.yaml", path)
    except ManifestError as err:
        raise _named(err, doc) from None
    _check_date(doc["date"], path)
    if manifest is None:
        manifest = load_dataset(root / "raw", doc["dataset"])
    if registry is None:
        registry = parse_registry(load_yaml(root / "workflow" / "scorecard.yaml"))
    emergent = [e for e in applicable(registry, manifest) if e.kind == EMERGENT]
    signatures = _signatures(root / "workflow" / "twin_calibration.yaml")
    catalogue = _captures(root / "workflow" / "protocols", manifest.get("protocols", ()))
    classes = {name: _class(name, c) for name, c in doc["classes"].items()}
    folds = _folds(doc["folds"], emergent, classes, catalogue, path)
    targets = _targets(doc["targets"], classes, signatures, catalogue, path)
    folds = tuple(
        Fold(
            f.id,
            f.name,
            f.captures,
            f.rows,
            tuple(t.id for t in targets if set(t.captures) & set(f.captures)),
        )
        for f in folds
    )
    _check_history(doc, path)
    _check_variant_rows(doc.get("variants", {}), folds, path)
    settings = {
        k: doc[k] for k in ("waves", "emulator", "prediction", "pseudo_theses", "description")
    } | {"variants": doc.get("variants", {})}
    return Declaration(
        version=doc["version"],
        date=doc["date"],
        dataset=doc["dataset"],
        cutoff=float(doc["cutoff"]["implausibility"]),
        second_maximum_from=int(doc["cutoff"]["second_maximum_from"]),
        classes=classes,
        folds=folds,
        targets=targets,
        settings=settings,
    )


# --- the pieces ---------------------------------------------------------------------------------


def _named(err: ManifestError, doc: Any) -> ManifestError:
    """A schema refusal inside folds.<i> or targets.<i> with the entry's id beside its index."""
    match = re.search(r"\b(folds|targets)\.(\d+)", str(err))
    if not match or not isinstance(doc, Mapping):
        return err
    try:
        uid = doc[match.group(1)][int(match.group(2))].get("id")
    except (TypeError, IndexError, AttributeError, KeyError):
        return err
    if not isinstance(uid, str):
        return err
    text = str(err)
    return ManifestError(text.replace(match.group(0), f"{match.group(0)} ({uid})", 1), err.key)


def _check_date(date: str, path: Path) -> None:
    try:
        datetime.date.fromisoformat(date)
    except ValueError:
        raise ManifestError(f"{path}: key date: {date!r} is not a calendar date", "date") from None


def _check_history(doc: Mapping[str, Any], path: Path) -> None:
    """A history, where given, ends with this file's version and date."""
    history = doc.get("history")
    if history and (history[-1]["version"], history[-1]["date"]) != (doc["version"], doc["date"]):
        raise ManifestError(
            f"{path}: key history: its last entry is version {history[-1]['version']} of "
            f"{history[-1]['date']}, not the file's version {doc['version']} of {doc['date']}",
            "history",
        )


def _check_variant_rows(variants: Mapping[str, Any], folds: Sequence[Fold], path: Path) -> None:
    """Every row the variants' report selects is a row of some fold."""
    known = {(r.source, r.quantity) for f in folds for r in f.rows}
    for i, sel in enumerate(variants.get("rows", {}).get("select", ())):
        if (sel["source"], sel["quantity"]) not in known:
            raise ManifestError(
                f"{path}: key variants.rows.select.{i}: {sel['source']} · {sel['quantity']} is "
                "no row of the folds",
                "variants.rows",
            )


def _signatures(path: Path) -> dict[str, Mapping[str, Any]]:
    doc = load_yaml(path)
    validate_document(doc, "twin_calibration.schema.yaml", path)
    return {s["id"]: s for s in doc["signatures"]}


def _captures(protocols: Path, names: Sequence[str]) -> set[str]:
    """Every experiment of the dataset's protocols: the captures a fold or target may name."""
    found: set[str] = set()
    for name in names:
        doc = load_yaml(protocols / f"{name}.yaml")
        found.update(doc.get("experiments", {}) if isinstance(doc, Mapping) else ())
    return found


def _class(name: str, doc: Mapping[str, Any]) -> QuantityClass:
    if doc.get("judged", True) is False:
        return QuantityClass(name, judged=False, why=doc["why"].strip())
    return QuantityClass(
        name,
        transform=doc["transform"],
        observation=tuple(_component(c) for c in doc["observation"]),
        discrepancy_sd=float(doc["discrepancy"]["sd"]),
        argument=doc["discrepancy"]["argument"].strip(),
    )


def _component(doc: Mapping[str, Any]) -> Component:
    return Component(
        what=doc["what"],
        source=doc["source"].strip(),
        sd=doc.get("sd"),
        rel=doc.get("rel"),
        rounding=bool(doc.get("rounding", False)),
        half_band=doc.get("half_band"),
        in_simulator=doc.get("in_simulator", "").strip(),
    )


def _folds(
    docs: Sequence[Mapping[str, Any]],
    emergent: Sequence[Entry],
    classes: Mapping[str, QuantityClass],
    catalogue: set[str],
    path: Path,
) -> tuple[Fold, ...]:
    by_source: dict[str, list[Entry]] = {}
    for e in emergent:
        by_source.setdefault(e.source, []).append(e)
    placed: dict[tuple[str, str], str] = {}
    owner: dict[str, str] = {}
    folds = []
    for i, fd in enumerate(docs):
        where = f"{path}: key folds.{i} ({fd['id']})"
        if any(f.id == fd["id"] for f in folds):
            raise ManifestError(f"{where}: fold id {fd['id']!r} is declared twice", "folds")
        for capture in fd["captures"]:
            if capture not in catalogue:
                raise ManifestError(
                    f"{where}.captures: {capture!r} is no experiment of the dataset's protocols"
                )
            if capture in owner:
                raise ManifestError(
                    f"{where}.captures: capture {capture!r} is also fold {owner[capture]}'s: "
                    "rows from one capture are one fold"
                )
            owner[capture] = fd["id"]
        rows = []
        for j, sel in enumerate(fd["rows"]):
            at = f"{where}.rows.{j}"
            entries = by_source.get(sel["source"])
            if not entries:
                raise ManifestError(f"{at}: the registry has no emergent row of {sel['source']!r}")
            if "quantities" in sel:
                named = {e.quantity: e for e in entries}
                missing = [q for q in sel["quantities"] if q not in named]
                if missing:
                    raise ManifestError(
                        f"{at}: the registry has no emergent row {sel['source']!r}, {missing[0]!r}"
                    )
                entries = [named[q] for q in sel["quantities"]]
            cls = classes.get(sel["class"])
            if cls is None:
                raise ManifestError(f"{at}.class: no class {sel['class']!r} in classes")
            for e in entries:
                key = (e.source, e.quantity)
                if key in placed:
                    raise ManifestError(
                        f"{at}: row {e.source!r}, {e.quantity!r} is also in fold {placed[key]}: "
                        "a row belongs to exactly one fold"
                    )
                placed[key] = fd["id"]
                rows.append(_row(fd["id"], e, cls, sel.get("condition", True), at))
        folds.append(Fold(fd["id"], fd["name"], tuple(fd["captures"]), tuple(rows)))
    unplaced = [e for e in emergent if (e.source, e.quantity) not in placed]
    if unplaced:
        e = unplaced[0]
        raise ManifestError(
            f"{path}: key folds: row {e.source!r}, {e.quantity!r} is in no fold "
            f"({len(unplaced)} emergent rows unplaced): every emergent row belongs to one",
            "folds",
        )
    return tuple(folds)


def _row(fold: str, e: Entry, cls: QuantityClass, condition: bool, at: str) -> Row:
    no_verdict = e.tolerance is None
    if no_verdict and cls.judged:
        raise ManifestError(
            f"{at}: row {e.source!r}, {e.quantity!r} has no verdict in the registry "
            f"({e.band.name}), so its class {cls.id!r} must be judged: false"
        )
    if not no_verdict and not cls.judged:
        raise ManifestError(
            f"{at}: row {e.source!r}, {e.quantity!r} has a verdict in the registry "
            f"({e.band.name}), so its class {cls.id!r} cannot be unjudged"
        )
    published = float(e.published)
    if not cls.judged:
        nan = math.nan
        return Row(fold, e.source, e.quantity, e.unit, published, cls.id, "identity",
                   nan, nan, nan, nan, (nan, nan), False, False)  # fmt: skip
    lo, hi = registry_band(published, e)
    # a bound row asserts the registry's threshold, a point row its printed value
    low, high = (lo, hi) if e.bound else (published, published)
    centre = high if e.bound == "upper" else low if e.bound == "lower" else published
    printed = e.printed if e.printed is not None else _printed(published)
    what = f"{at}: row {e.source!r}, {e.quantity!r}"
    natural = math.sqrt(
        sum(c.natural_sd(centre, last_digit(printed), 0.0) ** 2 for c in cls.observation)
    )
    t_low, t_high = (_forward(cls.transform, v, what) for v in (low, high))
    band = tuple(_forward(cls.transform, v, what, clip=True) for v in (lo, hi))
    return Row(
        fold=fold,
        source=e.source,
        quantity=e.quantity,
        unit=e.unit,
        published=published,
        cls=cls.id,
        transform=cls.transform,
        low=t_low,
        high=t_high,
        obs_sd=_sd_on_scale(cls.transform, centre, natural),
        md_sd=cls.discrepancy_sd,
        band=band,
        judged=True,
        condition=condition,
    )


def _targets(
    docs: Sequence[Mapping[str, Any]],
    classes: Mapping[str, QuantityClass],
    signatures: Mapping[str, Mapping[str, Any]],
    catalogue: set[str],
    path: Path,
) -> tuple[Target, ...]:
    targets: list[Target] = []
    for i, td in enumerate(docs):
        where = f"{path}: key targets.{i} ({td['id']})"
        if any(t.id == td["id"] for t in targets):
            raise ManifestError(f"{where}: target id {td['id']!r} is declared twice", "targets")
        cls = classes.get(td["class"])
        if cls is None:
            raise ManifestError(f"{where}.class: no class {td['class']!r} in classes")
        if not cls.judged:
            raise ManifestError(
                f"{where}.class: class {cls.id!r} is unjudged and has no variance: a target "
                "needs an observation and a discrepancy spread"
            )
        for capture in td["captures"]:
            if capture not in catalogue:
                raise ManifestError(
                    f"{where}.captures: {capture!r} is no experiment of the dataset's protocols"
                )
        half = 0.0
        if td["kind"] == "signature":
            sig = signatures.get(td["signature"])
            if sig is None:
                raise ManifestError(
                    f"{where}.signature: no signature {td['signature']!r} in "
                    "workflow/twin_calibration.yaml"
                )
            b_lo, b_hi = sig["band"]
            centre, half = (b_lo + b_hi) / 2, (b_hi - b_lo) / 2
            low = high = centre
            quantity, unit, locate = sig["signature"], sig["unit"], sig["locate"]
        else:
            quantity, unit, locate = td["quantity"], td["unit"], td["locate"]
            if "value" in td:
                low = high = centre = float(td["value"])
            elif "upper" in td:
                low, high = -math.inf, float(td["upper"])
                centre = high
            else:
                low, high = float(td["lower"]), math.inf
                centre = low
        printed = _printed(centre)
        natural = math.sqrt(
            sum(c.natural_sd(centre, last_digit(printed), half) ** 2 for c in cls.observation)
        )
        if natural == 0.0 and cls.discrepancy_sd == 0.0:
            raise ManifestError(
                f"{where}: class {cls.id!r} gives it no variance (observation and discrepancy "
                "both 0): an implausibility needs a spread"
            )
        t_low, t_high = (_forward(cls.transform, v, where) for v in (low, high))
        targets.append(
            Target(
                id=td["id"],
                kind=td["kind"],
                quantity=quantity,
                unit=unit,
                cls=cls.id,
                transform=cls.transform,
                low=t_low,
                high=t_high,
                obs_sd=_sd_on_scale(cls.transform, centre, natural),
                md_sd=cls.discrepancy_sd,
                captures=tuple(td["captures"]),
                locate=locate,
                source=td["source"].strip(),
            )
        )
    return tuple(targets)


def _printed(value: float) -> str:
    """A number as the thesis would print it, for its last digit: 14374.0 → '14374'."""
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text


def transform(kind: str, values: np.ndarray) -> np.ndarray:
    """The emulators' scale: log for a positive quantity, log(1 − value) for a goodness of fit
    (the registry's scales, docs/scorecard.md), else the value."""
    values = np.asarray(values, dtype=float)
    if kind == "log":
        return np.log(values)
    if kind == "log1m":
        return np.log1p(-values)
    return values


def inverse(kind: str, values: np.ndarray) -> np.ndarray:
    """Back from the emulators' scale to the quantity's."""
    values = np.asarray(values, dtype=float)
    if kind == "log":
        return np.exp(values)
    if kind == "log1m":
        return -np.expm1(values)
    return values


def _forward(kind: str, value: float, what: str, clip: bool = False) -> float:
    """One edge on the transformed scale; an infinite edge stays infinite."""
    if math.isinf(value):
        return value
    if kind == "log" and value <= 0 or kind == "log1m" and value >= 1:
        if clip:  # a band edge beyond the scale's domain: the band is open there
            return -math.inf if kind == "log" else math.inf
        raise ManifestError(
            f"{what}: {value:g} is outside the domain of its class's transform {kind!r}"
        )
    return float(transform(kind, np.array(value)))


def _sd_on_scale(kind: str, centre: float, sd: float) -> float:
    """An sd in the quantity's unit carried to the transformed scale to first order (the delta
    method): sd/|z| on log, sd/(1 − z) on log(1 − z)."""
    if kind == "log":
        return sd / abs(centre)
    if kind == "log1m":
        return sd / (1.0 - centre)
    return sd
