"""The envelope's numbers as the documentation quotes them: the README's counts per chapter and
docs/envelope.md's list of inconsistent numbers, over one or several designs' envelope scorecards
(scripts/update_docs.py writes them between the markers of :mod:`selfsense.scorecard.render`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

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
        for _, row in part.iterrows():
            unit = f" {row['unit']}" if isinstance(row["unit"], str) and row["unit"] else ""
            drivers = row["driven by"] if isinstance(row["driven by"], str) else ""
            lines.append(
                f"  - {row['source']}, {row['quantity']}: published {row['published']:.4g}, "
                f"envelope {row['p2.5']:.4g} to {row['p97.5']:.4g}{unit} "
                f"({row['distance [widths]']:.2g} widths{edge_note(row)}); "
                f"driven by {drivers or '–'}"
            )
    return "\n".join(lines)
