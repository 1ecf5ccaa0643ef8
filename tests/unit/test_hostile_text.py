"""Text from a manifest, a capture or a file name is data, never markup: inert in the report's
reStructuredText and HTML (selfsense.scorecard.render) and in the result tables a spreadsheet opens
(selfsense.io.provenance.spreadsheet_safe). The same payloads through the built report:
tests/workflow/test_hostile_report.py."""

import html
import math
import re
import unicodedata
from functools import cache

import numpy as np
import pandas as pd
import pytest
from docutils.utils import SystemMessage
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from selfsense.io.provenance import spreadsheet_cell, spreadsheet_safe, write_table
from selfsense.scorecard.reference_values import CHARACTERISE, reference_rows
from selfsense.scorecard.render import (
    _rst,
    landing_rst,
    out_of_band_rst,
    pending_rst,
    rst_html,
    safe_url,
    scorecard_html,
)

#: the issue's payloads: a live script, a file pulled into the page, a live link
SCRIPT = "x\n\n.. raw:: html\n\n   <script>alert(1)</script>"
PASSWD = ".. include:: /etc/passwd\n   :literal:"
LINK = "javascript:alert(1)"
PAYLOADS = (SCRIPT, PASSWD, LINK)
#: the first line of /etc/passwd on any Linux
ROOT_LINE = "root:x:0:0"

#: pieces hostile text is made of, for the property tests to combine with arbitrary text
FRAGMENTS = (
    SCRIPT,
    PASSWD,
    LINK,
    ".. raw:: html",
    ".. include:: ",
    ".. image:: javascript:alert(2)",
    "   :target: javascript:alert(3)",
    "`x <javascript:alert(4)>`_",
    ".. _t: javascript:alert(5)",
    "t_",
    "<script>",
    "</script>",
    "javascript:",
    "JaVa\tScRiPt:",
    "http://example.com",
    "a@b.c",
    "\n",
    "\n\n",
    "\r\n",
    "   ",
    "::",
    ":literal:",
    ":raw-html:`<b>`",
    "- ",
    "1. ",
    "#. ",
    "(a) ",
    "• ",
    "|s|",
    "[1]_",
    "**",
    "*",
    "`",
    "``",
    "_",
    "__",
    "\\",
    "===",
    "---",
    "+--+",
    ">>> ",
    "\u202e",
    "\u200b",
    "\x00",
    "\x0c",
    "\u2028",
)
hostile = st.lists(st.sampled_from(FRAGMENTS) | st.text(max_size=12), max_size=8).map("".join)


def folded(text):
    """The text as a page shows it: whitespace, control and format characters (and lone
    surrogates) as single spaces."""
    return " ".join(
        "".join(" " if unicodedata.category(c) in ("Cc", "Cf", "Cs") else c for c in text).split()
    )


def page(text):
    """A page that puts ``text`` wherever render.py puts a row's text: a section title, strong
    emphasis, a paragraph after a label, a nested list item, a list-table cell."""
    t = _rst(text)
    return rst_html(
        "\n".join(
            [
                "Page",
                "====",
                "",
                t,
                "-" * (2 * len(t)),
                "",
                f"**{t}**: emergent 1 within band of 2.",
                "",
                f"- Out of band. Why: {t}",
                "",
                f"  - {t}",
                "",
                "    - " + t,
                "",
                ".. list-table:: Table",
                "   :header-rows: 1",
                "",
                "   * - dataset",
                "     - chapter",
                f"   * - {t}",
                "     - 3",
                "",
            ]
        )
    )


def tags(page_html):
    """The page's elements, in order."""
    return re.findall(r"</?\w+", page_html[page_html.index("<body") :])


@cache
def plain_tags():
    """The elements of the page made with plain text: hostile text must make no other."""
    return tags(page("x"))


def assert_inert(page_html, marker=ROOT_LINE):
    assert "<script" not in page_html.lower()
    assert not re.search(r"""(?:href|src)\s*=\s*["']?\s*javascript:""", page_html, re.I)
    assert marker not in page_html


def visible(page_html):
    body = page_html[page_html.index("<body") :]
    return html.unescape(re.sub(r"<[^>]+>", " ", body))


# --- reStructuredText and HTML --------------------------------------------------------------------


@pytest.mark.parametrize("payload", PAYLOADS)
def test_the_issues_payloads_are_shown_as_text_not_run(payload):
    out = page(payload)
    assert_inert(out)
    assert folded(payload) in " ".join(visible(out).split())
    assert tags(out) == plain_tags()  # no element the plain text does not make


def test_an_include_payload_never_puts_the_file_into_the_page(tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("the-secret-line-4711\n")
    for payload in (
        f".. include:: {secret}\n   :literal:",
        f"x\n\n.. include:: {secret}\n",
        f".. raw:: html\n   :file: {secret}\n",
        f".. csv-table:: t\n   :file: {secret}\n",
    ):
        assert_inert(page(payload), marker="the-secret-line-4711")


@settings(max_examples=150, deadline=None)
@given(hostile)
def test_any_text_is_inert_wherever_a_page_puts_it(text):
    assume(folded(text))
    out = page(text)  # halt_level 2: a docutils warning raises, so nothing in it was markup
    assert_inert(out)
    assert tags(out) == plain_tags()
    assert folded(text) in " ".join(visible(out).split())


@given(hostile)
def test_escaped_text_is_one_line(text):
    escaped = _rst(text)
    assert "\n" not in escaped and "\r" not in escaped and escaped == escaped.strip()
    chars = iter(escaped)
    for c in chars:  # every character but a letter, digit or space is escaped
        assert c.isalnum() or c == " " or (c == "\\" and next(chars, None) is not None), escaped


def test_the_renderer_refuses_raw_and_file_insertion_and_unsafe_links(tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("the-secret-line-4711\n")
    for directive in (
        ".. raw:: html\n\n   <script>alert(1)</script>\n",
        f".. include:: {secret}\n",
        f".. csv-table:: t\n   :file: {secret}\n",
    ):
        with pytest.raises(SystemMessage, match="disabled|deactivated"):
            rst_html(directive)
    out = rst_html(
        "`a <javascript:alert(1)>`_, `b <JaVa\tScript:x>`_, `c <https://example.com>`_, "
        "`d <page.html#x>`_ and data:text/html,x\n\n.. image:: javascript:alert(2)\n   :alt: pic\n"
    )
    assert_inert(out)
    assert 'href="https://example.com"' in out and 'href="page.html#x"' in out
    assert "data:text/html" in out and 'href="data:' not in out and "pic" in out


@pytest.mark.parametrize(
    ("url", "safe"),
    [
        ("javascript:alert(1)", False),
        ("JAVASCRIPT:alert(1)", False),
        (" java\tscript:alert(1)", False),
        ("java\x00script:alert(1)", False),
        ("vbscript:x", False),
        ("data:text/html,<script>alert(1)</script>", False),
        ("file:" + "///etc/passwd", False),
        ("http://example.com", True),
        ("https://example.com/a?b#c", True),
        ("mailto:a@b.c", True),
        ("scorecard.html#x", True),
        ("#section", True),
        ("a/b:c", True),
        ("", True),
    ],
)
def test_only_safe_url_schemes(url, safe):
    assert safe_url(url) is safe


def hostile_card():
    """A dataset's reference-value rows whose sources, capture and justifications carry the issue's
    payloads (all out of band or missing from the table, so every list names them)."""
    manifest = {
        "name": "hostile",
        "model": "other",
        "reference": {
            "stroke_um": {"value": 1000, "tolerance_percent": 1, "source": SCRIPT},
            "gain_um_per_V": {
                "value": 1000,
                "tolerance_percent": 1,
                "source": PASSWD,
                "experiment": LINK,
            },
            "loop_width_percent": {"value": 1, "tolerance_percent": 1, "source": LINK},
        },
    }
    table = pd.DataFrame(
        {
            "experiment": ["run"],
            "stroke [µm]": [30.0],
            "gain (least squares) [µm/V]": [0.2],
            "x–U loop width [% of stroke]": [12.0],
        }
    )
    return reference_rows(manifest, {CHARACTERISE: table})


def test_the_scorecards_pages_show_a_hostile_manifest_as_text():
    card = hostile_card()
    assert set(card["source"]) == set(PAYLOADS)
    cards = {"hostile": card}
    for rst in (landing_rst(cards), out_of_band_rst(cards), pending_rst(cards)):
        assert_inert(rst_html(rst))
    text = " ".join(visible(rst_html(out_of_band_rst(cards))).split())
    assert all(folded(p) in text for p in PAYLOADS)
    assert_inert(scorecard_html(card, "Scorecard: hostile"))


def test_the_scorecard_page_shows_hostile_text_as_text_and_makes_no_other_element():
    """The dataset's HTML page escapes every text of the card: the payloads in the sources, the
    justifications and the locators make no element a plain card's page lacks, the page's only
    links are its own anchors, and the payloads read as given."""
    card = hostile_card()
    page = scorecard_html(card, SCRIPT)
    plain = card.assign(
        **{c: "x" for c in ("source", "justification", "note", "read from", "quantity")}
    )
    assert set(tags(page)) <= set(tags(scorecard_html(plain, "x")))
    assert_inert(page)
    assert set(re.findall(r"""(?:href|src)\s*=\s*["']?([^"'\s>]*)""", page)) <= {"#c1"}
    text = visible(page)
    assert all(p in text for p in PAYLOADS)


# --- spreadsheet formulas in CSV ------------------------------------------------------------------


@pytest.mark.parametrize(
    "text",
    [
        "=1+1",
        '=HYPERLINK("http://evil","x")',
        '+HYPERLINK("http://evil")',
        "-2+3+cmd|' /C calc'!A0",
        "+1+cmd|' /C calc'!A0",
        "-1 +cmd|' /C calc'!A0",
        "-x",
        "+ 1",
        "@SUM(A1:A2)",
        "\t=1+1",
        "\r=1+1",
        "-1-1",
        "=",
    ],
)
def test_a_formula_gets_a_quote_in_front(text):
    assert spreadsheet_cell(text) == "'" + text


@pytest.mark.parametrize(
    "value",
    [
        "-",
        "+",
        "-1.5",
        "+3",
        "-1e-05",
        "-inf",
        "+2 %, same factor below",  # the registry's tolerances, in every shipped scorecard.csv
        "+0.6 µm, same factor below",
        "+20 % ΔCx",  # Table 4.2's cases
        "−3",  # U+2212, not a sign a spreadsheet reads
        "plain text = fine",
        " =1+1",
        "",
        "'=already quoted",
        -1.5,
        3,
        None,
        float("nan"),
        True,
    ],
)
def test_numbers_and_ordinary_text_are_left_as_they_are(value):
    out = spreadsheet_cell(value)
    assert out is value or (isinstance(value, float) and math.isnan(value) and math.isnan(out))


@given(st.floats() | st.integers())
def test_a_number_as_text_is_never_touched(number):
    for text in (str(number), repr(number), f"{number:.10g}" if isinstance(number, float) else ""):
        assert spreadsheet_cell(text) == text


@given(st.text())
def test_a_text_cell_never_starts_a_formula(text):
    out = spreadsheet_cell(text)
    assert out in (text, "'" + text)
    assert not out.startswith(("=", "@", "\t", "\r"))
    if out[:1] in ("+", "-"):  # a sign, a number and plain words only
        assert not re.search(r"[()|!=*/^&@;\"]|[+-].*[+-]", out[1:].split(" ", 1)[-1] + out[:1])


def test_a_table_keeps_its_numbers_and_only_text_cells_change(tmp_path):
    table = pd.DataFrame(
        {
            "value": [-1.5, 2.0, -3.25],
            "count": [-1, 0, 1],
            "mixed": ["=1+1", -2.5, np.nan],
            "note": ["-", "+2 %, same factor below", "@SUM(A1)"],
            "flag": [True, False, True],
        }
    )
    before = table.copy()
    safe = spreadsheet_safe(table)
    pd.testing.assert_frame_equal(table, before)  # the caller's table is not changed
    assert list(safe["mixed"])[:2] == ["'=1+1", -2.5] and math.isnan(safe["mixed"][2])
    assert list(safe["note"]) == ["-", "+2 %, same factor below", "'@SUM(A1)"]
    for column in ("value", "count", "flag"):
        pd.testing.assert_series_equal(safe[column], table[column])
    plain = table.drop(columns=["mixed", "note"])
    assert spreadsheet_safe(plain) is plain  # nothing to change: no copy
    write_table(table, tmp_path / "t.csv")
    assert (tmp_path / "t.csv").read_text() == (
        "value,count,mixed,note,flag\n"
        "-1.5,-1,'=1+1,-,True\n"
        '2,0,-2.5,"+2 %, same factor below",False\n'
        "-3.25,1,,'@SUM(A1),True\n"
    )


def test_a_hostile_scorecard_is_written_inert(tmp_path):
    card = hostile_card()
    card.loc[0, "note"] = '=HYPERLINK("http://evil","click")'
    write_table(card, tmp_path / "scorecard.csv")
    back = pd.read_csv(tmp_path / "scorecard.csv")
    assert back.loc[0, "note"] == '\'=HYPERLINK("http://evil","click")'
    assert list(back["source"]) == list(card["source"])  # no payload here starts a formula
    pd.testing.assert_series_equal(back["reproduced"], card["reproduced"].astype(float))
