"""The envelope's and the validation's numbers as the documentation quotes them: the README's
counts per chapter, docs/envelope.md's list of inconsistent numbers over one or several designs'
envelope scorecards, and the validation's verdicts, pseudo-theses and incompatible folds with
docs/validation.md's list of inconsistent rows (scripts/update_docs.py writes them between the
markers of :mod:`selfsense.scorecard.render`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from selfsense.envelope import fold_prediction, judgement, variant_choice
from selfsense.envelope.campaign import TODAY
from selfsense.envelope.design import Design
from selfsense.envelope.verdicts import (
    INCONSISTENT,
    NO_ENVELOPE,
    VERDICTS,
    edge_note,
    edge_rows,
    findings,
)
from selfsense.scorecard.render import chapter_label


def combined_envelope(cards: Sequence[pd.DataFrame]) -> pd.DataFrame:
    """One envelope scorecard from several designs' (a design of its own for Chapter 7, whose
    records are too long to run in the others' members): each emergent row takes its columns from
    the design that judged it, the first card's where none did. A row two designs judged is an
    error: which of the two verdicts stands would be a choice nobody declared."""
    key = ["source", "quantity"]
    combined = cards[0].set_index(key)
    judged = combined["envelope verdict"] != NO_ENVELOPE
    for card in cards[1:]:
        other = card.set_index(key)
        missing = other.index.difference(combined.index)
        if len(missing):
            raise ValueError(f"envelope rows of no other design: {list(missing)}")
        theirs = other.index[other["envelope verdict"] != NO_ENVELOPE]
        twice = theirs[judged.loc[theirs].to_numpy()]
        if len(twice):
            raise ValueError(f"envelope rows judged by two designs: {list(twice)}")
        combined.loc[theirs, other.columns] = other.loc[theirs]
        judged.loc[theirs] = True
    return combined.reset_index()[cards[0].columns]


def envelope_markdown(designs: Sequence[tuple[pd.DataFrame, Design, Mapping[str, Any]]]) -> str:
    """The README's envelope counts: per chapter, the emergent rows and the findings among them (a
    row and its algebraic twins are one), the findings consistent (informative), consistent
    (uninformative), inconsistent, without a verdict and without an envelope, the nominal twin's
    within band beside them, over the designs' envelope scorecards (:func:`combined_envelope`); each
    design named with the chapters it gave verdicts for, its members and its code (``designs``:
    (scorecard, design, provenance) of each)."""
    card = combined_envelope([c for c, _, _ in designs])
    named = []
    for design_card, design, provenance in designs:
        judged = design_card.loc[design_card["envelope verdict"] != NO_ENVELOPE, "chapter"]
        chapters = list(dict.fromkeys(str(c) for c in judged))
        word = "Chapter" if len(chapters) == 1 else "Chapters"
        method = design.method + (f" and {design.spread} latin" if design.spread else "")
        code = provenance["code"]
        made = [c for c in provenance.get("members_code", []) if c != code]
        if made:
            code = f"{code} (its members {', '.join(made)})"
        named.append(
            f"{word} {', '.join(chapters)}: {len(provenance['members'])} members, "
            f"{method}, `docs/snapshot/envelope/{design.name}/`, code {code}"
        )
    lines = [
        f"The reproduction envelope of `{designs[0][1].dataset}` "
        f"on the `{designs[0][2]['campaign']}` campaign ({'; '.join(named)}):",
        "",
        "| chapter | emergent rows | findings | consistent | consistent (uninformative) "
        "| inconsistent | no verdict | no envelope | nominal: within band |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    parts = [(str(c), p) for c, p in card.groupby("chapter", sort=False)] + [("total", card)]
    for chapter, part in parts:
        own = part[findings(part)]
        tally = own["envelope verdict"].value_counts()
        name = "**total**" if chapter == "total" else chapter_label(chapter)
        cells = [str(len(part)), str(len(own)), *(str(int(tally.get(v, 0))) for v in VERDICTS)]
        within = int((own["verdict"] == "within band").sum())
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {within} |")
    return "\n".join(lines)


def envelope_rows_markdown(card: pd.DataFrame) -> str:
    """docs/envelope.md's list: every inconsistent finding (a row with its algebraic twins) with
    its envelope, distance (and whether it is on the edge) and drivers, per chapter."""
    out = card[findings(card) & (card["envelope verdict"] == INCONSISTENT)]
    edge = int(edge_rows(out).sum())
    on_edge = f"; {edge} of them on the edge, where one member's draw decides" if edge else ""
    lines = [f"{len(out)} findings are inconsistent with the envelope{on_edge}.", ""]
    for chapter, part in out.groupby("chapter", sort=False):
        lines.append(f"- {chapter_label(chapter)}:")
        lines += [
            "  "
            + _row_line(row, "envelope", f"{row['distance [widths]']:.2g} widths{edge_note(row)}")
            for _, row in part.iterrows()
        ]
    return "\n".join(lines)


def _row_line(row: pd.Series, interval: str, note: str) -> str:
    """One listed row: its source and quantity, the published value, the ``interval``'s 2.5–97.5 %
    in its unit with ``note``, and its drivers."""
    unit = f" {row['unit']}" if isinstance(row["unit"], str) and row["unit"] else ""
    drivers = row["driven by"] if isinstance(row["driven by"], str) else ""
    return (
        f"- {row['source']}, {row['quantity']}: published {row['published']:.4g}, {interval} "
        f"{row['p2.5']:.4g} to {row['p97.5']:.4g}{unit} ({note}); driven by {drivers or '–'}"
    )


@dataclass(frozen=True)
class ValidationSnapshot:
    """One validation's committed results (docs/snapshot/validation/<name>/): its verdicts, the
    pseudo-theses (one row each) and their PIT table, the verdicts' provenance sidecar, and its
    folds' names."""

    name: str
    verdicts: pd.DataFrame
    coverage: pd.DataFrame
    pit: pd.DataFrame
    provenance: Mapping[str, Any]
    folds: Mapping[str, str]

    def incompatible(self) -> list[str]:
        """The folds the others leave no bench for, each with its name."""
        v = self.verdicts
        ids = v.loc[v["verdict"] == fold_prediction.INCOMPATIBLE, "fold"].unique()
        return [f"{f} ({self.folds.get(f, f)})" for f in ids]


#: a row no run of the ensemble gave a value (its stage was not run): not emulable, said so
NOT_RUN = "not run"


def _own(verdicts: pd.DataFrame) -> pd.DataFrame:
    """The findings (:func:`selfsense.envelope.judgement.findings`), one no run gave a value
    :data:`NOT_RUN` rather than not emulable."""
    own = judgement.findings(verdicts).copy()
    unrun = (own["verdict"] == fold_prediction.NOT_EMULABLE) & (own["runs"] == 0)
    own.loc[unrun, "verdict"] = NOT_RUN
    return own


def coverage_sentence(pit: pd.DataFrame, pseudo_theses: int) -> str:
    """The pseudo-theses' coverage at 95 % and PIT histogram in tenths under the declaration's
    latest test, as one sentence, the earlier tests' coverage after it."""
    top = judgement.headline(pit)
    inside = top["inside 95 %"].astype(bool)
    if not len(inside):
        return f"{pseudo_theses} pseudo-theses: no held-out row had an interval."
    counts, _ = np.histogram(top["PIT"].astype(float), bins=10, range=(0.0, 1.0))
    named = "test" in pit
    test = f", test “{top['test'].iloc[0]}”" if named else ""
    tests = pit.groupby("test", sort=False)["inside 95 %"] if named else []
    earlier = [f"“{k}”: {v.astype(bool).mean():.1%}" for k, v in tests if k != top["test"].iloc[0]]
    return (
        f"{pseudo_theses} pseudo-theses (members of the ensemble as the bench, their numbers "
        f"printed as the thesis prints them, through the same leave-one-fold-out){test}: "
        f"{int(inside.sum())} of {len(inside)} held-out rows inside their 95 % interval, "
        f"**{inside.mean():.1%}** (the method's claim: 90–99 %); PIT histogram in tenths "
        + " ".join(str(int(c)) for c in counts)
        + "."
        + (f" The earlier test, {'; '.join(earlier)}." if earlier else "")
    )


def validation_markdown(snapshots: Sequence[ValidationSnapshot]) -> str:
    """The README's validation block: per validation, its runs, declaration and code; the
    findings' posterior verdicts per chapter; the pseudo-theses' coverage; the incompatible
    folds."""
    if not snapshots:
        return "No validation is committed yet (`snakemake validate`, docs/validation.md)."
    blocks = []
    columns = [*fold_prediction.VERDICTS, NOT_RUN]
    for snap in snapshots:
        record = snap.provenance
        code = record["code"]["git_describe"]
        lines = [
            f"The validation `{snap.name}` (`docs/snapshot/validation/{snap.name}/`: "
            f"{record['members']} runs, `workflow/validation.yaml` sha256 "
            f"{record['validation_sha256'][:12]}, code {code}): every emergent row predicted "
            "from the other folds on the posterior predictive. Findings (a row and its "
            "algebraic twins are one):",
            "",
            "| chapter | findings | " + " | ".join(columns) + " |",
            "|---" * (len(columns) + 2) + "|",
        ]
        own = _own(snap.verdicts)
        parts = [(str(c), q) for c, q in own.groupby("chapter", sort=False)] + [("total", own)]
        for chapter, part in parts:
            tally = part["verdict"].value_counts()
            name = "**total**" if chapter == "total" else chapter_label(chapter)
            cells = [str(len(part)), *(str(int(tally.get(v, 0))) for v in columns)]
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
        folds = snap.incompatible()
        lines += [
            "",
            coverage_sentence(snap.pit, snap.coverage["member"].nunique()),
            "Incompatible folds (the other folds leave no bench): "
            + (", ".join(folds) if folds else "none")
            + ".",
        ]
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def validation_rows_markdown(snapshots: Sequence[ValidationSnapshot]) -> str:
    """docs/validation.md's list: per validation, every inconsistent finding with its fold, its
    posterior-predictive interval, the published value's implausibility and its drivers, and
    the incompatible folds with their rows' count."""
    if not snapshots:
        return "No validation is committed yet."
    lines: list[str] = []
    for snap in snapshots:
        own = _own(snap.verdicts)
        out = own[own["verdict"] == fold_prediction.INCONSISTENT]
        lines += [f"`{snap.name}`: {len(out)} findings inconsistent.", ""]
        lines += [
            _row_line(row, "predicted", f"{row['fold']}, I = {row['implausibility']:.3g}")
            for _, row in out.iterrows()
        ]
        incompatible = own[own["verdict"] == fold_prediction.INCOMPATIBLE]
        if len(incompatible):
            lines += [
                "",
                "Incompatible folds (the other folds leave no bench), with their findings:",
            ]
            lines += [
                f"- {fold} ({snap.folds.get(fold, fold)}): {len(part)}"
                for fold, part in incompatible.groupby("fold", sort=True)
            ]
        lines.append("")
    return "\n".join(lines).rstrip()


@dataclass(frozen=True)
class VariantSnapshot:
    """One variant validation's committed choice (docs/snapshot/validation/<name>/variants/):
    each fold's state per model, the declared rows under every model, the provenance."""

    name: str
    folds: pd.DataFrame  # fold, then one column per model
    rows: pd.DataFrame
    provenance: Mapping[str, Any]


def variants_markdown(snapshots: Sequence[VariantSnapshot]) -> str:
    """docs/validation.md's table of the variants: per model the folds it holds, fails and
    cannot judge, those it reconciles and breaks against today's twin, and whether it is
    supported."""
    if not snapshots:
        return "No variant validation is committed yet (`validation.variants`, above)."
    blocks = []
    for snap in snapshots:
        states = snap.folds.set_index("fold")
        chosen = variant_choice.supported(states)
        lines = [
            f"`{snap.name}` ({snap.provenance['members']} runs, `workflow/validation.yaml` sha256 "
            f"{snap.provenance['validation_sha256'][:12]}, code "
            f"{snap.provenance['code']['git_describe']}): each fold predicted from the others "
            "under every model.",
            "",
            "| model | holds | fails | not judged | reconciles | breaks | supported |",
            "|---|---|---|---|---|---|---|",
        ]
        for model in states.columns:
            state = states[model]
            won, lost = variant_choice.reconciled(states, model) if model != TODAY else ([], [])
            cells = [
                str(int((state == s).sum()))
                for s in (variant_choice.HOLDS, variant_choice.FAILS, variant_choice.NOT_JUDGED)
            ]
            verdict = "" if model == TODAY else ("yes" if model in chosen else "no")
            lines.append(
                f"| {model} | "
                + " | ".join(cells)
                + f" | {', '.join(won) or '–'} | {', '.join(lost) or '–'} | {verdict} |"
            )
        lines += ["", "Supported: " + (", ".join(chosen) or "none") + "."]
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def variant_rows_markdown(snapshots: Sequence[VariantSnapshot]) -> str:
    """docs/deviations.md's table: the rows every setting of today's twin misses, their verdict
    and posterior-predictive 95 % interval under every model; then each variant's effect on the
    folds it is not judged on (those it reconciles and breaks) and whether it is supported."""
    if not snapshots:
        return "No variant validation is committed yet (docs/validation.md, variants)."
    blocks = []
    for snap in snapshots:
        rows = snap.rows
        models = list(dict.fromkeys(rows["model"]))
        lines = [
            f"`{snap.name}`: each row predicted from the other folds under today's twin, each "
            "variant alone and all of them (verdict, 95 % interval):",
            "",
            "| row | published | " + " | ".join(models) + " |",
            "|---" * (len(models) + 2) + "|",
        ]
        for (source, quantity), part in rows.groupby(["source", "quantity"], sort=False):
            by = part.set_index("model")
            first = part.iloc[0]
            cells = [_variant_cell(by.loc[m]) for m in models]
            lines.append(
                f"| {source}, {quantity} | {first['published']:.4g} {first['unit']} | "
                + " | ".join(cells)
                + " |"
            )
        states = snap.folds.set_index("fold")
        failing = states.index[states[TODAY] == variant_choice.FAILS]
        lines += ["", f"Folds today's twin fails: {', '.join(failing) or 'none'}. Each variant:"]
        for model in [m for m in states.columns if m != TODAY]:
            won, lost = variant_choice.reconciled(states, model)
            chosen = "supported" if model in variant_choice.supported(states) else "not supported"
            lines.append(
                f"- {model}: reconciles {', '.join(won) or 'no fold'}, breaks "
                f"{', '.join(lost) or 'no fold'}: {chosen}"
            )
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def _variant_cell(row: pd.Series) -> str:
    if not np.isfinite(row["p2.5"]):
        return str(row["verdict"])
    return f"{row['verdict']} [{row['p2.5']:.3g}, {row['p97.5']:.3g}]"
