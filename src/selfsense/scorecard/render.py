"""The scorecard's renderings: the report's landing page, the out-of-band and pending lists
(reStructuredText), the per-dataset HTML page, and the blocks the documentation quotes.
"""

from __future__ import annotations

import html
import math
import re
import unicodedata
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

from selfsense.scorecard.registry import (
    BIAS,
    CAUSE_MARK,
    CHECK,
    EMERGENT,
    INFORMATION,
    KINDS,
    MISSING,
    NOT_YET,
    OUT,
    PUBLISHED,
    VERDICTS,
    WITHIN,
)
from selfsense.scorecard.scoring import bias_verdicts, counts

#: where a row's note has a measured cause (Cause.note), which comes last: the pages count by it,
#: and the HTML page shows it apart
CAUSE = rf"(?:^|; )(?={CAUSE_MARK} (?:cause )?\()"

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
    """One line per dataset: emergent numbers within band, then the other kinds, then the model's
    bias of the recovery numbers centred on the model on truth."""
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
        parts += [_kind_tally(by_kind.loc[k], k) for k in (*KINDS[1:], BIAS) if k in by_kind.index]
        lines.append("; ".join(parts) + ".")
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


def coverage(this_run: Sequence[str], earlier: Mapping[str, str]) -> str:
    """reStructuredText of one paragraph: the datasets a project-wide summary covers, this run's
    and the earlier ones' (each with its scorecard's date). A name is a folder's (letters, digits,
    _ and -): a literal."""
    text = "Datasets: " + ", ".join(f"``{d}``" for d in this_run) + " (this run)"
    for dataset, when in earlier.items():
        text += f"; ``{dataset}`` (scorecard of an earlier run, {when})"
    return text + "."


def summary_pages(
    cards: Mapping[str, pd.DataFrame], this_run: Sequence[str], earlier: Mapping[str, str]
) -> tuple[str, str, str]:
    """The project-wide summary's reStructuredText: the landing (:func:`landing_rst`, opened by
    :func:`coverage` when it holds an earlier run's scorecard: the landing's height is counted,
    the first screen must hold it), the out-of-band page and the not-yet page (each with
    :func:`coverage` under its title)."""
    paragraph = coverage(this_run, earlier)

    def covered(page: str) -> str:
        title, _, body = page.partition("\n\n")
        return f"{title}\n\n{paragraph}\n\n{body}"

    landing = landing_rst(cards)
    return (
        f"{paragraph}\n\n{landing}" if earlier else landing,
        covered(out_of_band_rst(cards)),
        covered(pending_rst(cards)),
    )


#: what the landing page says of the kinds that are not reproductions, and of the model's bias
LANDING_NOTE = """Only emergent numbers are reproductions; what the other kinds and a recovery \
number's model's bias are: docs/scorecard.md, "Kinds of numbers" and "The model's bias".
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
    text = ("unit", "note", "read from", "bias band", "bias verdict")
    return {
        d: c.astype({k: object for k in text if k in c.columns}).fillna(
            {k: "" for k in text if k in c.columns}
        )
        for d, c in cards.items()
    }


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
            f"     - {chapter_label(row['chapter'])}",
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
    measured = int(out["note"].str.contains(CAUSE).sum())
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
    return f"{_rst(row['quantity'])}: {_bias_text(row, _rst)}"


def _bias_text(row: pd.Series, text) -> str:
    """A row's model on truth against the built value, and the bias band; ``text`` makes the
    card's text safe for the page (:func:`_rst`; the HTML page escapes the whole)."""
    unit = f" {text(row['unit'])}" if row["unit"] else ""
    change = "" if pd.isna(row["bias [%]"]) else f" ({row['bias [%]']:+.1f} %)"
    built = row["model on truth"] - row["bias"]
    return (
        f"model on truth {row['model on truth']:.6g}{unit}, built "
        f"{built:.6g}{unit}{change}, bias band {row['bias band low']:.6g} … "
        f"{row['bias band high']:.6g}{unit} ({text(row['bias band'])})"
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
            f"  - {chapter_label(chapter)}: "
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


def chapter_label(chapter: Any) -> str:
    """A chapter as the pages name it ("Chapter 3", a paper's name), escaped for them."""
    return _rst(_chapter_title(chapter))


def _chapter_title(chapter: Any) -> str:
    """A chapter's number as "Chapter 3", the name of any other (say, a paper's)."""
    return f"Chapter {chapter}" if str(chapter).isdigit() else _cell(chapter)


def _describe(row: pd.Series) -> str:
    unit = f" {_rst(row['unit'])}" if row["unit"] else ""
    band_text = _band_text(row["band low"], row["band high"])
    change = "" if pd.isna(row["deviation [%]"]) else f" ({row['deviation [%]']:+.1f} %)"
    kind = "" if row.get("kind", EMERGENT) == EMERGENT else f" ({_rst(row['kind'])})"
    return (
        f"{_rst(row['quantity'])}{kind}: published {row['published']:.6g}{unit}, "
        f"reproduced {row['reproduced']:.6g}{unit}{change}, band {band_text}{unit}"
    )


def _band_text(lo: Any, hi: Any) -> str:
    """A band's limits: "≤ high", "≥ low" (a bound) or "low … high"."""
    return (
        f"≤ {_cell(hi)}"
        if pd.isna(lo)
        else f"≥ {_cell(lo)}"
        if pd.isna(hi)
        else f"{_cell(lo)} … {_cell(hi)}"
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


# --- the dataset's page -------------------------------------------------------------------------

#: the order of a group's rows by kind: the reproductions first, then what the twin must give back,
#: the source's own equations, the calibration's signatures and what holds by construction
ROW_ORDER = (EMERGENT, "recovery", "closed form", "calibration", CHECK)
#: the lines of the page's headline: the kinds, the model's bias after the recovery chain's
HEADLINE_KINDS = (EMERGENT, "closed form", "recovery", BIAS, "calibration", CHECK)
#: how the headline names a kind where the kind alone would say less
_KIND_LABELS = {"recovery": "recovery (chain)"}
#: each verdict's CSS class (its colour) and label on the page; a verdict not here is shown grey
VERDICT_STYLE = {
    WITHIN: ("within", "within band"),
    OUT: ("out", "out of band"),
    NOT_YET: ("pending", "not yet"),
    MISSING: ("missing", "missing"),
    INFORMATION: ("info", "no verdict"),
}
#: the labels of the bias verdict beside a recovery row's own
_BIAS_LABELS = {WITHIN: "bias within", OUT: "bias out"}
#: the columns of a number's line (the header row of the page)
LINE_COLUMNS = (
    "quantity",
    "unit",
    "kind",
    "published",
    "reproduced",
    "deviation",
    "band",
    "verdict",
)

PAGE_CSS = """
body{font:13px/1.35 system-ui,-apple-system,"Segoe UI",sans-serif;margin:10px 20px;color:#1f2328}
h1{font-size:20px;margin:0 0 6px}
h2{font-size:16px;margin:16px 0 2px;padding-top:4px;border-top:2px solid #d0d7de}
h3{font-size:13px;margin:8px 0 2px}
.head+h2{border-top:0;margin-top:6px}
h2 small,h3 small{font-weight:normal;color:#57606a;margin-left:6px}
.top{display:flex;gap:28px;align-items:flex-start;flex-wrap:wrap}
.kinds{border-collapse:collapse}
.kinds th,.kinds td{padding:1px 8px;text-align:right;font-variant-numeric:tabular-nums}
.kinds th:first-child{text-align:left}
.kinds thead th{font-weight:normal;color:#57606a;font-size:12px;border-bottom:1px solid #d0d7de}
.aside{color:#57606a;font-size:12px;max-width:46em;margin:4px 0 0}
nav ul{margin:2px 0 0;padding:0;list-style:none}
nav li{margin:2px 0}
.zero{color:#8c959f}
.head,.row>summary{display:grid;column-gap:10px;padding:1px 4px;
 grid-template-columns:minmax(14em,1fr) 4em 6.5em 6.5em 6.5em 5.5em 13em 13em}
.head{position:sticky;top:0;z-index:1;background:#fff;margin-top:10px;font-size:12px;
 color:#57606a;border-bottom:1px solid #d0d7de}
summary{cursor:pointer;list-style:none}
summary::-webkit-details-marker{display:none}
.q::before{content:"\\25B8  ";color:#8c959f}
details[open]>summary .q::before{content:"\\25BE  "}
.row:nth-of-type(even)>summary{background:#f6f8fa}
.row>summary:hover{background:#eaeef2}
.x{text-align:right;font-variant-numeric:tabular-nums}
.k{color:#57606a}
.emergent .k{color:#1f2328;font-weight:600}
.v{display:inline-block;padding:0 5px;border-radius:3px;font-size:12px;white-space:nowrap}
.within{background:#dafbe1;color:#116329}
.out{background:#ffebe9;color:#a40e26}
.info{background:#eaeef2;color:#57606a}
.pending{background:#fff8c5;color:#7d4e00}
.missing{background:#fff8c5;color:#7d4e00;outline:1px dashed #bf8700}
dl{display:grid;grid-template-columns:7em 1fr;gap:2px 10px;margin:2px 0 6px 18px;padding:4px 8px;
 background:#f6f8fa;border-left:3px solid #d0d7de}
dt{color:#57606a}
dd{margin:0}
"""


def scorecard_html(card: pd.DataFrame, title: str) -> str:
    """A self-contained page of one dataset's scorecard (the report shows HTML inline, a CSV only
    as a download), readable at 1280×800 without scrolling sideways: the title; a headline, one
    line per kind and one for the model's bias (:func:`summary`'s totals); a table of contents of
    the chapters with their counts; then per chapter and per source (a table or figure of it) a
    line per number (:func:`scorecard_groups`, emergent ones first): quantity, unit, kind,
    published, reproduced, deviation, band and the verdict in colour, a recovery row's bias verdict
    beside it. A click on a line unfolds (``<details>``) the band's rule and justification, the
    model's bias, the note, the measured cause and where the value was read from.

    Every text of the card is data, never markup (``html.escape``); the page's only links are its
    own anchors, and it needs no script, style sheet or font from elsewhere."""
    card = _filled({"": card})[""]
    table = summary({"": card})
    groups = scorecard_groups(card)
    chapters = "\n".join(
        _chapter_html(i, chapter, parts, table) for i, (chapter, parts) in enumerate(groups, 1)
    )
    head = "".join(f"<span>{c}</span>" for c in LINE_COLUMNS)
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">\n'
        f"<title>{html.escape(title)}</title>\n<style>{PAGE_CSS}</style></head>\n<body>\n"
        f"<h1>{html.escape(title)}</h1>\n"
        f'<div class="top">\n{_headline_html(table)}\n{_contents_html(groups, table)}\n</div>\n'
        + (
            f'<div class="head">{head}</div>\n{chapters}\n'
            if groups
            else "<p>No published number applies to this dataset.</p>\n"
        )
        + "</body></html>\n"
    )


def scorecard_groups(card: pd.DataFrame) -> list[tuple[Any, list[tuple[Any, pd.DataFrame]]]]:
    """The page's groups: per chapter, per source (a table or figure of it), each in the card's
    (the registry's) order of first appearance; a source's rows ordered by kind,
    :data:`ROW_ORDER` (the card's order within a kind, a kind not there last). Every row of the
    card is in exactly one group."""
    rank = {k: i for i, k in enumerate(ROW_ORDER)}
    groups = []
    for chapter, part in card.groupby("chapter", sort=False, dropna=False):
        sources = []
        for source, rows in part.groupby("source", sort=False, dropna=False):
            kinds = rows["kind"].tolist()
            order = sorted(range(len(rows)), key=lambda i: rank.get(kinds[i], len(rank)))
            sources.append((source, rows.iloc[order]))
        groups.append((chapter, sources))
    return groups


def _headline_html(table: pd.DataFrame) -> str:
    """The counts per kind (:data:`HEADLINE_KINDS`, then any other the summary has)."""
    total = table[table["chapter"] == "total"].set_index("kind")
    kinds = [k for k in HEADLINE_KINDS if k in total.index]
    kinds += [k for k in total.index if k not in HEADLINE_KINDS]
    columns = ("", "numbers", "within band / reproduced", "out of band", "not yet", "missing")
    rows = [
        "<tr>"
        + f"<th>{html.escape(_KIND_LABELS.get(k, k))}</th><td>{total.loc[k, 'numbers']}</td>"
        + f"<td>{_count(total.loc[k, WITHIN], WITHIN)} / {total.loc[k, 'reproduced']}</td>"
        + "".join(f"<td>{_count(total.loc[k, v], v)}</td>" for v in (OUT, NOT_YET, MISSING))
        + f"<td>{_count(total.loc[k, INFORMATION], INFORMATION)}</td></tr>"
        for k in kinds
    ]
    head = "".join(f"<th>{c}</th>" for c in (*columns, "no verdict"))
    return (
        f'<div><table class="kinds"><thead><tr>{head}</tr></thead><tbody>\n'
        + "\n".join(rows)
        + "\n</tbody></table>\n"
        '<p class="aside">Only the emergent numbers are reproductions (docs/scorecard.md, '
        "\"Kinds of numbers\"). A recovery row's verdict is the chain's, what the captures give "
        "back against the model on the twin's truth; the model's bias is that model against the "
        "value the twin is built with. A click on a line shows its band's rule and justification, "
        "its note and cause, and where the value was read from.</p></div>"
    )


def _contents_html(groups: list, table: pd.DataFrame) -> str:
    items = [
        f'<li><a href="#c{i}">{html.escape(_chapter_title(chapter))}</a> '
        + _tally_html(_chapter_counts(table, chapter))
        + "</li>"
        for i, (chapter, _) in enumerate(groups, 1)
    ]
    return f"<nav><b>Chapters</b><ul>\n{chr(10).join(items)}\n</ul></nav>"


def _chapter_counts(table: pd.DataFrame, chapter: Any) -> dict[str, int]:
    """A chapter's counts by verdict over every kind (the summary's lines of that chapter)."""
    part = table[(table["chapter"] == str(chapter)) & table["kind"].isin(KINDS)]
    return {"numbers": int(part["numbers"].sum()), **{v: int(part[v].sum()) for v in VERDICTS}}


def _chapter_html(i: int, chapter: Any, parts: list, table: pd.DataFrame) -> str:
    emergent = table[(table["chapter"] == str(chapter)) & (table["kind"] == EMERGENT)]
    tally = (
        f"emergent {emergent[WITHIN].iloc[0]} within band of {emergent['reproduced'].iloc[0]}"
        if len(emergent)
        else "no emergent numbers"
    )
    return (
        f'<h2 id="c{i}">{html.escape(_chapter_title(chapter))} <small>{tally}</small></h2>\n'
        + "\n".join(
            f'<section><h3 id="c{i}-{j}">{html.escape(_cell(source))} '
            f"<small>{_tally_html({'numbers': len(rows), **counts(rows)})}</small></h3>\n"
            + "\n".join(_line_html(row) for _, row in rows.iterrows())
            + "\n</section>"
            for j, (source, rows) in enumerate(parts, 1)
        )
    )


def _tally_html(n: Mapping[str, int]) -> str:
    """How many numbers, and a coloured count per verdict present."""
    return f"{n['numbers']} number{'' if n['numbers'] == 1 else 's'} " + " ".join(
        _badge(v, f"{n[v]} {VERDICT_STYLE[v][1]}") for v in VERDICTS if n[v]
    )


def _count(n: int, verdict: str) -> str:
    return _badge(verdict, str(n)) if n else '<span class="zero">0</span>'


def _badge(verdict: str, label: str | None = None, prefix: str = "") -> str:
    """A verdict in its colour (:data:`VERDICT_STYLE`), shown as ``label`` (its own by default)."""
    css, own = VERDICT_STYLE.get(verdict, ("info", verdict))
    label = own if label is None else label
    return (
        f'<span class="v {css}" title="{html.escape(prefix + verdict)}">{html.escape(label)}</span>'
    )


def _line_html(row: pd.Series) -> str:
    """A number's line, its folded detail below it."""
    kind = _cell(row["kind"])
    verdict = _badge(_cell(row["verdict"]))
    bias = _cell(row.get("bias verdict", ""))
    if bias:
        label = _BIAS_LABELS.get(bias, f"bias {VERDICT_STYLE.get(bias, ('', bias))[1]}")
        verdict += " " + _badge(bias, label, "the model's bias: ")
    cells = [
        ("q", row["quantity"]),
        ("u", row["unit"]),
        ("k", kind),
        ("x", row["published"]),
        ("x", _cell(row["reproduced"]) or "–"),
        ("x", _deviation(row)),
        ("b", _band_cell(row)),
    ]
    line = "".join(f'<span class="{c}">{html.escape(_cell(v))}</span>' for c, v in cells)
    return (
        f'<details class="row{" emergent" if kind == EMERGENT else ""}"><summary>{line}'
        f"<span>{verdict}</span></summary>{_folded_html(row)}</details>"
    )


def _deviation(row: pd.Series) -> str:
    """In % of the published value where it has one (a published 0 has none), else absolute."""
    if pd.notna(row["deviation [%]"]):
        return f"{row['deviation [%]']:+.1f} %"
    return "" if pd.isna(row["deviation"]) else f"{row['deviation']:+.4g}"


def _band_cell(row: pd.Series) -> str:
    lo, hi = row["band low"], row["band high"]
    return "–" if pd.isna(lo) and pd.isna(hi) else _band_text(lo, hi)


def _folded_html(row: pd.Series) -> str:
    """What a click on a line shows: the band's rule and justification, the deviation, the model's
    bias, the note, the measured cause, where the value was read from and a section other than
    the published numbers'."""
    unit = f" {row['unit']}" if row["unit"] else ""
    note, cause = _note_and_cause(_cell(row["note"]))
    deviation = "" if pd.isna(row["deviation"]) else f"{row['deviation']:+.6g}{unit}"
    if deviation and pd.notna(row["deviation [%]"]):
        deviation += f" ({row['deviation [%]']:+.2f} %)"
    band = f"{_cell(row['band'])} ({_cell(row['tolerance'])})"
    if not (pd.isna(row["band low"]) and pd.isna(row["band high"])):
        band += f": {_band_text(row['band low'], row['band high'])}{unit}"
    bias = ""
    if pd.notna(row.get("model on truth", math.nan)):
        bias = f"{_bias_text(row, str)}: {_cell(row['bias verdict']) or 'no verdict'}"
    section = _cell(row["section"])
    items = [
        ("band", f"{band}. {_cell(row['justification'])}"),
        ("deviation", deviation),
        ("model's bias", bias),
        ("note", note),
        ("cause", cause),
        ("read from", _cell(row["read from"])),
        ("section", "" if section == PUBLISHED else section),
    ]
    return (
        "<dl>" + "".join(f"<dt>{k}</dt><dd>{html.escape(v)}</dd>" for k, v in items if v) + "</dl>"
    )


def _cell(value: Any) -> str:
    """A cell as text: a number to 6 significant digits, an empty one (NaN, None) as ""."""
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.6g}"
    return "" if value is None else str(value)


def _note_and_cause(note: str) -> tuple[str, str]:
    """A row's note split at its measured cause (:data:`CAUSE`), which comes last."""
    found = re.search(CAUSE, note)
    return (note, "") if found is None else (note[: found.start()], note[found.end() :])


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
        name = "**total**" if chapter == "total" else chapter_label(chapter)
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
            lines.append(f"- {chapter_label(chapter)}:")
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
