"""The dataset's scorecard page (results/<dataset>/scorecard.html): grouped by chapter and source,
emergent rows first, a compact line per number with its verdict in colour, the band's justification,
note, cause and locator folded into the line, a headline per kind, a table of contents, every text
of the card escaped."""

import html
import re

import pandas as pd
import pytest

from selfsense.scorecard.registry import (
    BIAS,
    INFORMATION,
    KINDS,
    NOT_YET,
    OUT,
    WITHIN,
    Band,
    Entry,
    Locator,
    Tolerance,
)
from selfsense.scorecard.render import (
    HEADLINE_KINDS,
    ROW_ORDER,
    VERDICT_STYLE,
    scorecard_groups,
    scorecard_html,
    summary,
)
from selfsense.scorecard.scoring import scorecard

from ..helpers import ROOT

STACK = {"name": "stack_ds", "model": "stack", "twin": {}}
TABLE = pd.DataFrame({"ns": [4, 12], "fs [kHz]": [400.0, 48.0]})
AT_48 = Locator("t.csv", "fs [kHz]", (("ns", 12),))
SNAPSHOTS = sorted((ROOT / "docs" / "snapshot").glob("scorecard_*_*.csv"))


def entry(quantity, kind="emergent", chapter="3", source="Table 3.1", published=48.0, **kw):
    fields = dict(
        section="published",
        kind=kind,
        chapter=chapter,
        source=source,
        model="stack",
        quantity=quantity,
        unit="kHz",
        published=published,
        band=Band(f"rule of {quantity}", f"justified so: {quantity}", Tolerance(rel=10)),
        locate=AT_48,
    )
    return Entry(**(fields | kw))


def card():
    """Rows of two chapters and three sources, in an order that puts emergent ones late, with
    every verdict but missing (a0 within, a3 out, a6 not yet, a2 information)."""
    return scorecard(
        [
            entry("a1", "closed form"),
            entry("a2", "check", band=Band("no verdict", "justified so: a2")),
            entry("a3", published=100.0, note="why out"),
            entry("b1", "recovery", chapter="4", source="Table 4.2"),
            entry("a4", "recovery"),
            entry("a5", "calibration"),
            entry("a6", locate=None),
            entry("c1", source="Fig 3.4"),
            entry("b2", chapter="4", source="Table 4.2"),
            entry("a0", "emergent"),
        ],
        {"t.csv": TABLE},
        STACK,
    )


def lines(page):
    """The page's lines in order: (chapter, source, quantity, kind, the verdict badges' classes
    and texts, the folded text), read back from the HTML."""
    found = []
    chapters = re.split(r'<h2 id="c\d+">', page)[1:]
    for chapter in chapters:
        title = html.unescape(chapter[: chapter.index(" <small>")])
        for section in re.findall(r"<section>(.*?)</section>", chapter, re.S):
            source = html.unescape(re.match(r'<h3 id="c\d+-\d+">(.*?) <small>', section).group(1))
            for line in re.findall(r"<details.*?</details>", section, re.S):
                summary_, folded = line.split("</summary>")
                found.append(
                    {
                        "chapter": title,
                        "source": source,
                        "quantity": html.unescape(
                            re.search(r'<span class="q">(.*?)</span>', summary_).group(1)
                        ),
                        "kind": html.unescape(
                            re.search(r'<span class="k">(.*?)</span>', summary_).group(1)
                        ),
                        "badges": [
                            (css, html.unescape(text))
                            for css, text in re.findall(
                                r'<span class="v (\w+)" title="[^"]*">(.*?)</span>', summary_
                            )
                        ],
                        "summary": html.unescape(re.sub(r"<[^>]+>", " ", summary_)),
                        "folded": dict(
                            (html.unescape(k), html.unescape(v))
                            for k, v in re.findall(r"<dt>(.*?)</dt><dd>(.*?)</dd>", folded, re.S)
                        ),
                    }
                )
    return found


# --- grouping -------------------------------------------------------------------------------------


def test_rows_are_grouped_by_chapter_and_source_emergent_first():
    assert set(ROW_ORDER) == set(KINDS) and ROW_ORDER[0] == "emergent"
    got = [(x["chapter"], x["source"], x["quantity"]) for x in lines(scorecard_html(card(), "t"))]
    assert got == [
        ("Chapter 3", "Table 3.1", q) for q in ("a3", "a6", "a0", "a4", "a1", "a5", "a2")
    ] + [("Chapter 3", "Fig 3.4", "c1"), ("Chapter 4", "Table 4.2", "b2")] + [
        ("Chapter 4", "Table 4.2", "b1")
    ]
    groups = scorecard_groups(card())
    assert [(c, [s for s, _ in parts]) for c, parts in groups] == [
        ("3", ["Table 3.1", "Fig 3.4"]),
        ("4", ["Table 4.2"]),
    ]


@pytest.mark.parametrize("path", SNAPSHOTS, ids=lambda p: p.stem)
def test_every_row_of_a_real_scorecard_is_on_the_page_exactly_once(path):
    """A thesis campaign's scorecard as read back from its CSV (empty text cells are NaN)."""
    card_ = pd.read_csv(path)
    page = scorecard_html(card_, "Scorecard")
    shown = lines(page)
    assert len(shown) == len(card_) == page.count("<details")
    assert sorted((x["source"], x["quantity"]) for x in shown) == sorted(
        zip(card_["source"], card_["quantity"])
    )
    rank = {k: i for i, k in enumerate(ROW_ORDER)}
    for (chapter, source), part in pd.DataFrame(shown).groupby(["chapter", "source"]):
        assert list(part["kind"]) == sorted(part["kind"], key=rank.get), (chapter, source)
    # the sources keep the registry's order within their chapter
    first_seen = list(dict.fromkeys(x["source"] for x in shown))
    assert first_seen == list(dict.fromkeys(card_["source"]))


# --- a line and what it folds ---------------------------------------------------------------------


def test_each_line_has_its_verdict_in_colour():
    by_quantity = {x["quantity"]: x for x in lines(scorecard_html(card(), "t"))}
    colour = {q: x["badges"][0][0] for q, x in by_quantity.items()}
    assert colour["a0"] == "within" and colour["a3"] == "out"
    assert colour["a6"] == "pending" and colour["a2"] == "info"
    assert by_quantity["a6"]["badges"] == [("pending", "not yet")]
    assert {c for c, _ in VERDICT_STYLE.values()} == {"within", "out", "pending", "missing", "info"}
    page = scorecard_html(card(), "t")
    css = page[page.index("<style>") : page.index("</style>")]
    green, red, grey, amber = (
        re.search(rf"\.{c}\{{background:(#\w+)", css).group(1)
        for c in ("within", "out", "info", "pending")
    )
    assert len({green, red, grey, amber}) == 4


def test_a_line_shows_the_numbers_and_folds_the_band_note_and_locator():
    shown = {x["quantity"]: x for x in lines(scorecard_html(card(), "t"))}
    a3 = shown["a3"]
    assert a3["summary"].split() == [
        "a3",
        "kHz",
        "emergent",
        "100",
        "48",
        "-52.0",
        "%",
        "90",
        "…",
        "110",
        "out",
        "of",
        "band",
    ]
    assert a3["folded"]["band"] == "rule of a3 (±10 %): 90 … 110 kHz. justified so: a3"
    assert a3["folded"]["note"] == "why out"
    assert a3["folded"]["read from"] == AT_48.describe()
    assert a3["folded"]["deviation"] == "-52 kHz (-52.00 %)"
    assert "cause" not in a3["folded"] and "section" not in a3["folded"]
    page = scorecard_html(card(), "t")
    # the justification is folded into its line, never a column: once per row, inside <details>
    for q in shown:
        assert page.count(f"justified so: {q}<") == 1
        assert re.search(rf"<details[^>]*>(?:(?!</details>).)*justified so: {q}<", page, re.S)
    assert "<dd>" not in re.sub(r"<details.*?</details>", "", page, flags=re.S)
    assert shown["a6"]["summary"].split()[:5] == ["a6", "kHz", "emergent", "48", "–"]
    assert shown["a2"]["summary"].split()[-3:] == ["–", "no", "verdict"]


def test_a_measured_cause_is_folded_apart_from_the_note():
    card_ = card()
    card_.loc[card_["quantity"] == "a3", "note"] = "why out; Measured (t.csv, ns = 12): nf = 4"
    a3 = next(x for x in lines(scorecard_html(card_, "t")) if x["quantity"] == "a3")
    assert a3["folded"]["note"] == "why out"
    assert a3["folded"]["cause"] == "Measured (t.csv, ns = 12): nf = 4"


# --- headline and contents ------------------------------------------------------------------------


def headline(page):
    table = page[page.index("<tbody>") : page.index("</tbody>")]
    return {
        html.unescape(k): " ".join(html.unescape(re.sub(r"<[^>]+>", " ", row)).split())
        for k, row in re.findall(r"<tr><th>(.*?)</th>(.*?)</tr>", table)
    }


def test_the_headline_has_a_line_per_kind_from_the_summary():
    page = scorecard_html(card(), "t")
    lines_ = headline(page)
    assert list(lines_) == ["emergent", "closed form", "recovery (chain)", "calibration", "check"]
    total = summary({"t": card()}).query("chapter == 'total'").set_index("kind")
    row = total.loc["emergent"]
    # numbers, within / reproduced, out of band, not yet, missing, no verdict
    assert lines_["emergent"] == (
        f"{row['numbers']} {row[WITHIN]} / {row['reproduced']} {row[OUT]} {row[NOT_YET]} 0 0"
    )
    assert lines_["emergent"] == "5 3 / 4 1 1 0 0"
    assert lines_["check"] == "1 0 / 0 0 0 0 1" and total.loc["check", INFORMATION] == 1
    assert HEADLINE_KINDS.index(BIAS) == HEADLINE_KINDS.index("recovery") + 1
    # the headline and the first chapter come before any line
    assert page.index('class="kinds"') < page.index("<nav>") < page.index("<details")


def test_the_contents_link_each_chapter_with_its_counts():
    page = scorecard_html(card(), "t")
    nav = page[page.index("<nav>") : page.index("</nav>")]
    items = re.findall(r'<li><a href="#(c\d+)">(.*?)</a> (.*?)</li>', nav)
    assert [(a, t) for a, t, _ in items] == [("c1", "Chapter 3"), ("c2", "Chapter 4")]
    assert all(f'<h2 id="{a}">' in page for a, _, _ in items)
    chapter_3 = " ".join(re.sub(r"<[^>]+>", " ", items[0][2]).split())
    assert chapter_3 == "8 numbers 5 within band 1 out of band 1 not yet 1 no verdict"
    assert re.findall(r'href="([^"]*)"', page) == ["#c1", "#c2"]  # no link but the anchors


def test_an_empty_scorecard_makes_a_page_that_says_so():
    page = scorecard_html(card().iloc[:0], "t")
    assert "No published number applies" in page and "<details" not in page


# --- escaping -------------------------------------------------------------------------------------


def test_every_text_of_the_card_is_escaped():
    hostile = '<img src=x onerror=alert(1)> & "q"'
    card_ = card()
    for column in ("chapter", "source", "quantity", "unit", "kind", "band", "tolerance"):
        card_[column] = card_[column].astype(object)
    card_.loc[0, ["chapter", "source", "quantity", "unit"]] = [hostile, hostile, hostile, hostile]
    card_.loc[0, ["band", "tolerance", "justification", "note", "read from"]] = [hostile] * 5
    card_.loc[1, "verdict"] = hostile
    page = scorecard_html(card_, hostile)
    assert "<img" not in page and "onerror=alert(1)>" not in page
    assert html.escape(hostile) in page
    assert page.count(html.escape(hostile)) >= 10
    assert re.findall(r'href="([^"]*)"', page) == ["#c1", "#c2", "#c3"]
    shown = lines(page)
    first = next(x for x in shown if x["source"] == hostile)
    assert first["quantity"] == hostile and first["chapter"] == hostile
    assert first["folded"]["note"] == hostile and first["folded"]["read from"] == hostile
    # a verdict the page does not know is shown as text, grey
    odd = next(x for x in shown if x["quantity"] == "a2")
    assert odd["badges"] == [("info", hostile)]
