"""Write the scorecard's numbers into the README and docs/ pages, and keep the summary they come
from under docs/snapshot/ (so a clone shows them before its first run, and a test checks the
pages against it). Run after the thesis campaign: .venv/bin/python scripts/update_docs.py

Each block sits between the markers of selfsense.scorecard.render (BEGIN, END) on its page:

- ``counts`` (README.md): the published numbers within band per dataset, chapter and kind;
- ``deviations`` (docs/deviations.md): every emergent number out of band;
- ``calibration`` (docs/twin.md): the signatures the twin's free parameters are set to;
- ``recovery`` (docs/twin.md): what the analyses give back of the twin's truth;
- ``envelope_design`` (docs/envelope.md): how many of the dataset's unknowns
  (workflow/unknowns.yaml) the snapshot's Chapters 3–6 design varies, in how many groups, and
  which it holds;
- ``envelope`` and ``envelope_rows`` (docs/envelope.md): the reproduction envelope's
  counts and every inconsistent number, over the designs under docs/snapshot/envelope/<name>/
  (``--envelope``: the results/envelope/<name>/ folder of a `snakemake envelope` run, copied
  there with its provenance: commit, workflow/unknowns.yaml's sha256, members; a design of its
  own, such as Chapter 7's, judges the rows the others have no envelope for).

- ``validation`` (README.md) and ``validation_rows`` (docs/validation.md): each committed
  validation's posterior verdicts per chapter (a row and its twins one finding), its
  pseudo-theses' coverage, its incompatible folds, and every inconsistent finding with its fold,
  implausibility and drivers, from docs/snapshot/validation/<name>/.

``--validation``: the results/validation/<name>/ folder of a `snakemake validate` run, copied to
docs/snapshot/validation/<name>/: every done batch's tables (members × inputs, the plan, members ×
rows, members × targets, with their provenance), the later waves' designs and the verdicts. A
clone's `snakemake validate` finds those batches done and extends them, never draws them again.

``--rejudge-envelope`` remakes the snapshot's envelope verdicts from the percentiles it keeps,
with the registry as it is now (selfsense.envelope.verdicts.rejudge: a change of the judge alone),
before writing the blocks.
"""

import argparse
import json
import math
import shutil
import tempfile
from collections.abc import Mapping
from pathlib import Path

import pandas as pd
import yaml

from selfsense.envelope import figures
from selfsense.envelope.design import Design
from selfsense.envelope.render import (
    ValidationSnapshot,
    VariantSnapshot,
    combined_envelope,
    envelope_markdown,
    envelope_rows_markdown,
    validation_markdown,
    validation_rows_markdown,
    variant_rows_markdown,
    variants_markdown,
)
from selfsense.envelope.validation import load_validation
from selfsense.envelope.verdicts import envelope_summary, rejudge
from selfsense.io.manifest import load_dataset, load_yaml
from selfsense.io.provenance import code_version, write_table
from selfsense.scorecard.registry import applicable, parse_registry
from selfsense.scorecard.render import counts_markdown, deviations_markdown, replace_block

SNAPSHOT = Path("docs/snapshot")
REGISTRY = "workflow/scorecard.yaml"
PAGES = {
    "counts": Path("README.md"),
    "deviations": Path("docs/deviations.md"),
    "calibration": Path("docs/twin.md"),
    "recovery": Path("docs/twin.md"),
    "envelope": Path("docs/envelope.md"),
    "envelope_design": Path("docs/envelope.md"),
    "envelope_rows": Path("docs/envelope.md"),
    "validation": Path("README.md"),
    "validation_rows": Path("docs/validation.md"),
    "variants": Path("docs/validation.md"),
    "variant_rows": Path("docs/deviations.md"),
}
UNKNOWNS = Path(__file__).resolve().parents[1] / "workflow" / "unknowns.yaml"
DECLARATION = Path(__file__).resolve().parents[1] / "workflow" / "validation.yaml"
#: what an envelope's snapshot keeps of results/envelope/<name>/: its verdicts and figures, and
#: the ensemble's tables (members × inputs, as drawn and in the unit hypercube; members × rows;
#: members × signatures), from which any later method re-judges without running a member again
ENVELOPE_FILES = (
    "scorecard.csv",
    "sensitivity.csv",
    "plan.csv",
    "unit.csv",
    "values.csv",
    "signatures.csv",
    "forest.png",
    "tornado.png",
    "envelope_summary.rst",
)


def _number(value) -> str:
    missing = value is None or (isinstance(value, float) and math.isnan(value))
    return "–" if missing else f"{value:.4g}"


def _band(low, high) -> str:
    low, high = _number(low), _number(high)
    if low == "–":
        return f"≤ {high}"
    if high == "–":
        return f"≥ {low}"
    return f"{low} to {high}"


def _unit(unit) -> str:
    return "" if not isinstance(unit, str) else unit


def _rows_markdown(cards, intro: str, columns: tuple[str, str], chosen) -> str:
    """A table of the scorecards' rows ``chosen(card)`` picks: dataset, source, quantity, the
    published (or reference) value and the reproduced one under ``columns``, band, unit, verdict."""
    lines = [
        intro,
        "",
        f"| dataset | source | quantity | {columns[0]} | {columns[1]} | band | unit | verdict |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for dataset, card in cards.items():
        for _, row in card[chosen(card)].iterrows():
            lines.append(
                f"| {dataset} | {row['source']} | {row['quantity']} | {_number(row['published'])}"
                f" | {_number(row['reproduced'])} | {_band(row['band low'], row['band high'])}"
                f" | {_unit(row['unit'])} | {row['verdict']} |"
            )
    return "\n".join(lines)


def calibration_markdown(cards: Mapping[str, pd.DataFrame], campaign: str) -> str:
    """docs/twin.md's table: every scorecard row of kind calibration, the thesis's (or the
    paper's) value beside the twin's, with the band the calibration holds it to."""
    intro = (
        f"The signatures on the `{campaign}` campaign (the scorecards' rows of kind calibration):"
    )
    return _rows_markdown(
        cards, intro, ("published", "twin"), lambda card: card["kind"] == "calibration"
    )


def recovery_markdown(cards: Mapping[str, pd.DataFrame], campaign: str) -> str:
    """docs/twin.md's table: the scorecards' twin-recovery rows, each beside its reference (the
    twin's built value; the source's model read on the twin's noiseless states where that model
    does not fit the twin; or the analysis's own bound, such as C_e within 1 %)."""
    intro = (
        f"The twin recovery rows on the `{campaign}` campaign (the scorecards' section twin"
        " recovery):"
    )
    return _rows_markdown(
        cards, intro, ("reference", "identified"), lambda card: card["section"] == "twin recovery"
    )


def envelope_design_markdown(record: Mapping, unknowns: Path = UNKNOWNS) -> str:
    """docs/envelope.md's sentences on a design (an envelope snapshot's provenance): the unknowns
    it varied of those its dataset declared when it ran (its varied and held ones), its groups,
    the unknowns it held, those workflow/unknowns.yaml declares since, with their groups, and
    those it no longer declares."""
    design = record["design"]
    entries = yaml.safe_load(unknowns.read_text(encoding="utf-8"))["unknowns"]
    now = {e["id"]: e for e in entries if e["dataset"] == design["dataset"]}
    ran = set(record["varied"]) | set(record["held"])
    since = [e for i, e in now.items() if i not in ran]
    gone = sorted(ran - set(now))
    held = ", ".join(f"`{u}`" for u in record["held"])
    text = (
        f"The shipped design varied {len(record['varied'])} of the {len(ran)} unknowns"
        f" {design['dataset']} declared when it ran, in {len(design['groups'])} groups; it held"
        f" {len(record['held'])}: {held}."
    )
    if since:
        groups = ", ".join(dict.fromkeys(e["group"] for e in since))
        text += f" {len(since)} more are declared since, in groups it did not vary ({groups})."
    if gone:
        named = ", ".join(f"`{u}`" for u in gone)
        text += f" No longer declared (the sources fix them, CHANGELOG.md): {named}."
    return f"{text} {len(now)} in all." if since or gone else text


def render(snapshot: Path = SNAPSHOT) -> dict[str, str]:
    """The generated blocks, from the snapshot of the summary and the scorecards."""
    counts = pd.read_csv(snapshot / "scorecard_counts.csv")
    campaign = json.loads((snapshot / "campaign.json").read_text())["campaign"]
    cards = {
        p.stem.removeprefix("scorecard_"): pd.read_csv(p)
        for p in sorted(snapshot.glob("scorecard_*.csv"))
        if p.name != "scorecard_counts.csv"
    }
    designs = sorted(
        (_snapshot_design(f) for f in (snapshot / "envelope").iterdir()),
        key=_dataset_s_own_first,
    )
    validations = validation_snapshots(snapshot)
    variants = variant_snapshots(snapshot)
    # the README leads with today's twin's validations; a variant validation's verdicts are
    # all the variants' (docs/validation.md)
    todays = [v for v in validations if v.name not in {s.name for s in variants}]
    return {
        "validation": validation_markdown(todays),
        "validation_rows": validation_rows_markdown(validations),
        "variants": variants_markdown(variants),
        "variant_rows": variant_rows_markdown(variants),
        "counts": counts_markdown(counts, campaign),
        "deviations": deviations_markdown(cards),
        "calibration": calibration_markdown(cards, campaign),
        "recovery": recovery_markdown(cards, campaign),
        "envelope": envelope_markdown(designs),
        "envelope_design": envelope_design_markdown(designs[0][2]),
        "envelope_rows": envelope_rows_markdown(combined_envelope([c for c, _, _ in designs])),
    }


def validation_snapshots(snapshot: Path) -> list[ValidationSnapshot]:
    """Every committed validation with its verdicts (docs/snapshot/validation/<name>/), its
    folds named as the declaration names them."""
    folds = {f.id: f.name for f in load_validation(DECLARATION).folds}
    out = []
    for folder in sorted((snapshot / "validation").glob("*/verdicts.csv")):
        here = folder.parent
        out.append(
            ValidationSnapshot(
                here.name,
                pd.read_csv(folder),
                pd.read_csv(here / "coverage.csv"),
                pd.read_csv(here / "pit.csv"),
                json.loads((here / "verdicts.csv.json").read_text()),
                folds,
            )
        )
    return out


def variant_snapshots(snapshot: Path) -> list[VariantSnapshot]:
    """Every committed variant validation's choice (docs/snapshot/validation/<name>/variants/)."""
    return [
        VariantSnapshot(
            folder.parent.parent.name,
            pd.read_csv(folder),
            pd.read_csv(folder.parent / "rows.csv"),
            json.loads((folder.parent / "folds.csv.json").read_text()),
        )
        for folder in sorted((snapshot / "validation").glob("*/variants/folds.csv"))
    ]


def _snapshot_design(folder: Path) -> tuple[pd.DataFrame, Design, dict]:
    """(envelope scorecard, design, provenance) of one design under snapshot/envelope/."""
    provenance = json.loads((folder / "provenance.json").read_text())
    return pd.read_csv(folder / "scorecard.csv"), Design(**provenance["design"]), provenance


def _dataset_s_own_first(snapshot: tuple[pd.DataFrame, Design, dict]) -> tuple[bool, str]:
    """The dataset's own design (named after it) first: its card is the one the others fill."""
    design = snapshot[1]
    return design.name != design.dataset, design.name


def snapshot_envelope(folder: Path, snapshot: Path, wall_s: float | None) -> None:
    """Copy an envelope's results into snapshot/envelope/<name>/ with their provenance: the
    commit, the unknowns' sha256, the design, the members, the commits that made the members'
    scorecards (the verdicts may be remade later from the same members), how many members have
    a calibration row out of band, and the run's wall time, if given."""
    sidecar = json.loads((folder / "scorecard.csv.json").read_text())
    results = folder.parents[1]
    target = snapshot / "envelope" / Design(**sidecar["design"]).name
    target.mkdir(parents=True, exist_ok=True)
    for name in ENVELOPE_FILES:
        shutil.copy(folder / name, target / name)
    plan = json.loads((folder / "plan.csv.json").read_text())
    record = {
        "code": sidecar["code"]["git_describe"],
        "unknowns_sha256": sidecar["unknowns_sha256"],
        "design": sidecar["design"],
        "members": sidecar["members"],
        "members_code": sorted(
            {
                json.loads((results / m / "scorecard.csv.json").read_text())["code"]["git_describe"]
                for m in sidecar["members"]
            }
        ),
        "varied": plan["varied"],
        "held": plan["held"],
        "calibration_misses": sidecar["calibration_misses"],
        "campaign": json.loads((snapshot / "campaign.json").read_text())["campaign"],
        "wall_s": wall_s,
    }
    (target / "provenance.json").write_text(json.dumps(record, indent=1) + "\n")


#: what a validation's snapshot keeps besides its batches: the verdicts and their figures
VALIDATION_SUFFIXES = (".csv", ".json", ".png", ".pdf", ".rst")


def snapshot_validation(folder: Path, snapshot: Path) -> Path:
    """Copy a validation's results into snapshot/validation/<name>/: every batch with its four
    tables (a batch left unfinished is not a batch done), the later waves' designs, the
    verdicts, each with its provenance sidecar."""
    target = snapshot / "validation" / folder.name
    tables = ("inputs.csv", "plan.csv", "rows.csv", "targets.csv")
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        relative = path.relative_to(folder)
        if path.suffix not in VALIDATION_SUFFIXES or ".part" in path.name:
            continue
        if relative.parts[0].startswith("wave") and len(relative.parts) == 3:
            if not all((path.parent / t).is_file() for t in tables):
                continue  # a batch whose tables are not all there is not done
        (target / relative).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(path, target / relative)
    return target


def rejudge_envelopes(snapshot: Path = SNAPSHOT, raw: Path = Path("raw")) -> None:
    """Remake every snapshot envelope's scorecard, summary and forest plot from the percentiles
    its scorecard keeps, judged with the registry as it is now; its provenance then names the
    commit that judged (``code``) beside those that made the members (``members_code``)."""
    entries = parse_registry(load_yaml(REGISTRY), REGISTRY)
    code = code_version()["git_describe"]
    for folder in sorted((snapshot / "envelope").iterdir()):
        old, design, record = _snapshot_design(folder)
        card = rejudge(old, applicable(entries, load_dataset(raw, design.dataset)))
        members = len(record["members"])
        summary = envelope_summary(
            card,
            design,
            record["held"],
            len(record["varied"]),
            record["calibration_misses"],
            record["unknowns_sha256"],
            members,
        )
        with tempfile.TemporaryDirectory() as scratch:  # the writers' sidecars stay behind
            write_table(card, Path(scratch) / "scorecard.csv")
            title = f"{design.dataset}: {members} envelope members"
            figures.forest_figure(card, Path(scratch) / "forest.png", title, pdf=False)
            for name in ("scorecard.csv", "forest.png"):
                shutil.copy(Path(scratch) / name, folder / name)
        (folder / "envelope_summary.rst").write_text(summary, encoding="utf-8")
        record["members_code"] = sorted(set(record.get("members_code", [record["code"]])))
        record["code"] = code
        (folder / "provenance.json").write_text(json.dumps(record, indent=1) + "\n")


def main(
    results: Path | None,
    snapshot: Path = SNAPSHOT,
    envelope: Path | None = None,
    wall_s=None,
    rejudge_envelope: bool = False,
    validation: Path | None = None,
):
    """Snapshot the run's scorecards (``results``; None: keep the snapshot's) and an envelope's
    results (``envelope``), remake the envelopes' verdicts if asked, then write every page's
    blocks from the snapshot."""
    snapshot.mkdir(exist_ok=True)
    if results is not None:
        _snapshot_scorecards(results, snapshot)
    if envelope is not None:
        snapshot_envelope(envelope, snapshot, wall_s)
    if rejudge_envelope:
        rejudge_envelopes(snapshot)
    if validation is not None:
        snapshot_validation(validation, snapshot)
    for name, body in render(snapshot).items():
        PAGES[name].write_text(
            replace_block(PAGES[name].read_text(encoding="utf-8"), name, body), encoding="utf-8"
        )


def _snapshot_scorecards(results: Path, snapshot: Path) -> None:
    shutil.copy(results / "scorecard_counts.csv", snapshot / "scorecard_counts.csv")
    # the run's datasets: an envelope member's (pi_p885~07) is not one
    for card in sorted(c for c in results.glob("*/scorecard.csv") if "~" not in c.parent.name):
        shutil.copy(card, snapshot / f"scorecard_{card.parent.name}.csv")
    sidecar = json.loads((results / "scorecard_counts.csv.json").read_text())
    (snapshot / "campaign.json").write_text(
        json.dumps(
            {"campaign": sidecar["config"]["campaign"], "code": sidecar["code"]["git_describe"]},
            indent=1,
        )
        + "\n"
    )


if __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("--results", type=Path, default=Path("results"))
    cli.add_argument("--envelope", type=Path, help="results/envelope/<name>/ of an envelope")
    cli.add_argument("--envelope-wall-s", type=float, help="the envelope run's wall time [s]")
    cli.add_argument(
        "--envelope-only",
        action="store_true",
        help="snapshot the envelope alone, keeping the snapshot's scorecards (a design run "
        "apart from the campaign, such as Chapter 7's)",
    )
    cli.add_argument(
        "--rejudge-envelope",
        action="store_true",
        help="remake the snapshot's envelope verdicts from the percentiles it keeps (a change of "
        "the judge alone), keeping the snapshot's scorecards",
    )
    cli.add_argument(
        "--validation",
        type=Path,
        help="results/validation/<name>/ of a validation: its done batches' tables and its "
        "verdicts into docs/snapshot/validation/<name>/, keeping the snapshot's scorecards",
    )
    args = cli.parse_args()
    only = args.envelope_only or args.rejudge_envelope or args.validation is not None
    results = None if only else args.results
    main(
        results,
        envelope=args.envelope,
        wall_s=args.envelope_wall_s,
        rejudge_envelope=args.rejudge_envelope,
        validation=args.validation,
    )
