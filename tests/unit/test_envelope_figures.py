"""The envelope's reviewer figures: deviations from the published value (with the axis' clipping),
the per-table ranking of drivers, and both figures written for a small card and for an envelope
without a Morris screening."""

import math

import numpy as np
import pandas as pd
import pytest
from matplotlib import cbook
from matplotlib.image import imread

from selfsense.envelope.figures import (
    EMPTY_SENSITIVITY,
    beyond,
    cut,
    deviation,
    deviations,
    drivers,
    forest,
    forest_figure,
    label,
    plain,
    plt,
    tornado,
    tornado_figure,
)
from selfsense.envelope.verdicts import COLUMNS as ENVELOPE_COLUMNS
from selfsense.envelope.verdicts import NOMINAL_COLUMNS

NAN = math.nan
# the envelope scorecard's columns, as selfsense.envelope.verdicts writes them (verdict aside)
COLUMNS = [c for c in NOMINAL_COLUMNS if c != "verdict"] + ENVELOPE_COLUMNS


def _card() -> pd.DataFrame:
    rows = [
        # chapter, source, quantity, unit, published, reproduced, members, p2.5, p50, p97.5,
        # half-width, width / band, verdict, distance, on the edge, twin of, driven by
        ("6", "Table 6.1", "C_e", "uF", 10.0, 10.2, 12, 9.0, 10.5, 12.0, 15.0, 0.5, "consistent",
         NAN, False, "", "geometry"),
        ("6", "Table 6.1", "ripple $U_0$ amplitude", "V", 4.0, 20.0, 12, 5.0, 6.0, 7.0, 12.0, 0.4,
         "inconsistent", 2.5, True, "", "drive"),
        ("6", "Table 6.2", "offset", "V", 0.0, 0.1, 12, -0.1, 0.0, 0.1, NAN, 0.2, "consistent",
         NAN, False, "", ""),
        ("3", "Table 3.1", "loss", "W", -4.0, -9.0, 2, NAN, NAN, NAN, NAN, NAN, "no envelope",
         NAN, NAN, "", ""),
        ("Ronkanen", "Fig 5", "stroke", "um", 50.0, NAN, 12, 0.0, 50.0, 400.0, 400.0, 8.0,
         "consistent (uninformative)", NAN, False, "", "stiffness"),
    ]  # fmt: skip
    return pd.DataFrame(rows, columns=COLUMNS)


def _sensitivity() -> pd.DataFrame:
    rows = [
        # source, quantity, factor, mu_star, sigma, mu_star [%]
        ("Table 6.1", "C_e", "geometry", 1.0, 0.1, 10.0),
        ("Table 6.1", "ripple $U_0$ amplitude", "geometry", 2.0, 0.2, 20.0),
        ("Table 6.1", "C_e", "drive", 3.0, 0.3, NAN),
        ("Table 6.1", "ripple $U_0$ amplitude", "drive", 0.4, 0.1, 4.0),
        ("Table 6.1", "C_e", "wiring", 3.0, 0.3, 30.0),
        ("Table 6.1", "ripple $U_0$ amplitude", "wiring", 0.2, 0.1, 2.0),
        ("Table 6.2", "offset", "drive", 0.5, 0.1, NAN),
        ("Table 6.2", "offset", "geometry", 0.5, 0.1, NAN),
        ("Fig 5", "stroke", "stiffness", 5.0, 1.0, 10.0),
        ("Fig 5", "stroke", "drive", 1.0, 1.0, 2.0),
    ]
    return pd.DataFrame(
        rows, columns=["source", "quantity", "factor", "mu_star", "sigma", "mu_star [%]"]
    )


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


# --- deviations ---------------------------------------------------------------------------------


def test_deviation_is_relative_to_the_published_magnitude():
    got = deviation([9.0, 12.0, -8.0, -2.0, NAN], [10.0, 10.0, -4.0, -4.0, 3.0])
    np.testing.assert_allclose(got[:4], [-10.0, 20.0, -100.0, 50.0])
    assert np.isnan(got[4])


def test_beyond_marks_values_off_either_edge_and_leaves_nan_on_the_axis():
    got = beyond([-100.0, -100.5, 200.0, 200.5, NAN, 0.0])
    assert got.tolist() == [0, -1, 0, 1, 0, 0]


def test_deviations_of_a_card():
    card = _card()
    dev = deviations(card)
    # the published 0 (index 2) is left out; the others keep the card's index and order
    assert dev.index.tolist() == [0, 1, 3, 4]
    assert dev["chapter"].tolist() == ["6", "6", "3", "Ronkanen"]
    np.testing.assert_allclose(dev.loc[0, ["p2.5 [%]", "p50 [%]", "p97.5 [%]"]], [-10, 5, 20])
    assert dev.loc[0, "reproduced [%]"] == pytest.approx(2.0)
    # published 4, nominal 20: +400 %, right of the axis; envelope 5..7: +25..+75 %
    assert dev.loc[1, "reproduced [%]"] == pytest.approx(400.0)
    assert dev.loc[1, "reproduced beyond"] == 1
    np.testing.assert_allclose(dev.loc[1, ["p2.5 [%]", "p97.5 [%]"]], [25.0, 75.0])
    assert dev.loc[1, ["p2.5 beyond", "p50 beyond", "p97.5 beyond"]].tolist() == [0, 0, 0]
    # published −4, nominal −9: −125 %, left of the axis; no envelope: NaN, not beyond
    assert dev.loc[3, "reproduced [%]"] == pytest.approx(-125.0)
    assert dev.loc[3, "reproduced beyond"] == -1
    assert dev.loc[3, ["p2.5 [%]", "p50 [%]", "p97.5 [%]"]].isna().all()
    assert dev.loc[3, ["p2.5 beyond", "p50 beyond", "p97.5 beyond"]].tolist() == [0, 0, 0]
    # published 50, envelope 0..400: −100 % (on the edge) .. +700 % (beyond); nominal NaN
    assert dev.loc[4, "p2.5 [%]"] == pytest.approx(-100.0)
    assert dev.loc[4, "p97.5 [%]"] == pytest.approx(700.0)
    assert dev.loc[4, ["p2.5 beyond", "p97.5 beyond", "reproduced beyond"]].tolist() == [0, 1, 0]
    assert np.isnan(dev.loc[4, "reproduced [%]"])


def test_labels_are_cut_and_dollars_printed_literally():
    assert label("Table 6.1", "C_e") == "Table 6.1 · C_e"
    long = label("Table 6.1", "x" * 100)
    assert len(long) == 60 and long.endswith("…") and long.startswith("Table 6.1 · xxx")
    assert cut("abcdef", 4) == "abc…" and cut("abcd", 4) == "abcd"
    text = plain("ripple $U_0$ amplitude")
    assert text == r"ripple \$U_0\$ amplitude"
    assert not cbook.is_math_text(text)


# --- drivers ------------------------------------------------------------------------------------


def test_drivers_rank_factors_per_table_by_mean_relative_mu_star():
    card = _card()
    got = drivers(_sensitivity(), card, top=2)
    # tables in the card's order; Table 6.2 has only NaN μ* [%] (published 0): no drivers
    assert got["source"].unique().tolist() == ["Table 6.1", "Fig 5"]
    t61 = got[got["source"] == "Table 6.1"]
    # wiring (30 + 2)/2 = 16, geometry (10 + 20)/2 = 15, drive 4 (its NaN ignored): top 2
    assert t61["factor"].tolist() == ["wiring", "geometry"]
    np.testing.assert_allclose(t61["mu_star [%]"], [16.0, 15.0])
    assert t61["rows"].tolist() == [2, 2] and t61["rank"].tolist() == [1, 2]
    fig5 = got[got["source"] == "Fig 5"]
    assert fig5["factor"].tolist() == ["stiffness", "drive"]
    np.testing.assert_allclose(fig5["mu_star [%]"], [10.0, 2.0])


def test_drivers_keep_a_nan_row_out_of_the_mean_and_count():
    got = drivers(_sensitivity(), _card(), top=8)
    drive = got[(got["source"] == "Table 6.1") & (got["factor"] == "drive")]
    assert drive["mu_star [%]"].tolist() == [4.0] and drive["rows"].tolist() == [1]
    assert drive["rank"].tolist() == [3]


def test_drivers_of_an_empty_sensitivity():
    got = drivers(pd.DataFrame(), _card())
    assert got.empty and "factor" in got.columns


# --- figures ------------------------------------------------------------------------------------


def test_forest_panels_per_chapter_in_reading_order_with_every_row_labelled():
    fig = forest(_card(), "envelope of pi_p885")
    axes = fig.axes
    assert len(axes) == 3
    assert axes[0].get_title(loc="left").startswith("Chapter 3: 1 number (1 no envelope)")
    assert (
        axes[1]
        .get_title(loc="left")
        .startswith("Chapter 6: 2 numbers (1 consistent, 1 inconsistent)")
    )
    assert axes[2].get_title(loc="left").startswith("Ronkanen")
    labels = [t.get_text() for t in axes[1].get_yticklabels()]
    assert labels == ["Table 6.1 · C_e", r"Table 6.1 · ripple \$U_0\$ amplitude"]
    assert not any(cbook.is_math_text(t) for t in labels)
    # the no-envelope row has no bar but still its label
    assert [t.get_text() for t in axes[0].get_yticklabels()] == ["Table 3.1 · loss"]
    assert len(axes[0].patches) == 0 and len(axes[1].patches) == 2
    # the inconsistent row's bar spans +25..+75 %; the x axis ends at the clip edges' margin
    bar = axes[1].patches[1]
    assert bar.get_x() == pytest.approx(25.0) and bar.get_width() == pytest.approx(50.0)
    # its verdict is on the edge: hatched, the consistent row's bar not
    assert bar.get_hatch() == "////" and axes[1].patches[0].get_hatch() is None
    lo, hi = axes[2].get_xlim()
    assert lo == pytest.approx(-112.0) and hi == pytest.approx(212.0)
    # the Ronkanen envelope's upper end (+700 %) is drawn at the 200 % edge
    assert axes[2].patches[0].get_x() + axes[2].patches[0].get_width() == pytest.approx(200.0)
    assert "4 numbers published; 1 with published 0 not drawn" in fig.get_suptitle()


def _png(path):
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return imread(path)


def test_forest_figure_writes_a_png_that_grows_with_rows(tmp_path):
    card = _card()
    forest_figure(card, tmp_path / "forest.png", "envelope")
    big = pd.concat([card] * 20, ignore_index=True)
    forest_figure(big, tmp_path / "forest_big.png", "envelope")
    small, large = _png(tmp_path / "forest.png"), _png(tmp_path / "forest_big.png")
    assert small.shape[0] > 100 and small.std() > 0  # not a blank canvas
    assert large.shape[0] > 2 * small.shape[0]
    assert (tmp_path / "forest.pdf").stat().st_size > 0
    assert (tmp_path / "forest.png.json").exists()
    assert not plt.get_fignums()  # saved figures are closed
    # figures.pdf false: the PNG alone, and the PDF of an earlier run is gone
    forest_figure(card, tmp_path / "forest.png", "envelope", pdf=False)
    assert (tmp_path / "forest.png").exists() and not (tmp_path / "forest.pdf").exists()


def test_tornado_panels_per_table_largest_on_top():
    fig = tornado(_sensitivity(), _card(), "drivers", top=2)
    shown = [ax for ax in fig.axes if ax.get_visible() and ax.axison]
    titles = [ax.get_title() for ax in shown]
    assert titles == [
        "Table 6.1 (ch. 6 · 2 numbers)",
        "Table 6.2 (ch. 6 · 1 number)",
        "Fig 5 (ch. Ronkanen · 1 number)",
    ]
    t61 = shown[0]
    assert [t.get_text() for t in t61.get_yticklabels()] == ["wiring", "geometry"]
    assert [p.get_width() for p in t61.patches] == pytest.approx([16.0, 15.0])
    assert t61.get_ylim()[0] > t61.get_ylim()[1]  # inverted: rank 1 on top
    assert not shown[1].patches  # no relative μ*: a note, no bars
    assert "no relative" in shown[1].texts[0].get_text()


def test_tornado_figure_writes_a_png(tmp_path):
    tornado_figure(_sensitivity(), _card(), tmp_path / "tornado.png", "drivers")
    image = _png(tmp_path / "tornado.png")
    assert image.shape[0] > 100 and image.std() > 0


def test_tornado_of_an_empty_sensitivity_says_why(tmp_path):
    empty = pd.DataFrame(columns=["source", "quantity", "factor", "mu_star", "sigma"])
    fig = tornado(empty, _card(), "drivers")
    assert len(fig.axes) == 1
    assert [t.get_text() for t in fig.axes[0].texts] == [EMPTY_SENSITIVITY]
    tornado_figure(empty, _card(), tmp_path / "tornado.png", "drivers")
    assert _png(tmp_path / "tornado.png").std() > 0
    tornado_figure(pd.DataFrame(), _card(), tmp_path / "bare.png", "drivers")
    assert (tmp_path / "bare.png").stat().st_size > 0


def test_forest_of_a_card_with_only_published_zero(tmp_path):
    card = _card().iloc[[2]]
    fig = forest(card, "envelope")
    assert len(fig.axes) == 1 and "nothing to compare" in fig.axes[0].texts[0].get_text()
    forest_figure(card, tmp_path / "zero.png", "envelope")
    assert _png(tmp_path / "zero.png").std() > 0
