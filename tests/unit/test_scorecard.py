"""The scorecard module and its registry: bands, verdicts, lookups, missing tables, the schema."""

import math
from dataclasses import replace

import docutils.core
import numpy as np
import pandas as pd
import pytest

from selfsense.io.manifest import ManifestError, load_yaml
from selfsense.scorecard.registry import (
    BUDGET_TABLE,
    INFORMATION,
    LEFT_OUT,
    MISSING,
    NOT_YET,
    OUT,
    RECOVERY,
    WITHIN,
    Band,
    Cause,
    Entry,
    Locator,
    RegistryError,
    Tolerance,
    applicable,
    last_digit,
    parse_registry,
    tables_read,
)
from selfsense.scorecard.render import landing_rst, out_of_band_rst, pending_rst, scorecard_html
from selfsense.scorecard.scoring import band, judge, lookup, score, scorecard

from ..helpers import ROOT

REGISTRY = ROOT / "workflow" / "scorecard.yaml"
STACK = {"name": "stack_ds", "model": "stack", "twin": {}}


def entry(
    published=10.0,
    tolerance=Tolerance(rel=10),
    bound=None,
    locate=None,
    kind="emergent",
    printed=None,
    **kw,
):
    fields = dict(
        section="published",
        kind=kind,
        chapter="3",
        source="Table 9.9",
        model="stack",
        quantity="q",
        unit="%",
        published=published,
        band=Band("a rule", "why", tolerance),
        bound=bound,
        locate=locate,
        printed=printed,
    )
    return Entry(**(fields | kw))


def limits(published, bound, tolerance, printed=None):
    return band(published, entry(published, tolerance, bound, printed=printed))


def group(**overrides):
    g = {
        "source": "Table 9.9",
        "chapter": "9",
        "model": "stack",
        "kind": "emergent",
        "unit": "V",
        "band": {"name": "b", "tolerance": {"abs": 1}, "justification": "why"},
        "entries": [{"quantity": "a", "published": 1}],
    }
    return {"groups": [g | overrides]}


TABLE = pd.DataFrame(
    {
        "ns": [4, 4, 12],
        "nf": [0, 2, 4],
        "fs [kHz]": [400.0, 80.0, 48.0],
        "loop": ["C_e–U", "C_e–x", "R–C"],
        "empty": [np.nan, 1.0, 2.0],
    }
)


# --- bands and verdicts ---------------------------------------------------------------------------


def test_band_of_a_value_is_symmetric_in_abs_or_percent():
    assert limits(10.0, None, Tolerance(abs=0.5)) == (9.5, 10.5)
    assert limits(-0.03, None, Tolerance(rel=2)) == pytest.approx((-0.0306, -0.0294))


def test_band_of_a_bound_is_open_on_one_side_and_widened_by_the_tolerance():
    assert limits(3.0, "upper", Tolerance(abs=0)) == (-math.inf, 3.0)
    assert limits(45.0, "lower", Tolerance(abs=5)) == (40.0, math.inf)


def test_a_log_band_goes_up_by_the_half_width_and_down_by_the_same_factor():
    lo, hi = limits(0.42, None, Tolerance(abs=0.6, scale="log"))
    assert hi == pytest.approx(1.02) and lo == pytest.approx(0.42 / (1.02 / 0.42)) and lo > 0
    assert limits(4.0, None, Tolerance(factor=2, scale="log")) == pytest.approx((2.0, 8.0))


def test_goodness_of_fit_is_compared_on_one_minus_r2_within_a_factor():
    lo, hi = limits(0.999, None, Tolerance(factor=2, scale="log1m"))
    assert (1 - hi, 1 - lo) == pytest.approx((0.0005, 0.002))


@pytest.mark.parametrize(
    "printed, unit",
    [
        ("400", 1),
        ("0.637", 1e-3),
        ("0.33", 1e-2),
        ("213.60", 1e-2),
        ("3.4e7", 1e6),
        ("6.0e-4", 1e-5),
        ("1.27", 1e-2),
    ],
)
def test_a_digit_tolerance_is_in_units_of_the_last_printed_digit(printed, unit):
    assert last_digit(printed) == pytest.approx(unit)
    assert limits(float(printed), None, Tolerance(digit=0.5), printed) == pytest.approx(
        (float(printed) - unit / 2, float(printed) + unit / 2)
    )


def test_an_information_row_is_read_but_gets_no_verdict():
    s = score(
        entry(tolerance=None, locate=Locator("t.csv", "fs [kHz]", (("ns", 12),))), {"t.csv": TABLE}
    )
    assert s.verdict == INFORMATION and s.reproduced == 48.0 and s.band == (-math.inf, math.inf)


def test_verdict_includes_the_band_edges_despite_float_round_trips():
    lo, hi = limits(0.33, None, Tolerance(abs=0.005))
    assert judge(0.335 + 1e-14, lo, hi) == WITHIN
    assert judge(0.3333, lo, hi) == WITHIN
    assert judge(0.336, lo, hi) == OUT
    assert judge(-1e9, -math.inf, 3.0) == WITHIN and judge(3.01, -math.inf, 3.0) == OUT


# --- locating the reproduced value ----------------------------------------------------------------


def test_lookup_selects_one_row_by_numbers_or_text_and_scales():
    assert lookup(Locator("t.csv", "fs [kHz]", (("ns", 4), ("nf", 2))), TABLE) == 80.0
    assert lookup(Locator("t.csv", "fs [kHz]", (("loop", "R–C"),), scale=1e3), TABLE) == 48000.0


@pytest.mark.parametrize(
    "locator, message",
    [
        (Locator("t.csv", "fs", (("ns", 4),)), "no column 'fs'"),
        (Locator("t.csv", "fs [kHz]", (("ns", 4),)), "2 rows"),
        (Locator("t.csv", "fs [kHz]", (("ns", 5),)), "0 rows"),
        (Locator("t.csv", "empty", (("nf", 0),)), "is empty"),
    ],
)
def test_lookup_says_what_is_wrong(locator, message):
    with pytest.raises(LookupError, match=message):
        lookup(locator, TABLE)


def test_an_entry_without_a_locator_or_whose_table_is_not_made_is_not_reproduced_yet():
    pending = score(entry(), {})
    assert (
        pending.verdict == NOT_YET and pending.reproduced is None and "no stage" in pending.detail
    )
    absent = score(entry(locate=Locator("ch9/t.csv", "fs [kHz]")), {})
    assert absent.verdict == NOT_YET and "ch9/t.csv is not made" in absent.detail


def test_a_broken_locator_on_an_existing_table_is_missing_not_silently_pending():
    broken = score(entry(locate=Locator("t.csv", "nope")), {"t.csv": TABLE})
    assert broken.verdict == MISSING and "no column 'nope'" in broken.detail
    gone = score(entry(locate=Locator("t.csv", "fs [kHz]", (("ns", 5),))), {"t.csv": TABLE})
    assert gone.verdict == MISSING and "0 rows" in gone.detail


def test_a_number_its_stage_left_out_is_not_reproduced_yet_with_the_stages_reason():
    empty = score(entry(locate=Locator("t.csv", "empty", (("nf", 0),))), {"t.csv": TABLE})
    assert empty.verdict == NOT_YET and empty.detail == LEFT_OUT + "t.csv [nf = 0] empty is empty"
    skipped = pd.DataFrame({"note": ["not computed: runs too short"]})
    noted = score(
        entry(locate=Locator("s.csv", "tau [s]", (("parameter", "tau"),))), {"s.csv": skipped}
    )
    assert (
        noted.verdict == NOT_YET
        and noted.detail == LEFT_OUT + "s.csv: not computed: runs too short"
    )


def test_within_and_out_of_band():
    here = Locator("t.csv", "fs [kHz]", (("ns", 12),))
    assert (
        score(entry(published=50, locate=here), {"t.csv": TABLE}).verdict == WITHIN
    )  # 48 vs 50 ± 5
    assert score(entry(published=40, locate=here), {"t.csv": TABLE}).verdict == OUT


def test_twin_recovery_reads_the_truth_from_the_located_row():
    e = entry(
        section=RECOVERY,
        published=None,
        truth="nf",
        unit="",
        tolerance=Tolerance(rel=2),
        locate=Locator("t.csv", "fs [kHz]", (("ns", 12),), scale=1 / 12),
    )
    s = score(e, {"t.csv": TABLE})
    assert (
        s.published == pytest.approx(4 / 12)
        and s.reproduced == pytest.approx(4.0)
        and s.verdict == OUT
    )
    pending = score(e, {})
    assert math.isnan(pending.published) and pending.verdict == NOT_YET


def test_a_centre_moves_the_band_to_the_model_on_truth_and_the_deviation_stays_from_the_published():
    # the located value 48 is 4 % off the published 50 but within 2 % of the model on truth, 48.5
    centre = Locator("truth.csv", "model on truth", (("p", "a"),))
    e = entry(
        published=50.0,
        kind="recovery",
        tolerance=Tolerance(rel=2),
        locate=Locator("t.csv", "fs [kHz]", (("ns", 12),)),
        centre=centre,
    )
    truth = pd.DataFrame({"p": ["a", "b"], "model on truth": [48.5, 99.0]})
    s = score(e, {"t.csv": TABLE, "truth.csv": truth})
    assert (
        s.band == pytest.approx((48.5 * 0.98, 48.5 * 1.02))
        and s.verdict == WITHIN
        and s.published == 50.0
    )
    assert "48.5" in s.detail and "truth.csv" in s.detail
    assert "truth.csv" in tables_read([e])
    # a dataset the twin did not make has no truth: the band is the published value's
    alone = score(e, {"t.csv": TABLE})
    assert alone.band == pytest.approx((49.0, 51.0)) and alone.verdict == OUT and not alone.detail
    # a centre that selects no row is a locator to fix
    assert (
        score(
            replace(e, centre=Locator("truth.csv", "model on truth", (("p", "z"),))),
            {"t.csv": TABLE, "truth.csv": truth},
        ).verdict
        == MISSING
    )


# --- the table ------------------------------------------------------------------------------------


def test_scorecard_keeps_every_applicable_entry_in_order_and_computes_deviations():
    entries = [
        entry(quantity="a", published=50, locate=Locator("t.csv", "fs [kHz]", (("ns", 12),))),
        entry(quantity="b"),
        entry(quantity="c", model="bender"),
        entry(
            quantity="d",
            published=0.0,
            tolerance=Tolerance(abs=0),
            locate=Locator("t.csv", "nf", (("ns", 12),)),
        ),
        entry(quantity="e", section=RECOVERY),
    ]
    card = scorecard(entries, {"t.csv": TABLE}, {"model": "stack"})  # no twin: no recovery rows
    assert card["quantity"].tolist() == ["a", "b", "d"]
    assert card["verdict"].tolist() == [WITHIN, NOT_YET, OUT]
    a = card.iloc[0]
    assert (
        a["deviation"] == -2
        and a["deviation [%]"] == -4
        and (a["band low"], a["band high"]) == (45, 55)
    )
    assert np.isnan(card.iloc[2]["deviation [%]"])  # published 0: no percentage
    assert card.iloc[0]["read from"] == "t.csv [ns = 12] fs [kHz]"


def test_the_tolerance_column_says_how_the_band_was_made():
    entries = [
        entry(quantity="a", tolerance=Tolerance(abs=0.5)),
        entry(quantity="b"),
        entry(quantity="c", bound="upper", tolerance=Tolerance(abs=0)),
        entry(quantity="d", published=0.33, bound="lower", tolerance=Tolerance(abs=0.28)),
    ]
    card = scorecard(entries, {}, STACK)
    assert card["tolerance"].tolist() == ["±0.5 %", "±10 %", "≤ published", "≥ published − 0.28"]
    assert card["kind"].tolist() == ["emergent"] * 4 and card["band"].tolist() == ["a rule"] * 4
    assert card.loc[3, "band low"] == pytest.approx(0.05) and np.isnan(card.loc[3, "band high"])


def test_applicable_filters_by_actuator_and_twin():
    es = [
        entry(quantity="a"),
        entry(quantity="b", model="bender"),
        entry(quantity="c", section=RECOVERY),
    ]
    assert [e.quantity for e in applicable(es, STACK)] == ["a", "c"]
    assert [e.quantity for e in applicable(es, {"model": "bender"})] == ["b"]


# --- the registry and its schema ------------------------------------------------------------------


@pytest.fixture(scope="module")
def registry():
    return parse_registry(load_yaml(REGISTRY), str(REGISTRY))


# number of published numbers per source table of docs/sources.md: guards against entries lost in
# edits
EXPECTED = {
    ("stack", "Table 3.1"): 10,
    ("stack", "Table 3.2"): 12,
    ("stack", "Table 4.2"): 11,
    ("stack", "Table 4.3"): 20,
    ("stack", "Table 5.1"): 14,
    ("stack", "Table 5.2"): 22,
    ("stack", "Table 5.3"): 3,
    ("stack", "Table 5.4"): 18,
    ("stack", "Table 6.1"): 72,
    ("stack", "Table 6.2"): 34,
    ("stack", "Table 7.1"): 4,
    ("stack", "Table 7.2"): 13,
    ("stack", "Table 7.3"): 23,
    ("bender", "Ronkanen, Table 1"): 2,
    ("bender", "Ronkanen, Table 2"): 5,
}


def test_the_registry_declares_its_algebraic_twins(registry):
    """Every % of stroke row beside a µm row of its source, and every adjusted R² beside its R², is
    declared its twin (the envelope counts each pair once)."""
    twins = {(e.source, e.quantity): e.twin for e in registry if e.twin}
    quantities = {(e.source, e.quantity) for e in registry}
    assert twins[("Table 6.2", "P2a, ε_OCL, % of stroke")] == "P2a, ε_OCL"
    assert twins[("Table 5.1", "Γ order 5, adjusted R²")] == "Γ order 5, R²"
    for source, quantity in quantities:
        if "adjusted R²" in quantity:
            assert (source, quantity) in twins, quantity
    assert len(twins) == 34


def test_the_registry_lists_every_published_table(registry):
    found = pd.Series([(e.model, e.source) for e in registry]).value_counts().to_dict()
    assert {k: found.get(k, 0) for k in EXPECTED} == EXPECTED
    assert {e.chapter for e in registry} == {"3", "4", "5", "6", "7", "Ronkanen"}


def test_every_registry_table_is_a_relative_csv_and_every_band_has_a_reason(registry):
    assert all(not t.startswith(("/", "..")) and t.endswith(".csv") for t in tables_read(registry))
    assert all(e.band.justification.strip() and e.band.name.strip() for e in registry)


def test_group_and_entry_locators_merge():
    doc = group(
        locate={"table": "ch9/t.csv", "column": "fs [kHz]"},
        entries=[
            {"quantity": "a", "published": 1, "locate": {"where": {"ns": 4}}},
            {"quantity": "b", "published": 1, "locate": {"column": "nf", "where": {"ns": 4}}},
        ],
    )
    a, b = parse_registry(doc)
    assert a.locate == Locator("ch9/t.csv", "fs [kHz]", (("ns", 4),))
    assert b.locate.column == "nf"


def test_a_cause_names_the_largest_sources_the_error_budget_measured_at_the_errors_max():
    """Group and entry causes merge as locators do; the note reads the budget row they select, and
    only where the budget is made (the twin's datasets): a measured dataset keeps its verdict."""
    doc = group(
        locate={"table": "ch9/t.csv", "column": "fs [kHz]", "where": {"ns": 12}},
        cause={"where": {"run": "p1"}},
        entries=[{"quantity": "a", "published": 48, "cause": {"where": {"segment": "b"}}}],
    )
    (e,) = parse_registry(doc)
    assert e.cause == Cause(BUDGET_TABLE, (("run", "p1"), ("segment", "b"))) and tables_read(
        [e]
    ) == ["ch9/t.csv", BUDGET_TABLE]
    budget = pd.DataFrame(
        {
            "run": ["p1", "p1", "p2"],
            "segment": ["a", "b", np.nan],
            "total at max [µm]": [1.0, -1.9, 2.0],
            "laser at total max [µm]": [0.1, -0.2, 0.0],
            "C_e estimate at total max [µm]": [0.5, -1.5, 1.0],
            "q–x map at total max [µm]": [0.4, 0.3, 1.0],
            "Γ map at total max [µm]": [0.0, -0.5, 0.0],
        }
    )
    s = score(e, {"ch9/t.csv": TABLE, BUDGET_TABLE: budget})
    assert s.verdict == WITHIN
    assert s.cause == (
        f"Measured cause ({BUDGET_TABLE}, run = p1, segment = b): at the observer error's max, "
        "-1.90 µm, its largest sources are C_e estimate -1.50, Γ map -0.50, q–x map +0.30 µm"
    )
    assert (
        s.cause in scorecard([e], {"ch9/t.csv": TABLE, BUDGET_TABLE: budget}, STACK).iloc[0]["note"]
    )
    assert (
        score(e, {"ch9/t.csv": TABLE}).cause == ""
        and score(e, {"ch9/t.csv": TABLE}).verdict == WITHIN
    )
    with pytest.raises(
        LookupError, match="0 rows of twin/error_budget.csv match run = p1, segment = b"
    ):
        score(e, {"ch9/t.csv": TABLE, BUDGET_TABLE: budget[budget["segment"] != "b"]})


def test_a_cause_can_select_its_row_by_the_entrys_located_row():
    """P1's summary names the segment it is stated at: the cause is read at that segment, whichever
    it is, and a located column the entry's table lacks is a locator to fix, said in one line."""
    doc = group(
        locate={"table": "ch9/t.csv", "column": "fs [kHz]", "where": {"ns": 12}},
        entries=[
            {
                "quantity": "q",
                "published": 48,
                "cause": {"table": "ch9/u.csv", "where": {}, "quote": ["v"], "located": ["loop"]},
            }
        ],
    )
    (entry,) = parse_registry(doc)
    other = pd.DataFrame({"loop": ["C_e–x", "R–C"], "v": [1.0, 2.0]})
    assert (
        score(entry, {"ch9/t.csv": TABLE, "ch9/u.csv": other}).cause
        == "Measured (ch9/u.csv, loop = R–C): v = 2"
    )
    moved = TABLE.assign(loop=["C_e–U", "R–C", "C_e–x"])
    assert (
        score(entry, {"ch9/t.csv": moved, "ch9/u.csv": other}).cause
        == "Measured (ch9/u.csv, loop = C_e–x): v = 1"
    )
    with pytest.raises(
        LookupError, match="ch9/t.csv has no column 'loop' to select the cause's row by"
    ):
        score(entry, {"ch9/t.csv": TABLE.drop(columns="loop"), "ch9/u.csv": other})


def test_a_cause_reads_the_spread_over_tests_or_quotes_another_tables_columns():
    """statistic σ names the sources with the largest spread over P1's tests; a quoting cause
    names any table's columns, and a cause that neither quotes nor names a budget is an error."""
    doc = group(
        locate={"table": "ch9/t.csv", "column": "fs [kHz]", "where": {"ns": 12}},
        entries=[
            {
                "quantity": "σ",
                "published": 48,
                "cause": {
                    "table": "twin/tracking_budget.csv",
                    "where": {"segment": "b"},
                    "statistic": "σ",
                },
            },
            {
                "quantity": "q",
                "published": 48,
                "cause": {"table": "ch9/t.csv", "where": {"ns": 12}, "quote": ["nf", "fs [kHz]"]},
            },
        ],
    )
    sigma, quoted = parse_registry(doc)
    budget = pd.DataFrame(
        {
            "segment": ["b"],
            "total max σ over tests [µm]": [0.0731],
            "laser at max σ over tests [µm]": [0.05],
            "creep at max σ over tests [µm]": [0.002],
            "hysteresis at max σ over tests [µm]": [0.061],
            "total at max [µm]": [3.0],
            "σ over tests of the signed error at max [µm]": [0.07],
        }
    )
    assert score(sigma, {"ch9/t.csv": TABLE, "twin/tracking_budget.csv": budget}).cause == (
        "Measured cause (twin/tracking_budget.csv, segment = b): σ over the tests of the tracking "
        "error's max, 0.073 µm; the σ of its largest sources at each test's max are hysteresis "
        "0.061, laser 0.050, creep 0.002 µm"
    )
    assert (
        score(quoted, {"ch9/t.csv": TABLE}).cause
        == "Measured (ch9/t.csv, ns = 12): nf = 4, fs [kHz] = 48"
    )
    # a count is quoted whole, anything else to 4 significant digits
    counts = TABLE.assign(nf=[0, 2, 19999], **{"fs [kHz]": [400.0, 80.0, 47.98765]})
    assert (
        score(quoted, {"ch9/t.csv": counts}).cause
        == "Measured (ch9/t.csv, ns = 12): nf = 19999, fs [kHz] = 47.99"
    )
    assert tables_read([quoted]) == ["ch9/t.csv"]
    with pytest.raises(RegistryError, match="cause table 'ch9/t.csv' is none of"):
        parse_registry(
            group(
                entries=[
                    {"quantity": "a", "published": 1, "cause": {"table": "ch9/t.csv", "where": {}}}
                ]
            )
        )


@pytest.mark.parametrize(
    "doc, message",
    [
        (group(colour="red"), "unknown key|colour"),
        ({"groups": [{k: v for k, v in group()["groups"][0].items() if k != "kind"}]}, "kind"),
        (group(kind="sort of"), "kind"),
        (group(band={"name": "b", "tolerance": {"abs": 1}}), "justification"),
        (
            group(band={"name": "b", "tolerance": {"factor": 2}, "justification": "why"}),
            "factor needs scale",
        ),
        (
            group(
                band={"name": "b", "tolerance": {"abs": 1, "scale": "log"}, "justification": "why"},
                entries=[{"quantity": "a", "published": 0}],
            ),
            "log scale, which needs a positive value",
        ),
        (group(entries=[{"quantity": "a", "published": "ten"}]), "published"),
        (
            group(band={"name": "b", "tolerance": {"abs": 1, "rel": 2}, "justification": "why"}),
            "tolerance",
        ),
        (group(locate={"table": "/etc/passwd.csv", "column": "x"}), "table"),
        (group(locate={"where": {"ns": 4}}), "both table and column"),
        (group(cause={"run": "p1"}), "cause"),
        (
            group(entries=[{"quantity": "a", "published": 1}, {"quantity": "a", "published": 2}]),
            "listed twice",
        ),
        (
            group(entries=[{"quantity": "a", "published": {"truth": "truth"}}]),
            "twin recovery and a locate",
        ),
        (
            group(
                section="twin recovery",
                entries=[{"quantity": "a", "published": {"truth": "truth"}}],
            ),
            "and a locate",
        ),
        (
            group(
                entries=[
                    {"quantity": "a", "published": 1, "centre": {"table": "t.csv", "column": "c"}}
                ]
            ),
            "a centre is for a published recovery number",
        ),
        (
            group(
                kind="recovery",
                entries=[{"quantity": "a", "published": 1, "centre": {"table": "t.csv"}}],
            ),
            "column",
        ),
        (group(entries=[{"quantity": "a", "published": 1, "twin": "b"}]), "twin 'b' is no entry"),
        (
            group(entries=[{"quantity": "a", "published": 1, "twin": "a"}]),
            "twin 'a' must be another entry",
        ),
        (
            group(
                entries=[
                    {"quantity": "a", "published": 1},
                    {"quantity": "b", "published": 1, "twin": "a"},
                    {"quantity": "c", "published": 1, "twin": "b"},
                ]
            ),
            "twin 'b' must be another entry of the same kind that names no twin itself",
        ),
    ],
)
def test_the_registry_schema_and_rules_reject_bad_entries_in_one_line(doc, message):
    with pytest.raises(ManifestError, match=message) as err:
        parse_registry(doc, "reg.yaml")
    assert str(err.value).startswith("reg.yaml") and "\n" not in str(err.value)


# --- renderings -----------------------------------------------------------------------------------


def test_summary_is_valid_restructuredtext_naming_what_is_out_and_why():
    entries = [
        entry(quantity="a", published=50, locate=Locator("t.csv", "fs [kHz]", (("ns", 12),))),
        entry(
            quantity="b*c|d_",
            published=40,
            note="twin_choice `x`",
            locate=Locator("t.csv", "fs [kHz]", (("ns", 12),)),
        ),
        entry(quantity="e", published=40, locate=Locator("t.csv", "fs [kHz]", (("ns", 12),))),
        entry(quantity="c", chapter="Ronkanen"),
    ]
    card = scorecard(entries, {"t.csv": TABLE}, STACK)
    pages = [render({"stack_ds": card}) for render in (landing_rst, out_of_band_rst, pending_rst)]
    text = "\n".join(pages)
    assert "emergent 1 within band of 3 (1 not reproduced yet)" in text
    assert "(0 of 2 with a measured cause; 1 without a note" in text
    entries[2] = replace(entries[2], cause=Cause("t.csv", (("ns", 12),), quote=("nf",)))
    assert "(1 of 2 with a measured cause)" in out_of_band_rst(
        {"stack_ds": scorecard(entries, {"t.csv": TABLE}, STACK)}
    )
    html = "".join(
        docutils.core.publish_parts(
            page, writer="html", settings_overrides={"halt_level": 2, "report_level": 5}
        )["body"]
        for page in pages
    )
    assert "b*c|d_" in html and "twin_choice `x`" in html and "Ronkanen: Table 9.9 (1)" in html


def test_html_page_escapes_and_colours_by_verdict():
    card = scorecard(
        [entry(quantity="<x>", published=50, locate=Locator("t.csv", "fs [kHz]", (("ns", 12),)))],
        {"t.csv": TABLE},
        STACK,
    )
    page = scorecard_html(card, "Scorecard: stack_ds")
    assert '<span class="q">&lt;x&gt;</span>' in page and "<x>" not in page
    assert '<span class="v within" title="within band">within band</span>' in page
