"""The scorecard's renderings: the report's landing page, the out-of-band and pending lists
(reStructuredText), the per-dataset HTML page, and the blocks the documentation quotes.
"""

from __future__ import annotations

import html
import math
import re
import unicodedata
from collections.abc import Mapping
from typing import Any

import pandas as pd

from selfsense.scorecard.registry import (
    BIAS,
    CAUSE_MARK,
    COLUMNS,
    EMERGENT,
    INFORMATION,
    KINDS,
    MISSING,
    NOT_YET,
    OUT,
    VERDICTS,
    WITHIN,
)
from selfsense.scorecard.scoring import bias_verdicts, counts

# --- renderings ---------------------------------------------------------------------------------


def summary(cards: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """Counts per dataset, kind and chapter (and a "total" row per dataset and kind): the numbers
    the report's opening and the README quote. ``reproduced`` = within + out of band.

    Every row counts by its verdict, a recovery row by its chain's (what the measurement gives back
    against the model on truth). The model's bias of the recovery rows centred on the model on
    truth is counted in lines of its own, kind :data:`BIAS`, by their bias verdicts (``numbers``:
    the rows that have one)."""
    rows = []
    for dataset, card in cards.items():
        judged = bias_verdicts(card) != ""
        parts = [(kind, card[card["kind"] == kind], "verdict") for kind in KINDS]
        parts.append((BIAS, card[judged], "bias verdict"))
        for kind, part, column in parts:
            if not len(part):
                continue
            groups = [(str(c), g) for c, g in part.groupby("chapter", sort=False)] + [
                ("total", part)
            ]
            for chapter, g in groups:
                n = counts(g, column)
                rows.append(
                    {
                        "dataset": dataset,
                        "kind": kind,
                        "chapter": chapter,
                        "numbers": len(g),
                        "reproduced": n[WITHIN] + n[OUT],
                        **n,
                    }
                )
    return pd.DataFrame(
        rows, columns=["dataset", "kind", "chapter", "numbers", "reproduced", *VERDICTS]
    )


def headline(counts_: pd.DataFrame) -> str:
    """One line per dataset: emergent numbers within band, then the other kinds; then, on a line of
    its own, the model's bias of the recovery numbers centred on the model on truth."""
    lines = []
    for dataset, part in counts_[counts_["chapter"] == "total"].groupby("dataset", sort=False):
        by_kind = part.set_index("kind")
        parts = [
            f"**{_rst(dataset)}**: "
            + (
                _kind_tally(by_kind.loc[EMERGENT], "emergent")
                if EMERGENT in by_kind.index
                else "no emergent numbers"
            )
        ]
        parts += [_kind_tally(by_kind.loc[k], k) for k in KINDS[1:] if k in by_kind.index]
        lines.append("; ".join(parts) + ".")
        if BIAS in by_kind.index:
            lines.append(
                f"**{_rst(dataset)}**, recovery numbers centred on the model on the twin's truth: "
                + _kind_tally(by_kind.loc[BIAS], BIAS)
                + " (the model on truth against the built value)."
            )
    return "\n\n".join(lines)


def _kind_tally(row: pd.Series, kind: str) -> str:
    text = f"{kind} {row[WITHIN]} within band of {row['reproduced']}"
    extra = [f"{row[v]} {v}" for v in (NOT_YET, MISSING, INFORMATION) if row[v]]
    return text + (f" ({', '.join(extra)})" if extra else "")


def landing_rst(cards: Mapping[str, pd.DataFrame]) -> str:
    """The short summary that opens the report: the emergent numbers (the reproduction proper) per
    chapter, then the other kinds. The long lists are pages of their own (`out_of_band_rst`,
    `pending_rst`): the report's landing text is centred vertically, so a long one starts above the
    top of the window, out of reach."""
    table = summary(_filled(cards))
    return (
        headline(table)
        + "\n\n"
        + "\n".join(_table(table[table["kind"] == EMERGENT], "Emergent numbers by chapter"))
        + "\n\n"
        + LANDING_NOTE
    )


#: what the landing page says of the kinds that are not reproductions, and of the model's bias
LANDING_NOTE = """Closed-form, recovery, calibration and check numbers are not reproductions: they \
hold by the source's own equations, by how the twin is built or calibrated, or by construction \
(docs/scorecard.md, "Kinds of numbers"). A recovery number centred on the model on the twin's \
truth is counted by what the measurement gives back of that model; the model's bias, that model \
against the value the twin is built with, is counted on a line of its own \
(docs/scorecard.md, "The model's bias").
"""


def out_of_band_rst(cards: Mapping[str, pd.DataFrame]) -> str:
    """A page: per dataset, every number out of band by source (with the registry's note saying
    why), every recovery number whose model's bias is out of its band, and every number missing
    from its table."""
    return _lists_page(
        cards,
        "Numbers out of band, and missing from their tables",
        lambda card: _out_of_band(card) + _bias_out(card) + _missing(card),
        "None: every reproduced number is within band.",
    )


def pending_rst(cards: Mapping[str, pd.DataFrame]) -> str:
    """A page: per dataset, the numbers no stage reproduces yet, by chapter and source."""
    return _lists_page(
        cards, "Numbers not reproduced yet", _pending, "None: every number is reproduced."
    )


def rst_html(text: str) -> str:
    """A self-contained HTML page of reStructuredText; a docutils warning or error raises (so a
    page never shows a "problematic" marker). Rendered as untrusted text: the ``raw`` directive
    and every file insertion (``include``, ``raw``/``csv-table`` with ``:file:`` or ``:url:``) are
    off (:data:`DOCUTILS_SAFE`), and a link or image whose URL has a scheme other than
    :data:`SAFE_SCHEMES` is reduced to its text."""
    from docutils.core import publish_doctree, publish_from_doctree

    settings = {
        "halt_level": 2,
        "report_level": 2,
        "output_encoding": "unicode",
        "embed_stylesheet": True,
        "_disable_config": True,
        **DOCUTILS_SAFE,
    }
    doctree = publish_doctree(text, settings_overrides=settings)
    _drop_unsafe_links(doctree)
    return publish_from_doctree(doctree, writer="html5", settings_overrides=settings)


#: docutils settings that keep a page's text from reaching the HTML as markup or pulling a file in
#: (docutils' "Deploying Docutils Securely": raw_enabled, file_insertion_enabled)
DOCUTILS_SAFE = {"raw_enabled": False, "file_insertion_enabled": False}
#: the URL schemes a link of a page may have (a URL without a scheme is relative: kept)
SAFE_SCHEMES = frozenset({"http", "https", "mailto"})


def safe_url(url: str) -> bool:
    """Whether a link may point at ``url``: no scheme (relative, or a fragment), or one of
    :data:`SAFE_SCHEMES`. Browsers ignore whitespace and control characters inside a scheme
    (``java\tscript:``), so they are taken out before it is read."""
    bare = re.sub(r"[\x00-\x20\x7f]+", "", url)
    scheme = re.match(r"([^/?#]*?):", bare)
    return scheme is None or scheme.group(1).lower() in SAFE_SCHEMES


def _drop_unsafe_links(doctree) -> None:
    """Every link and image of ``doctree`` whose URL :func:`safe_url` refuses becomes its text (a
    link target loses the URL)."""
    from docutils import nodes

    for node in list(doctree.findall(nodes.Element)):
        if all(safe_url(node.get(a, "")) for a in ("refuri", "uri")):
            continue
        if isinstance(node, nodes.reference):
            node.replace_self(nodes.inline("", "", *node.children))
        elif isinstance(node, nodes.image):
            inline = isinstance(node.parent, nodes.TextElement)
            node.replace_self(
                (nodes.inline if inline else nodes.paragraph)("", node.get("alt", ""))
            )
        else:
            for attr in ("refuri", "uri"):
                node.attributes.pop(attr, None)


def _filled(cards: Mapping[str, pd.DataFrame]) -> dict[str, pd.DataFrame]:
    # a scorecard read back from CSV has NaN where a text cell was empty (and one written before
    # the bias columns has none)
    text = {"unit": "", "note": "", "read from": "", "bias band": "", "bias verdict": ""}
    return {d: c.fillna({k: text[k] for k in text if k in c.columns}) for d, c in cards.items()}


def _table(table: pd.DataFrame, title: str) -> list[str]:
    lines = [
        f".. list-table:: {title}",
        "   :header-rows: 1",
        "",
        "   * - dataset",
        "     - chapter",
        "     - within band",
        "     - out of band",
        "     - not reproduced yet",
    ]
    for _, row in table.iterrows():
        lines += [
            f"   * - {_rst(row['dataset'])}",
            f"     - {_chapter(row['chapter'])}",
            *(f"     - {row[v]}" for v in (WITHIN, OUT, NOT_YET)),
        ]
    return lines


def _tally(dataset: str, card: pd.DataFrame) -> str:
    return headline(summary({dataset: card}))


def _out_of_band(card: pd.DataFrame) -> list[str]:
    out = card[card["verdict"] == OUT]
    if not len(out):
        return []
    unexplained = int((out["note"] == "").sum())
    measured = int(out["note"].str.contains(rf"(?:^|; ){CAUSE_MARK} (?:cause )?\(").sum())
    counts = [f"{measured} of {len(out)} with a measured cause"]
    if unexplained:
        counts.append(f"{unexplained} without a note in workflow/scorecard.yaml saying why")
    return [
        f"- Out of band, by source ({'; '.join(counts)}):",
        *_by_source(
            out,
            lambda row: (
                f"{_describe(row)}." + (f" Why: {_rst(row['note'])}" if row["note"] else "")
            ),
        ),
    ]


def _bias_out(card: pd.DataFrame) -> list[str]:
    """The recovery numbers whose model on the twin's truth is out of its bias band: the source's
    model reads the twin as something other than the value it is built with."""
    out = card[bias_verdicts(card) == OUT]
    if not len(out):
        return []
    return [
        "- The model's bias out of band (recovery numbers whose band is centred on the model on "
        "the twin's truth, that model against the value the twin is built with; their own verdict "
        "is in the list above when out of band):",
        *_by_source(out, _describe_bias),
    ]


def _describe_bias(row: pd.Series) -> str:
    unit = f" {_rst(row['unit'])}" if row["unit"] else ""
    change = "" if pd.isna(row["bias [%]"]) else f" ({row['bias [%]']:+.1f} %)"
    built = row["model on truth"] - row["bias"]
    return (
        f"{_rst(row['quantity'])}: model on truth {row['model on truth']:.6g}{unit}, built "
        f"{built:.6g}{unit}{change}, bias band {row['bias band low']:.6g} … "
        f"{row['bias band high']:.6g}{unit} ({_rst(row['bias band'])})"
    )


def _missing(card: pd.DataFrame) -> list[str]:
    missing = card[card["verdict"] == MISSING]
    if not len(missing):
        return []
    return [
        "- Missing from their tables (a locator to fix):",
        *_by_source(missing, lambda row: f"{_rst(row['quantity'])}: {_rst(row['note'])}"),
    ]


def _pending(card: pd.DataFrame) -> list[str]:
    pending = card[card["verdict"] == NOT_YET]
    if not len(pending):
        return []
    lines = [f"- Not reproduced yet, by chapter and source ({len(pending)} numbers):", ""]
    for chapter, part in pending.groupby("chapter", sort=False):
        per_source = part.groupby("source", sort=False).size()
        lines.append(
            f"  - {_chapter(chapter)}: "
            + ", ".join(f"{_rst(src)} ({n})" for src, n in per_source.items())
        )
    return lines + [""]


def _lists_page(cards: Mapping[str, pd.DataFrame], title: str, lists, empty: str) -> str:
    """reStructuredText of a page: its title, then per dataset a section with its tally and
    lists."""
    lines = [title, "=" * len(title), ""]
    for dataset, card in _filled(cards).items():
        head = _rst(dataset)
        lines += [head, _underline(head, "-"), "", _tally(dataset, card), ""]
        lines += lists(card) or [empty, ""]
    return "\n".join(lines) + "\n"


def _by_source(rows: pd.DataFrame, describe) -> list[str]:
    """A nested bullet list: one item per source, one sub-item per row."""
    lines = [""]
    for source, part in rows.groupby("source", sort=False):
        lines += [f"  - {_rst(source)}", ""]
        lines += [f"    - {describe(row)}" for _, row in part.iterrows()]
        lines.append("")
    return lines


def _chapter(chapter: Any) -> str:
    return f"Chapter {chapter}" if str(chapter).isdigit() else _rst(str(chapter))


def _describe(row: pd.Series) -> str:
    unit = f" {_rst(row['unit'])}" if row["unit"] else ""
    lo, hi = row["band low"], row["band high"]
    band_text = (
        f"≤ {hi:.6g}" if pd.isna(lo) else f"≥ {lo:.6g}" if pd.isna(hi) else f"{lo:.6g} … {hi:.6g}"
    )
    change = "" if pd.isna(row["deviation [%]"]) else f" ({row['deviation [%]']:+.1f} %)"
    kind = "" if row.get("kind", EMERGENT) == EMERGENT else f" ({_rst(row['kind'])})"
    return (
        f"{_rst(row['quantity'])}{kind}: published {row['published']:.6g}{unit}, "
        f"reproduced {row['reproduced']:.6g}{unit}{change}, band {band_text}{unit}"
    )


#: characters :func:`_rst` turns into spaces besides whitespace: control and format characters
#: (bidirectional overrides, zero-width spaces) and lone surrogates
_FOLDED = frozenset({"Cc", "Cf", "Cs"})


def _rst(text: Any) -> str:
    """Any text as inert reStructuredText: data, never markup, wherever a line of inline text may
    stand (a paragraph, a list item or table cell, strong emphasis, a section title). Whitespace,
    line breaks, control and format characters fold to single spaces, so the text cannot start a
    line of its own (a directive such as ``.. raw::`` or ``.. include::``, a list, a section); every
    character but letters, digits and the space is backslash-escaped, so no inline markup, role,
    reference, substitution or standalone link (``javascript:…``, ``a@b.c``) is recognised in it.
    The page shows the text as given, its whitespace folded."""
    folded = " ".join(
        "".join(" " if unicodedata.category(c) in _FOLDED else c for c in str(text)).split()
    )
    escaped = "".join(c if c.isalnum() or c == " " else "\\" + c for c in folded)
    if set(escaped) == {"\\"}:  # backslashes alone would be a line of section adornment
        return "\\ ".join(["\\\\"] * (len(escaped) // 2))  # docutils drops an escaped space
    return escaped


def _underline(title: str, char: str) -> str:
    """A section title's underline, as long as the title is wide (East Asian wide characters take
    two columns)."""
    return char * sum(2 if unicodedata.east_asian_width(c) in "WF" else 1 for c in title)


def scorecard_html(card: pd.DataFrame, title: str) -> str:
    """A self-contained page of the scorecard (the report shows HTML inline, a CSV only as a
    download)."""
    tally = ", ".join(f"{n} {v}" for v, n in counts(card).items())
    biased = counts(card, "bias verdict")
    if biased[WITHIN] + biased[OUT]:
        tally += (
            f"; the model's bias (recovery numbers centred on the model on the twin's truth, "
            f"against the built value): {biased[WITHIN]} {WITHIN}, {biased[OUT]} {OUT}"
        )
    columns = [c for c in COLUMNS if c in card.columns]
    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns)
    body = "\n".join(
        f'<tr class="{row["verdict"].replace(" ", "-")}">'
        + "".join(_td(c, row[c]) for c in columns)
        + "</tr>"
        for _, row in card.iterrows()
    )
    return (
        f'<!DOCTYPE html>\n<html><head><meta charset="utf-8"><title>{html.escape(title)}</title>\n'
        "<style>body{font-family:sans-serif;font-size:13px} table{border-collapse:collapse}"
        " td,th{border:1px solid #ccc;padding:2px 6px;vertical-align:top}"
        " .within-band{background:#e6f4e6} .out-of-band{background:#fbe3e3}"
        " .not-reproduced-yet{color:#777} .missing-from-table{background:#fff1c2}"
        " td.bias-out-of-band{background:#fbe3e3} td.bias-within-band{background:#e6f4e6}"
        "</style></head>\n"
        f"<body><h1>{html.escape(title)}</h1><p>{html.escape(tally)}</p>\n"
        f"<table><thead><tr>{head}</tr></thead><tbody>\n{body}\n</tbody></table></body></html>\n"
    )


def _td(column: str, value: Any) -> str:
    """A cell; the bias verdict's coloured by itself (the row is coloured by the chain's)."""
    text = html.escape(_cell(value))
    if column == "bias verdict" and text in (WITHIN, OUT):
        return f'<td class="bias-{text.replace(" ", "-")}">{text}</td>'
    return f"<td>{text}</td>"


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.6g}"
    return "" if value is None else str(value)


# --- the numbers the documentation quotes ---------------------------------------------------------

#: a block of a Markdown page written by scripts/update_docs.py (never by hand) sits between these
BEGIN, END = (
    "<!-- scorecard:{name} begin (scripts/update_docs.py writes this block) -->",
    "<!-- scorecard:{name} end -->",
)


def counts_markdown(counts_: pd.DataFrame, campaign: str) -> str:
    """The README's numbers: emergent published numbers within band per dataset and chapter, then
    the other kinds that the summary has (results/scorecard_counts.csv, the pipeline's), and the
    model's bias of the recovery numbers centred on the model on truth (:data:`BIAS`)."""
    present = set(counts_["kind"])
    kinds = [EMERGENT] + [k for k in (*KINDS[1:], BIAS) if k in present]
    lines = [
        f"Published numbers within their band on the `{campaign}` campaign "
        "(from `results/scorecard_counts.csv`):",
        "",
        "| "
        + " | ".join(["dataset", "chapter", "emergent: within band / reproduced", *kinds[1:]])
        + " |",
        "|---" * (len(kinds) + 2) + "|",
    ]
    for (dataset, chapter), part in counts_.groupby(["dataset", "chapter"], sort=False):
        cells = {row["kind"]: f"{row[WITHIN]} / {row['reproduced']}" for _, row in part.iterrows()}
        name = "**total**" if chapter == "total" else _chapter(chapter)
        lines.append(
            f"| {dataset} | {name} | " + " | ".join(cells.get(k, "–") for k in kinds) + " |"
        )
    return "\n".join(lines)


def deviations_markdown(cards: Mapping[str, pd.DataFrame]) -> str:
    """docs/deviations.md's list: every emergent number out of band, per dataset and chapter, with
    published and reproduced values and the registry's note."""
    lines = []
    for dataset, card in _filled(cards).items():
        out = card[(card["kind"] == EMERGENT) & (card["verdict"] == OUT)]
        lines += [f"**{dataset}**: {len(out)} emergent numbers out of band.", ""]
        for chapter, part in out.groupby("chapter", sort=False):
            lines.append(f"- {_chapter(chapter)}:")
            for _, row in part.iterrows():
                unit = f" {row['unit']}" if row["unit"] else ""
                lines.append(
                    f"  - {row['source']}, {row['quantity']}: "
                    f"{row['published']:.4g} → {row['reproduced']:.4g}{unit}"
                )
        lines.append("")
    return "\n".join(lines).rstrip()


def replace_block(text: str, name: str, body: str) -> str:
    """``text`` with its generated block ``name`` replaced by ``body``."""
    begin, end = BEGIN.format(name=name), END.format(name=name)
    head, sep, rest = text.partition(begin)
    _, sep2, tail = rest.partition(end)
    if not (sep and sep2):
        raise ValueError(f"no block {name!r} ({begin} … {end})")
    return f"{head}{begin}\n{body}\n{end}{tail}"
