"""The scorecard's kind `check` and the model's bias: a recovery number centred on the model on the
twin's truth carries a second verdict, that model against the built value, counted apart
(docs/scorecard.md, "Kinds of numbers" and "The model's bias")."""

import html
import re
from dataclasses import replace

import docutils.core
import pandas as pd
import pytest

from selfsense.io.manifest import ManifestError
from selfsense.scorecard.registry import (
    BIAS,
    BIAS_COLUMNS,
    CHECK,
    COLUMNS,
    EMERGENT,
    KINDS,
    OUT,
    RECOVERY,
    WITHIN,
    Band,
    Entry,
    Locator,
    Tolerance,
    parse_registry,
)
from selfsense.scorecard.render import (
    counts_markdown,
    headline,
    landing_rst,
    out_of_band_rst,
    scorecard_html,
    summary,
)
from selfsense.scorecard.scoring import score, scorecard

STACK = {"name": "stack_ds", "model": "stack", "twin": {}}
TWIN_INPUT = Band("twin input", "the twin is built with it", Tolerance(rel=2))
ON_TRUTH = Band("model on truth", "the model reads the twin so", Tolerance(rel=2), bias=TWIN_INPUT)

# Table 7.3's g on the thesis campaign: published (and built) 0.263115 µm/K, the model on truth at
# the thesis's order 0.2541, the captures' 0.253855
COEFFICIENTS = pd.DataFrame({"coefficient": ["g", "b0"], "Coefficients": [0.253855, -644.1]})
GAMMA_T_TRUTH = pd.DataFrame({"fit": ["thesis order"], "g [µm/K], all true": [0.2541]})
MODEL_RECOVERY = pd.DataFrame(
    {
        "parameter": ["C_P0", "alpha"],
        "truth": [3.13, 9.36],
        "model on truth": [3.1352, 9.6078],
        "identified mean": [3.1361, 9.625],
    }
)
TABLES = {
    "ch7/coef.csv": COEFFICIENTS,
    "twin/gamma_t_truth.csv": GAMMA_T_TRUTH,
    "twin/model_recovery.csv": MODEL_RECOVERY,
}


def entry(quantity="q", published=10.0, kind=EMERGENT, band=None, chapter="7", **kw):
    fields = dict(
        section="published",
        kind=kind,
        chapter=chapter,
        source="Table 9.9",
        model="stack",
        quantity=quantity,
        unit="µm/K",
        published=published,
        band=band or Band("a rule", "why", Tolerance(rel=10)),
    )
    return Entry(**(fields | kw))


def g_row(**kw):
    return entry(
        "g (temperature coefficient)",
        0.263115,
        kind="recovery",
        band=ON_TRUTH,
        locate=Locator("ch7/coef.csv", "Coefficients", (("coefficient", "g"),)),
        centre=Locator("twin/gamma_t_truth.csv", "g [µm/K], all true", (("fit", "thesis order"),)),
        **kw,
    )


def twin_rows():
    """The twin recovery rows of Chapter 4's Case 2, held to the model on truth and built with
    ``truth``."""
    return [
        entry(
            f"{p} vs truth",
            None,
            kind="recovery",
            band=ON_TRUTH,
            chapter="4",
            section=RECOVERY,
            truth="model on truth",
            built="truth",
            locate=Locator("twin/model_recovery.csv", "identified mean", (("parameter", p),)),
        )
        for p in ("C_P0", "alpha")
    ]


# --- the second verdict ---------------------------------------------------------------------------


def test_g_reads_within_its_chain_band_and_out_of_its_bias_band():
    s = score(g_row(), TABLES)
    assert s.verdict == WITHIN  # 0.253855 within ±2 % of the model on truth 0.2541
    assert s.band == pytest.approx((0.2541 * 0.98, 0.2541 * 1.02))
    assert s.bias is not None and s.bias.verdict == OUT  # 0.2541 is 3.4 % below the built 0.263
    assert s.bias.band == pytest.approx((0.263115 * 0.98, 0.263115 * 1.02))
    assert s.bias.centre == 0.2541 and s.bias.built == 0.263115
    assert s.bias.rule == "twin input, ±2 % of the built value"
    row = scorecard([g_row()], TABLES, STACK).iloc[0]
    assert row["verdict"] == WITHIN and row["bias verdict"] == OUT
    assert row["model on truth"] == 0.2541
    assert row["bias"] == pytest.approx(0.2541 - 0.263115)
    assert row["bias [%]"] == pytest.approx(100 * (0.2541 / 0.263115 - 1))
    assert (row["bias band low"], row["bias band high"]) == pytest.approx(
        (0.263115 * 0.98, 0.263115 * 1.02)
    )
    # the existing columns keep their meaning: the deviation is from the published value
    assert row["deviation"] == pytest.approx(0.253855 - 0.263115)
    assert (row["band low"], row["band high"]) == pytest.approx((0.2541 * 0.98, 0.2541 * 1.02))


def test_a_model_that_reads_the_twin_as_built_is_within_its_bias_band():
    twin = {"t.csv": pd.DataFrame({"p": ["C_P0"], "on truth": [3.1352], "got": [3.1361]})}
    row = entry(
        "C_P0",
        3.13,
        kind="recovery",
        band=ON_TRUTH,
        locate=Locator("t.csv", "got", (("p", "C_P0"),)),
        centre=Locator("t.csv", "on truth", (("p", "C_P0"),)),
    )
    s = score(row, twin)
    assert s.verdict == WITHIN and s.bias.verdict == WITHIN


def test_a_twin_recovery_row_holds_its_model_on_truth_to_the_built_column():
    card = scorecard(twin_rows(), TABLES, STACK)
    assert card["published"].tolist() == pytest.approx([3.1352, 9.6078])  # the model on truth
    assert card["verdict"].tolist() == [WITHIN, WITHIN]
    assert card["bias verdict"].tolist() == [WITHIN, OUT]  # α: 9.6078 is 2.6 % above 9.36
    assert card["model on truth"].tolist() == pytest.approx([3.1352, 9.6078])
    assert card["bias [%]"].tolist() == pytest.approx(
        [100 * (3.1352 / 3.13 - 1), 100 * (9.6078 / 9.36 - 1)]
    )


def test_rows_without_a_model_on_truth_have_empty_bias_columns():
    plain = entry(
        "plain", 0.25, locate=Locator("ch7/coef.csv", "Coefficients", (("coefficient", "g"),))
    )
    # a dataset the twin did not make: the centred row is held to the published value, no bias
    card = scorecard([plain, g_row()], {"ch7/coef.csv": COEFFICIENTS}, STACK)
    assert card["bias verdict"].tolist() == ["", ""]
    assert (
        card[["model on truth", "bias", "bias [%]", "bias band low", "bias band high"]]
        .isna()
        .all()
        .all()
    )
    assert card.loc[1, "verdict"] == OUT  # 0.2539 is 3.5 % below the published 0.263
    # a pending row has none either
    assert scorecard([replace(g_row(), locate=None)], {}, STACK)["bias verdict"].tolist() == [""]


def test_the_bias_columns_sit_between_the_verdict_and_where_the_value_was_read():
    assert COLUMNS[COLUMNS.index("verdict") + 1 : COLUMNS.index("read from")] == BIAS_COLUMNS


# --- counting -------------------------------------------------------------------------------------


def card():
    """Emergent, check and recovery rows, the recovery ones centred on the model on truth."""
    e = entry("e", 0.25, locate=Locator("ch7/coef.csv", "Coefficients", (("coefficient", "g"),)))
    c = entry(
        "c",
        1.0,
        kind=CHECK,
        bound="upper",
        band=Band("scatter", "idealised noise", Tolerance(abs=0), "upper"),
        locate=Locator("ch7/coef.csv", "Coefficients", (("coefficient", "g"),)),
    )
    return scorecard([e, c, g_row(), *twin_rows()], TABLES, STACK)


def test_check_is_a_kind_counted_apart_from_the_emergent_numbers():
    assert CHECK in KINDS and KINDS[0] == EMERGENT
    table = summary({"ds": card()})
    total = table[table["chapter"] == "total"].set_index("kind")
    assert total.loc[EMERGENT, "numbers"] == 1 and total.loc[CHECK, "numbers"] == 1
    assert total.loc[CHECK, WITHIN] == 1
    line = headline(table).split("\n\n")[0]
    assert (
        line.startswith("**ds**: emergent 1 within band of 1;")
        and "check 1 within band of 1" in line
    )


def test_recovery_rows_count_by_their_chain_and_the_bias_on_lines_of_its_own():
    table = summary({"ds": card()})
    total = table[table["chapter"] == "total"].set_index("kind")
    # the chain: all three recovery rows within their bands about the model on truth
    assert (total.loc["recovery", "numbers"], total.loc["recovery", WITHIN]) == (3, 3)
    # the model's bias: g and α out of ±2 % of the built value, C_P0 within
    assert total.loc[BIAS, ["numbers", "reproduced", WITHIN, OUT]].tolist() == [3, 3, 1, 2]
    by_chapter = table[(table["kind"] == BIAS) & (table["chapter"] != "total")]
    assert dict(zip(by_chapter["chapter"], by_chapter["numbers"])) == {"7": 1, "4": 2}
    (line,) = headline(table).split("\n\n")  # the bias last on the dataset's line
    assert line.endswith(f"; {BIAS} 1 within band of 3.")


def test_a_card_written_before_the_bias_columns_counts_as_before():
    old = card().drop(columns=BIAS_COLUMNS)
    table = summary({"ds": old})
    assert BIAS not in set(table["kind"])
    pd.testing.assert_frame_equal(table, summary({"ds": card()}).query("kind != @BIAS"))
    assert "within band" in landing_rst({"ds": old}) and scorecard_html(old, "t")


def test_the_readme_table_has_a_column_per_kind_present():
    markdown = counts_markdown(summary({"ds": card()}), "thesis")
    assert (
        "| dataset | chapter | emergent: within band / reproduced | recovery | check "
        f"| {BIAS} |" in markdown
    )
    assert (
        "|---|---|---|---|---|---|" in markdown
        and "| ds | **total** | 1 / 1 | 3 / 3 | 1 / 1 | 1 / 3 |" in markdown
    )


# --- renderings -----------------------------------------------------------------------------------


def test_the_out_of_band_page_lists_every_bias_out_of_band_as_valid_restructuredtext():
    page = out_of_band_rst({"ds": card()})
    assert "The model's bias out of band" in page
    body = docutils.core.publish_parts(
        page, writer="html", settings_overrides={"halt_level": 2, "report_level": 5}
    )["body"]
    assert "g (temperature coefficient)" in body and "alpha vs truth" in body
    assert "alpha vs truth: model on truth 9.6078 µm/K, built 9.36 µm/K (+2.6 %)" in body
    assert "C_P0 vs truth: model on truth" not in body  # within its bias band
    assert "twin input, ±2 % of the built value" in body
    landing = landing_rst({"ds": card()})
    docutils.core.publish_parts(landing, writer="html", settings_overrides={"halt_level": 2})


def test_the_html_page_shows_both_verdicts_each_coloured():
    page = html.unescape(scorecard_html(card(), "Scorecard: ds"))
    line = {
        q: text
        for q, text in re.findall(r'<span class="q">(.*?)</span>(.*?)</details>', page, re.S)
    }
    # the chain's verdict, then the model's bias beside it, each in its colour
    chain = '<span class="v within" title="within band">within band</span>'
    assert (
        f'{chain} <span class="v out" title="the model\'s bias: out of band">bias out</span>'
        in (line["g (temperature coefficient)"])
    )
    assert (
        f'{chain} <span class="v within" title="the model\'s bias: within band">bias within'
        in (line["C_P0 vs truth"])
    )
    assert "bias" not in re.sub(r"<dl>.*", "", line["e"])  # a row without a model on truth
    # folded: the model on truth against the built value, and its band
    assert (
        "<dt>model's bias</dt><dd>model on truth 9.6078 µm/K, built 9.36 µm/K (+2.6 %), bias band "
        "9.1728 … 9.5472 µm/K (twin input, ±2 % of the built value): out of band</dd>"
    ) in line["alpha vs truth"]
    # the headline's line of its own: 3 numbers, 1 within band of 3, 2 out of band
    bias_line = re.search(r"<tr><th>model's bias</th>(.*?)</tr>", page).group(1)
    assert re.sub(r"<[^>]+>", " ", bias_line).split() == ["3", "1", "/", "3", "2", "0", "0", "0"]


# --- the registry ---------------------------------------------------------------------------------


def registry(band, entries, **group):
    g = {
        "source": "Table 9.9",
        "chapter": "9",
        "model": "stack",
        "kind": "recovery",
        "unit": "V",
        "band": band,
        "entries": entries,
    }
    return {"groups": [g | group]}


RULE = {"name": "model on truth", "tolerance": {"rel": 2}, "justification": "why"}
BIAS_RULE = {"name": "twin input", "tolerance": {"rel": 2}, "justification": "built"}
CENTRED = {
    "quantity": "a",
    "published": 1,
    "locate": {"table": "t.csv", "column": "c"},
    "centre": {"table": "truth.csv", "column": "model on truth"},
}


def test_the_registry_reads_a_bias_rule_and_a_built_column():
    band = RULE | {"bias": BIAS_RULE}
    (e,) = parse_registry(registry(band, [CENTRED]), "reg.yaml")
    assert e.band.bias == Band("twin input", "built", Tolerance(rel=2))
    twin = registry(
        band,
        [{"quantity": "b", "published": {"truth": "model on truth", "built": "truth"}}],
        section="twin recovery",
        locate={"table": "t.csv", "column": "c"},
    )
    (t,) = parse_registry(twin, "reg.yaml")
    assert (t.truth, t.built, t.published) == ("model on truth", "truth", None)
    (c,) = parse_registry(
        registry(BIAS_RULE, [{"quantity": "c", "published": 1}], kind=CHECK), "r.yaml"
    )
    assert c.kind == CHECK


@pytest.mark.parametrize(
    "doc, message",
    [
        (registry(RULE, [CENTRED]), "needs a bias rule"),
        (
            registry(RULE | {"bias": BIAS_RULE}, [{"quantity": "a", "published": 1}]),
            "judges the model's bias",
        ),
        (
            registry(RULE | {"bias": BIAS_RULE | {"bound": "upper"}}, [CENTRED]),
            "needs a tolerance, two-sided",
        ),
        (
            registry(RULE | {"bias": {"name": "x", "justification": "y"}}, [CENTRED]),
            "needs a tolerance",
        ),
        (
            registry(
                RULE,
                [{"quantity": "a", "published": {"truth": "t", "built": "b", "x": "y"}}],
                section="twin recovery",
                locate={"table": "t.csv", "column": "c"},
            ),
            "published",
        ),
        (registry(BIAS_RULE, [{"quantity": "a", "published": 1}], kind="sort of check"), "kind"),
    ],
)
def test_the_registry_rejects_a_bias_without_its_model_on_truth_and_the_reverse(doc, message):
    with pytest.raises(ManifestError, match=message) as err:
        parse_registry(doc, "reg.yaml")
    assert str(err.value).startswith("reg.yaml") and "\n" not in str(err.value)
